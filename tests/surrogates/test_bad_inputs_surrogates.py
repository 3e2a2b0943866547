"""Bad inputs to ``surrogates``: one row per input, each asserting the error type and that the
message names the field, file or line (issue 9 items 2, 3, 5, 6, 8, 9, 10)."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from surrogates import Kriging, LegendreRegression, build, io
from surrogates.cli import main
from surrogates.models.checks import ModelFieldError

RNG = np.random.default_rng(3)
U2 = RNG.uniform(-1.0, 1.0, (40, 2)) * [0.03, 0.3]
V2 = 4e5 * U2[:, 0] + 3e4 * U2[:, 1] + 1e8 * U2[:, 0] ** 3
LPR_DOC = io.model_to_document(LegendreRegression(degree=(3, 2)).fit(U2, V2))
KRG_DOC = io.model_to_document(Kriging(n_starts=1).fit(U2[:12], V2[:12]))
U3 = RNG.uniform(-1.0, 1.0, (60, 3)) * [0.03, 0.3, 0.01]
MAXWELL_DOC = io.model_to_document(
    LegendreRegression(degree=1).fit(U3, 4e5 * U3[:, 0] + 3e4 * U3[:, 2]), form="maxwell", tau=0.01
)
#: LS-DYNA ASCII samples of the readers
DATA = Path(__file__).resolve().parents[1] / "data"

Mutation = Callable[[dict[str, Any]], Any]


def _set(path: str, value: Any) -> Mutation:
    """Mutation setting ``doc[a][b]...`` (``path`` "a.b.c", integer parts index lists)."""

    def mutate(doc: dict[str, Any]) -> None:
        *head, last = path.split(".")
        node: Any = doc
        for key in head:
            node = node[int(key)] if isinstance(node, list) else node[key]
        if isinstance(node, list):
            node[int(last)] = value
        else:
            node[last] = value

    return mutate


def _drop(path: str) -> Mutation:
    def mutate(doc: dict[str, Any]) -> None:
        *head, last = path.split(".")
        node: Any = doc
        for key in head:
            node = node[key]
        del node[last]

    return mutate


def _swap_domain(doc: dict[str, Any]) -> None:
    dom = doc["model"]["domain"]
    dom["lower"], dom["upper"] = dom["upper"], dom["lower"]


def _equal_domain(doc: dict[str, Any]) -> None:
    doc["model"]["domain"]["lower"][1] = doc["model"]["domain"]["upper"][1]


def _drop_exponent_row(doc: dict[str, Any]) -> None:
    doc["model"]["state"]["exponents"].pop()


def _drop_coefficient(doc: dict[str, Any]) -> None:
    doc["model"]["state"]["coef"].pop()


# (row id, base document, mutation, text the message must contain)
DOC_ROWS: list[tuple[str, dict[str, Any], Mutation, str]] = [
    ("lpr-domain-swapped", LPR_DOC, _swap_domain, "model.domain column 0"),
    ("lpr-domain-equal", LPR_DOC, _equal_domain, "model.domain column 1"),
    (
        "lpr-domain-overflow",
        LPR_DOC,
        _set("model.domain", {"lower": [-1.7e308, -1.0], "upper": [1.7e308, 1.0]}),
        "overflows",
    ),
    ("lpr-domain-nan", LPR_DOC, _set("model.domain.lower", [math.nan, 0.0]), "domain.lower"),
    ("lpr-domain-inf", LPR_DOC, _set("model.domain.upper", [math.inf, 1.0]), "domain.upper"),
    ("lpr-domain-string", LPR_DOC, _set("model.domain.lower", "abc"), "model.domain.lower"),
    ("lpr-domain-length", LPR_DOC, _set("model.domain.upper", [1.0]), "model.domain.upper"),
    ("lpr-domain-empty", LPR_DOC, _set("model.domain", {"lower": [], "upper": []}), "domain"),
    ("lpr-domain-missing", LPR_DOC, _drop("model.domain"), "'domain'"),
    ("lpr-domain-bools", LPR_DOC, _set("model.domain.lower", [True, False]), "domain.lower"),
    ("lpr-coef-nan", LPR_DOC, _set("model.state.coef.0", math.nan), "model.state.coef"),
    ("lpr-coef-inf", LPR_DOC, _set("model.state.coef.1", -math.inf), "model.state.coef"),
    ("lpr-coef-string", LPR_DOC, _set("model.state.coef", "1,2,3"), "model.state.coef"),
    ("lpr-coef-ragged", LPR_DOC, _set("model.state.coef", [1.0, [2.0]]), "model.state.coef"),
    ("lpr-coef-empty", LPR_DOC, _set("model.state.coef", []), "model.state.coef"),
    ("lpr-coef-dict", LPR_DOC, _set("model.state.coef", {"a": 1}), "model.state.coef"),
    ("lpr-coef-null", LPR_DOC, _set("model.state.coef", None), "model.state.coef"),
    ("lpr-coef-missing-one", LPR_DOC, _drop_coefficient, "model.state.coef has"),
    ("lpr-exp-negative", LPR_DOC, _set("model.state.exponents.1", [-1, 0]), "exponents"),
    ("lpr-exp-huge", LPR_DOC, _set("model.state.exponents.1", [10**9, 0]), "exponents"),
    ("lpr-exp-float", LPR_DOC, _set("model.state.exponents.1", [1.5, 0]), "exponents"),
    ("lpr-exp-shape", LPR_DOC, _drop_exponent_row, "model.state.exponents"),
    ("lpr-exp-bool", LPR_DOC, _set("model.state.exponents.1", [True, 0]), "exponents"),
    ("lpr-exp-bigint", LPR_DOC, _set("model.state.exponents.1", [10**30, 0]), "exponents"),
    ("lpr-cond-missing", LPR_DOC, _drop("model.state.cond"), "'cond'"),
    ("lpr-cond-string", LPR_DOC, _set("model.state.cond", "big"), "model.state.cond"),
    ("lpr-state-list", LPR_DOC, _set("model.state", [1, 2]), "model.state"),
    ("lpr-state-missing", LPR_DOC, _drop("model.state"), "'state'"),
    ("lpr-extrap-unknown", LPR_DOC, _set("model.params.extrapolation", "cubic"), "extrapolation"),
    ("lpr-extrap-number", LPR_DOC, _set("model.params.extrapolation", 5), "extrapolation"),
    ("lpr-degree-string", LPR_DOC, _set("model.params.degree", "abc"), "degree"),
    ("lpr-degree-huge", LPR_DOC, _set("model.params.degree", 10**9), "degree"),
    ("lpr-degree-negative", LPR_DOC, _set("model.params.degree", [-1, 2]), "degree[0]"),
    ("lpr-degree-empty", LPR_DOC, _set("model.params.degree", []), "degree"),
    ("lpr-interactions-str", LPR_DOC, _set("model.params.interactions", "yes"), "interactions"),
    ("lpr-param-unknown", LPR_DOC, _set("model.params.foo", 1), "unknown field(s) ['foo']"),
    ("lpr-params-list", LPR_DOC, _set("model.params", [1]), "model.params"),
    ("kind-unknown", LPR_DOC, _set("model.kind", "nn"), "unknown model kind"),
    ("kind-number", LPR_DOC, _set("model.kind", 3), "model.kind"),
    ("model-missing", LPR_DOC, _drop("model"), "'model'"),
    ("model-string", LPR_DOC, _set("model", "lpr"), "model.kind"),
    ("schema-future", LPR_DOC, _set("schema_version", 4), "schema_version"),
    ("schema-bool", LPR_DOC, _set("schema_version", True), "schema_version"),
    ("schema-missing", LPR_DOC, _drop("schema_version"), "schema_version"),
    ("format-wrong", LPR_DOC, _set("format", "pickle"), "'format'"),
    ("features-missing", LPR_DOC, _drop("features"), "'features'"),
    ("features-inputs-len", LPR_DOC, _set("features.inputs", ["a"]), "features.inputs"),
    ("features-inputs-num", LPR_DOC, _set("features.inputs", [1, 2]), "features.inputs"),
    ("features-output-num", LPR_DOC, _set("features.output", 7), "features.output"),
    ("features-units-list", LPR_DOC, _set("features.units", ["N"]), "features.units"),
    ("metadata-list", LPR_DOC, _set("metadata", [1]), "'metadata'"),
    (
        "relaxation-pair-of-numbers",
        MAXWELL_DOC,
        _set("features.relaxation", [1, 2]),
        "field 'features.relaxation': must be a mapping {'zeta': [m, ...], 'rate': [m/s, ...]}",
    ),
    (
        "relaxation-number-lists",
        MAXWELL_DOC,
        _set("features.relaxation", {"zeta": 1, "rate": [0, 1, 2]}),
        "field 'features.relaxation': zeta must be a list of numbers",
    ),
    ("krg-theta-negative", KRG_DOC, _set("model.state.theta.0", -1.0), "model.state.theta"),
    ("krg-theta-zero", KRG_DOC, _set("model.state.theta.1", 0.0), "model.state.theta"),
    ("krg-theta-length", KRG_DOC, _set("model.state.theta", [1.0]), "model.state.theta"),
    ("krg-sigma2-negative", KRG_DOC, _set("model.state.sigma2", -1.0), "model.state.sigma2"),
    ("krg-sigma2-string", KRG_DOC, _set("model.state.sigma2", "1"), "model.state.sigma2"),
    ("krg-nugget-negative", KRG_DOC, _set("model.state.nugget", -1e-3), "model.state.nugget"),
    ("krg-ystd-zero", KRG_DOC, _set("model.state.y_std", 0.0), "model.state.y_std"),
    ("krg-ymean-nan", KRG_DOC, _set("model.state.y_mean", math.nan), "model.state.y_mean"),
    ("krg-X-columns", KRG_DOC, _set("model.state.X", [[0.0, 0.0, 0.0]] * 12), "model.state.X"),
    ("krg-weights-length", KRG_DOC, _set("model.state.weights", [0.0] * 3), "state.weights"),
    ("krg-beta-length", KRG_DOC, _set("model.state.beta", [0.0, 1.0]), "model.state.beta"),
    ("krg-y-missing", KRG_DOC, _drop("model.state.y"), "'y'"),
    ("krg-n-starts-zero", KRG_DOC, _set("model.params.n_starts", 0), "n_starts"),
    ("krg-seed-negative", KRG_DOC, _set("model.params.seed", -1), "seed"),
    ("krg-kernel-unknown", KRG_DOC, _set("model.params.kernel", "rbf"), "kernel"),
    ("krg-trend-unknown", KRG_DOC, _set("model.params.trend", "cubic"), "trend"),
    ("krg-nugget-string", KRG_DOC, _set("model.params.nugget", "big"), "nugget"),
    ("krg-max-samples", KRG_DOC, _set("model.params.max_samples", 5), "max_samples"),
]


@pytest.mark.parametrize(
    ("base", "mutate", "text"), [r[1:] for r in DOC_ROWS], ids=[r[0] for r in DOC_ROWS]
)
def test_bad_model_file(tmp_path: Path, base: dict, mutate: Mutation, text: str) -> None:
    doc = json.loads(json.dumps(base))
    mutate(doc)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFieldError) as exc:
        io.load(path)
    assert text in str(exc.value) and str(path) in str(exc.value)


FILE_ROWS: list[tuple[str, bytes, str]] = [
    ("binary", bytes(range(256)) * 4, "not a UTF-8 text file"),
    ("nested", b"[" * 200_000 + b"]" * 200_000, "nested too deeply"),
    ("truncated", b'{"schema_version": 1, "model": ', "not valid JSON"),
    ("empty", b"", "not valid JSON"),
    ("long-int", b'{"a": ' + b"9" * 5000 + b"}", "not valid JSON"),
    ("top-level-list", b"[1, 2]", "top level"),
]


CSV_ROWS: list[tuple[str, bytes, str]] = [
    ("duplicate-header", b"du,F,F\n1,2,3\n", "line 1: duplicate column name(s) ['F']"),
    ("non-utf8", b"du,F\n1,2\n3,\xff\n", "line 3: not UTF-8"),
    ("long-field", b"du,F\n1," + b"7" * 200_000 + b"\n", "line 2"),
    ("nul-byte", b"du,F\n1,2\x00\n", "line 2"),
    ("non-numeric", b"du,F\n1,abc\n", "column 'F' line 2: 'abc' is not a number"),
    ("time-non-numeric", b"t,du,F\n0,1,x\n", "'x' is not a number"),
    ("long-number", b"du,F\n1," + b"1" * 70 + b"\n", "column 'F' line 2"),
    ("infinite", b"du,F\n1,inf\n", "column 'F' line 2: value is inf"),
    ("nan", b"du,F\n1,2\nnan,3\n", "column 'du' line 3"),
    ("time-nan", b"t,du,F\n0,1,nan\n", "column 'F' line 2"),
    ("fields", b"du,F\n1,2\n1\n", "line 3 has 1 fields"),
    ("time-fields", b"t,du,F\n0,1,2\n1,2\n", "line 3 has 2 fields"),
    ("missing-column", b"du,G\n1,2\n", "missing column(s) ['F']"),
    ("time-missing-column", b"t,du\n0,1\n", "missing column"),
    ("empty", b"", "empty file"),
    ("no-rows", b"du,F\n", "no data rows"),
    ("time-no-rows", b"t,du,F\n", "no data rows"),
    ("multiline-quoted", b'du,F\n1,2\n"3\n4",5\n', "column 'du' line 4"),
]

#: reader → (file name, read, the error it raises)
READERS: dict[str, tuple[str, Callable[[Path], object], type[ValueError]]] = {
    "model": ("m.json", io.load, ModelFieldError),
    "csv": ("d.csv", lambda path: io.read_csv(path, columns=["du", "F"]), ValueError),
}
BYTE_ROWS = [("model", *r) for r in FILE_ROWS] + [("csv", *r) for r in CSV_ROWS]


@pytest.mark.parametrize(
    ("reader", "raw", "text"),
    [(r[0], *r[2:]) for r in BYTE_ROWS],
    ids=[f"{r[0]}-{r[1]}" for r in BYTE_ROWS],
)
def test_bad_file_bytes(tmp_path: Path, reader: str, raw: bytes, text: str) -> None:
    """A model file (``io.load``) or a data table (``io.read_csv``) of these bytes raises the
    reader's error, naming the file and the fault."""
    name, read, error = READERS[reader]
    path = tmp_path / name
    path.write_bytes(raw)
    with pytest.raises(error) as exc:
        read(path)
    assert text in str(exc.value) and str(path) in str(exc.value)


def test_csv_bom_is_stripped(tmp_path: Path) -> None:
    path = tmp_path / "d.csv"
    path.write_bytes("\ufeffdu,F\n1,2\n".encode())
    assert io.read_csv(path)["du"].tolist() == [1.0]


def _steep() -> LegendreRegression:
    x = np.linspace(-1.0, 1.0, 9)[:, None]
    return LegendreRegression(degree=1).fit(x, 1e5 * x[:, 0])


def _raising() -> LegendreRegression:
    x = np.linspace(-1.0, 1.0, 9)[:, None]
    return LegendreRegression(degree=1, extrapolation="raise").fit(x, x[:, 0])


U_CONST = np.column_stack([np.linspace(0, 1, 30), np.full(30, 2.0)])
U_WIDE = np.column_stack([np.resize([-1.7e308, 1.7e308, 0.0], 30), np.linspace(0, 1, 30)])
U_BIG = RNG.uniform(0, 1, (2500, 2))
V_LIN = np.linspace(0, 1, 30)
V_HUGE = np.where(np.arange(30) % 2 == 0, 1.7e308, -1.7e308)
X1 = np.linspace(0, 1, 30)[:, None]  # one input column

# (row id, call, error type, text the message must contain)
API_ROWS: list[tuple[str, Callable[[], Any], type[Exception], str]] = [
    ("lpr-degree-neg", lambda: LegendreRegression(degree=-1).fit(X1, V_LIN), ValueError, "degree"),
    (
        "lpr-degree-float",
        lambda: LegendreRegression(degree=2.5).fit(X1, V_LIN),
        ValueError,
        "degree",
    ),
    (
        "lpr-degree-huge",
        lambda: LegendreRegression(degree=10**9).fit(X1, V_LIN),
        ValueError,
        "degree",
    ),
    (
        "lpr-interactions",
        lambda: LegendreRegression(interactions="no").fit(X1, V_LIN),
        ValueError,
        "interactions",
    ),
    (
        "lpr-interactions-huge",
        lambda: LegendreRegression(degree=200, interactions=True).fit(U_BIG[:30], V_LIN),
        ValueError,
        "needs at least",
    ),
    (
        "lpr-extrapolation",
        lambda: LegendreRegression(extrapolation="cubic").fit(X1, V_LIN),
        ValueError,
        "extrapolation",
    ),
    ("krg-kernel", lambda: Kriging(kernel="rbf").fit(X1, V_LIN), ValueError, "kernel"),
    ("krg-n-starts", lambda: Kriging(n_starts=0).fit(X1, V_LIN), ValueError, "n_starts"),
    ("krg-seed-neg", lambda: Kriging(seed=-1).fit(X1, V_LIN), ValueError, "seed"),
    ("krg-seed-float", lambda: Kriging(seed=1.5).fit(X1, V_LIN), ValueError, "seed"),
    ("krg-max-samples", lambda: Kriging(max_samples=1).fit(X1, V_LIN), ValueError, "max_samples"),
    ("krg-nugget-bool", lambda: Kriging(nugget=True).fit(X1, V_LIN), ValueError, "nugget"),
    ("krg-too-many", lambda: Kriging().fit(U_BIG, U_BIG[:, 0]), ValueError, "max_samples=1000"),
    ("fit-constant-col", lambda: LegendreRegression().fit(U_CONST, V_LIN), ValueError, "column 1"),
    ("fit-wide-col", lambda: LegendreRegression().fit(U_WIDE, V_LIN), ValueError, "overflows"),
    ("fit-huge-output", lambda: LegendreRegression(1).fit(X1, V_HUGE), ValueError, "y overflows"),
    ("predict-1d", lambda: _steep().predict([0.5]), ValueError, "X must be 2-D"),
    ("fit-1d", lambda: LegendreRegression(1).fit(V_LIN, V_LIN), ValueError, "X must be 2-D"),
    ("predict-raise", lambda: _raising().predict([[3.0]]), ValueError, "column(s) [0]"),
    ("predict-overflow", lambda: _steep().predict([[1e306]]), ValueError, "overflows float64"),
    ("predict-columns", lambda: _steep().predict(np.zeros((2, 3))), ValueError, "3 columns"),
    (
        "predict-strings",
        lambda: _steep().predict([["a"]]),
        ValueError,
        "X must be an array of real",
    ),
    ("predict-complex", lambda: _steep().predict([[1j]]), ValueError, "X must be an array of real"),
    ("set-params", lambda: Kriging().set_params(degree=3), ValueError, "degree"),
    ("build-const-col", lambda: build(U_CONST, V_LIN, m=20), ValueError, "U column 1"),
    ("build-wide-col", lambda: build(U_WIDE, V_LIN, m=20), ValueError, "overflows"),
    (
        "build-extrapolation",
        lambda: build(U_BIG[:30], V_LIN, m=20, extrapolation="x"),
        ValueError,
        "extrapolation",
    ),
    (
        "build-kernel",
        lambda: build(U_BIG[:30], V_LIN, kind="kriging", m=20, candidates=["rbf"]),
        ValueError,
        "kernel",
    ),
    (
        "build-empty-cands",
        lambda: build(U_BIG[:30], V_LIN, m=20, candidates=[]),
        ValueError,
        "candidates is empty",
    ),
    ("build-m-zero", lambda: build(U_BIG[:30], V_LIN, m=0), ValueError, "m must be"),
    ("build-m-float", lambda: build(U_BIG[:30], V_LIN, m=2.5), ValueError, "m must be an integer"),
    (
        "build-sampling",
        lambda: build(U_BIG[:30], V_LIN, m=20, sampling="sobol"),
        ValueError,
        "sampling",
    ),
    ("build-kind", lambda: build(U_BIG[:30], V_LIN, m=20, kind="nn"), ValueError, "kind"),
    (
        "build-model-param",
        lambda: build(U_BIG[:30], V_LIN, m=20, colour=1),
        ValueError,
        "invalid model parameter",
    ),
    (
        "build-too-few",
        lambda: build(U_BIG[:30], V_LIN, m=20, candidates=[(20, 20)]),
        ValueError,
        "20,20: X has 20 samples but degree=(20, 20)",
    ),
    (
        "build-k",
        lambda: build(U_BIG[:30], V_LIN, m=20, selection="kfold", k=1),
        ValueError,
        "k must be",
    ),
    ("build-huge-output", lambda: build(U_BIG[:30], V_HUGE, m=20), ValueError, "V overflows"),
]


@pytest.mark.parametrize(
    ("call", "error", "text"), [r[1:] for r in API_ROWS], ids=[r[0] for r in API_ROWS]
)
def test_bad_api_input(call: Callable[[], Any], error: type[Exception], text: str) -> None:
    with pytest.raises(error) as exc:
        call()
    assert text in str(exc.value)


def _rcforc_with(tmp_path: Path, old: str, new: str) -> Path:
    """The rcforc sample with one field replaced."""
    text = (DATA / "rcforc_sled").read_text()
    assert old in text
    path = tmp_path / "rcforc"
    path.write_text(text.replace(old, new, 1))
    return path


def _table(tmp_path: Path, **kwargs: Any) -> Any:
    path = tmp_path / "t.csv"
    path.write_text("# export\nt,x\n0,1\n1,2\n")
    return io.read_table(path, **kwargs)


# (row id, call of tmp_path, error type, texts the message must contain)
PATH_ROWS: list[tuple[str, Callable[[Path], Any], type[Exception], list[str]]] = [
    (
        "rcforc-resultant-overflow",
        lambda tmp: io.read_rcforc(
            _rcforc_with(tmp, "x -1.50000E+03", "x -1.00000E+200"), "mm-ms-kg-kN"
        ),
        ValueError,
        ["rcforc: line 13: contact ('master', 1)", "overflows float64", "check the line"],
    ),
    (
        "table-comment-empty",
        lambda tmp: _table(tmp, comment=""),
        ValueError,
        ["comment must be the non-empty prefix", "or None", "skip every line"],
    ),
    (
        "table-header-row-negative",
        lambda tmp: _table(tmp, header_row=-1),
        ValueError,
        ["header_row must be a 0-based line number", "integer >= 0", "got -1"],
    ),
    (
        "table-header-row-bool",
        lambda tmp: _table(tmp, header_row=True),
        ValueError,
        ["header_row must be a 0-based line number", "got True"],
    ),
    (
        "table-unit-row-negative",
        lambda tmp: _table(tmp, header_row=1, unit_row=-2),
        ValueError,
        ["unit_row must be a 0-based line number", "got -2"],
    ),
    (
        "save-metadata-object",
        lambda tmp: io.save(_steep(), tmp / "m.json", metadata={"run": {"x": object()}}),
        ValueError,
        ["metadata['run']['x']", "type object", "give numbers, strings"],
    ),
    (
        "save-metadata-nan",
        lambda tmp: io.save(_steep(), tmp / "m.json", metadata={"x": np.array([1.0, np.nan])}),
        ValueError,
        ["metadata['x'][1] must be a finite number", "nan"],
    ),
    (
        "save-metadata-int-key",
        lambda tmp: io.save(_steep(), tmp / "m.json", metadata={1: "a"}),
        ValueError,
        ["metadata: key 1 must be a string"],
    ),
]


@pytest.mark.parametrize(
    ("call", "error", "texts"), [r[1:] for r in PATH_ROWS], ids=[r[0] for r in PATH_ROWS]
)
def test_bad_file_or_argument_names_the_field(
    tmp_path: Path, call: Callable[[Path], Any], error: type[Exception], texts: list[str]
) -> None:
    with pytest.raises(error) as exc:
        call(tmp_path)
    for text in texts:
        assert text in str(exc.value), str(exc.value)
    assert not (tmp_path / "m.json").exists()  # nothing written


def test_numpy_metadata_is_saved_as_plain_json(tmp_path: Path) -> None:
    """Documented result: numpy arrays and scalars in ``metadata`` are saved as lists and
    numbers, and read back as such."""
    meta = {"x": np.arange(3), "g": np.float32(0.5), "pair": (1, np.int64(2)), "ok": np.bool_(1)}
    io.save(_steep(), tmp_path / "m.json", metadata=meta)
    assert io.load(tmp_path / "m.json").metadata_ == {
        "x": [0, 1, 2],
        "g": 0.5,
        "pair": [1, 2],
        "ok": True,
    }


def test_table_comment_none_skips_no_line(tmp_path: Path) -> None:
    """``comment=None`` (documented): no line is a comment, so a ``#`` line is data."""
    path = tmp_path / "t.csv"
    path.write_text("t,x\n0,1\n1,2\n")
    assert io.read_table(path, comment=None).t.tolist() == [0.0, 1.0]
    path.write_text("t,x\n0,1\n#1,2\n")
    with pytest.raises(ValueError, match="line 3: column 't': '#1' is not a number"):
        io.read_table(path, comment=None)


def test_save_refuses_to_overwrite_when_asked(tmp_path: Path) -> None:
    path = tmp_path / "m.json"
    model = _steep()
    io.save(model, path)
    before = path.read_text()
    with pytest.raises(FileExistsError, match=str(path)):
        io.save(model, path, overwrite=False)
    assert path.read_text() == before
    io.save(model, path)  # the default replaces, as callers in railgym expect
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json"]  # no temporary left


def _csv(path: Path) -> Path:
    rng = np.random.default_rng(0)
    du, dv = rng.uniform(-0.02, 0.02, 80), rng.uniform(-0.2, 0.2, 80)
    rows = "\n".join(f"{a},{b},{8.6e5 * a + 4e4 * b}" for a, b in zip(du, dv, strict=True))
    path.write_text("du,dv,F\n" + rows + "\n")
    return path


# (row id, extra arguments, -o target relative to tmp_path, text on stderr)
CLI_ROWS: list[tuple[str, list[str], str, str]] = [
    ("out-no-folder", [], "nodir/m.json", "does not exist"),
    ("out-exists", [], "exists.json", "--overwrite"),
    ("out-is-folder", [], "folder", "is a folder"),
    ("report-no-folder", ["--report", "{tmp}/nodir/r.json"], "m.json", "--report"),
    ("report-same-file", ["--report", "{tmp}/m.json"], "m.json", "same file"),
    ("units", ["--units", "F"], "m.json", "--units 'F'"),
    ("m-zero", ["--m", "0"], "m.json", "--m must be >= 1"),
    ("seed-negative", ["--seed", "-3"], "m.json", "--seed"),
    ("m-too-large", ["--m", "500"], "m.json", "m = 500"),
    ("duplicate-columns", ["--inputs", "du", "du"], "m.json", "more than once"),
    ("missing-data", ["--data-missing"], "m.json", "nofile.csv"),
]


@pytest.mark.parametrize(
    ("extra", "target", "text"), [r[1:] for r in CLI_ROWS], ids=[r[0] for r in CLI_ROWS]
)
def test_bad_cli_call(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], target: str, text: str
) -> None:
    data = _csv(tmp_path / "d.csv")
    (tmp_path / "exists.json").write_text("keep")
    (tmp_path / "folder").mkdir()
    extra = [e.replace("{tmp}", str(tmp_path)) for e in extra]
    if extra == ["--data-missing"]:
        data, extra = tmp_path / "nofile.csv", []
    inputs = ["--inputs", "du", "dv"] if "--inputs" not in extra else []
    argv = ["build", str(data), *inputs, "--target", "F", "-o", str(tmp_path / target)]
    code = main([*argv, "--m", "41", "--quiet", *extra])
    err = capsys.readouterr().err
    assert code == 2
    assert text in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "m.json").exists()  # nothing written after a user error
    assert (tmp_path / "exists.json").read_text() == "keep"


def test_cli_debug_shows_the_traceback(tmp_path: Path) -> None:
    argv = ["build", str(tmp_path / "none.csv"), "--inputs", "a", "--target", "b"]
    with pytest.raises(OSError):
        main([*argv, "-o", str(tmp_path / "m.json"), "--debug"])
