"""Outputs of a mapping file as expressions of FMU variables (``railgym.fmu.expression``).

A parser table (values on given variables, errors naming the file, the field and the
column), nothing evaluated as Python, ``der()`` against analytic signals, the unit rule, the
``vehicle:`` key, and the reference FMU mapped once with its outputs and once with
expressions of its states, through ``gym.make``.
"""

from __future__ import annotations

import builtins
import math
import re
import shutil
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import railgym  # noqa: F401  (registers the envs)
from railgym.fmu import expression as ex
from railgym.fmu.expression import Derivatives, ExpressionError, compile_expression, parse
from railgym.fmu.mapping import FMUError, load_mapping
from railgym.fmu.reference import export_reference_fmu
from railgym.fmu.runner import FMURunner
from tests.markers import needs_cc

pytest.importorskip("fmpy", reason="the 'fmi' extra (fmpy) is not installed")
ID = "railgym/VerticalSuspension-v1"

#: variable values of the parser table (names as FMI writes them)
VALUES = {"x1": 0.3, "x2": 0.1, "v1": 2.0, "v2": -1.0, "a2": 9.0, "z_mm": 12.0}
VALUES |= {"body.a[1]": 4.0, "der(v1)": 5.0, "q_2.b[10]": -0.5}

#: (expression, its value on VALUES computed by Python arithmetic in the same order)
VALID = [
    ("x1 - x2", lambda v: v["x1"] - v["x2"]),
    ("-a2", lambda v: -v["a2"]),
    ("0.001 * z_mm", lambda v: 0.001 * v["z_mm"]),
    ("(v1 - v2)", lambda v: v["v1"] - v["v2"]),
    ("x1 - x2 * 2", lambda v: v["x1"] - v["x2"] * 2.0),  # * before -
    ("(x1 - x2) * 2", lambda v: (v["x1"] - v["x2"]) * 2.0),
    ("v1 / v2 / 4", lambda v: v["v1"] / v["v2"] / 4.0),  # left to right
    ("x1 - x2 - x1", lambda v: v["x1"] - v["x2"] - v["x1"]),
    ("- -v2", lambda v: v["v2"]),
    ("2 * -v1", lambda v: 2.0 * -v["v1"]),
    ("-(x1 + x2) / 2", lambda v: -(v["x1"] + v["x2"]) / 2.0),
    ("body.a[1] + 1e-3", lambda v: v["body.a[1]"] + 1e-3),
    ("q_2.b[10]*.5", lambda v: v["q_2.b[10]"] * 0.5),
    ('"der(v1)" * 2', lambda v: v["der(v1)"] * 2.0),  # a quoted name: the FMU's variable
    ("2 * 3 * x1", lambda v: 6.0 * v["x1"]),  # constant parts folded
    ("1.5E2 * .5 - 1", lambda v: 74.0),
    ("  x1\t ", lambda v: v["x1"]),
    ("((((x2))))", lambda v: v["x2"]),
]


def _evaluate(text: str, values: dict[str, float]) -> float:
    expr = parse(text)
    columns = {n: j for j, n in enumerate(expr.names)}
    raw = np.array([[values[n] for n in expr.names]])
    f = compile_expression(expr, columns, dict.fromkeys(expr.names, 1.0))
    return float(f(raw, Derivatives(expr.n_der, 1e-3))[0])


@pytest.mark.parametrize("text, value", VALID, ids=[t for t, _ in VALID])
def test_valid_expressions_have_their_arithmetic_value(text, value):
    assert _evaluate(text, VALUES) == value(VALUES)


def test_names_are_listed_once_in_order_of_first_use_with_their_columns():
    e = parse("x1 - 2 * x2 + x1 / body.a[1] + der(x2)")
    assert e.names == ("x1", "x2", "body.a[1]") and e.columns == (1, 10, 20)
    assert e.n_der == 1


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """``(fmu, mapping document)`` of the exported vertical reference (ME and CS)."""
    if shutil.which("cc") is None and shutil.which("gcc") is None:
        pytest.skip("no C compiler")
    fmu, mapping = export_reference_fmu(tmp_path_factory.mktemp("ref") / "vehicle.fmu")
    doc = yaml.safe_load(mapping.read_text())
    doc["fmu"] = str(fmu)
    return fmu, doc


def _write(doc: dict, path: Path, **outputs) -> Path:
    doc = yaml.safe_load(yaml.safe_dump(doc))
    doc["outputs"].update(outputs)
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


#: (field, mapping value, words the one FMUError must contain besides the file and field)
INVALID = [
    ("deflection", "", ["the expression is empty"]),
    ("deflection", "   ", ["the expression is empty"]),
    ("deflection", "x1; x2", ["unexpected character ';' at column 3", "'x1; x2'"]),
    ("deflection", "x1**2", ["at column 4", "got '*'"]),
    ("deflection", "a.b()", ["'a.b' at column 1 is not a function", "der(...)"]),
    ("deflection", "__import__('os')", ["'__import__' at column 1 is not a function"]),
    ("deflection", "(x1 - x2", ["unbalanced parenthesis", "'(' at column 1 is not closed"]),
    ("deflection", "x1 - x2)", ["unbalanced parenthesis", "')' at column 8 has no '('"]),
    ("deflection", "x1 / 0", ["division by zero at column 4"]),
    ("deflection", "x1 / (2 - 2.0)", ["division by zero at column 4"]),
    ("deflection", "x1 - nope", ["has no variable 'nope'", "column 6"]),
    ("deflection", "x1 x2", ["expected an operator", "column 4", "got 'x2'"]),
    ("deflection", "x1 -", ["column 5", "got the end"]),
    ("deflection", "1e999 * x1", ["not finite"]),
    ("deflection", '"x1 - x2', ["unterminated quoted name at column 1"]),
    ("deflection", "'x1'", ['unexpected character "\'" at column 1']),
    ("deflection", "-" * 150 + "x1", ["nested more than 100 deep"]),
    ("deflection", "der()", ["column 5", "got ')'"]),
    ("deflection", "x1 - v1", ["'-' at column 4 combines m with m/s"]),
    ("deflection", "v1 - v2", ["is in m/s", "outputs.deflection is in m"]),
    ("bogie_acc", {"expr": "der(x1)"}, ["is in m/s", "outputs.bogie_acc is in m/s2"]),
    ("bogie_acc", "der(x1)", ["unit 'm/s' of FMU variable 'der(x1)' does not convert"]),
    ("deflection", "-dp_bag", ["is in kg/m.s2", "is in m"]),
    ("carbody_disp", "z - x2", ["'z' has causality 'input'", "column 1"]),
    ("deflection", {"expr": "1000 * x1 - 1000 * x2", "unit": "mm"}, ["declares 'm'", "'x1'"]),
    ("deflection", {"expr": "x1 - x2", "name": "x1"}, ["name:", "expr:", "not both"]),
    ("deflection", {"unit": "m"}, ["name:", "expr:"]),
    ("deflection", {"expr": 3}, ["outputs.deflection.expr", "non-empty string"]),
    ("deflection", {"expr": "x1", "units": "m"}, ["unknown field outputs.deflection.units"]),
    ("deflection", 3, ["must be a variable name, an expression"]),
]


@needs_cc
@pytest.mark.parametrize("key, value, words", INVALID, ids=[repr(c[1])[:40] for c in INVALID])
def test_bad_expression_gives_one_error_naming_file_and_field(
    reference, tmp_path, key, value, words
):
    _, doc = reference
    path = _write(doc, tmp_path / "map.yaml", **{key: value})
    with pytest.raises(FMUError) as info:
        load_mapping(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: ") and f"outputs.{key}" in msg, msg
    assert info.value.field.startswith(f"outputs.{key}")
    for word in words:
        assert word in msg, (word, msg)


@needs_cc
@pytest.mark.parametrize("name", ["print", "eval", "open", "abs", "__import__", "__builtins__"])
def test_a_python_builtin_is_an_unknown_fmu_variable(reference, tmp_path, name):
    _, doc = reference
    path = _write(doc, tmp_path / "map.yaml", deflection=f"x1 - {name}")
    with pytest.raises(FMUError, match=f"has no variable '{name}' \\(column 6 of"):
        load_mapping(path)


def test_nothing_is_evaluated_as_python(monkeypatch):
    """With eval, exec and compile made to fail, expressions still parse and evaluate: the
    parser does not use them, and the module does not import ast."""

    def refuse(*args, **kwargs):
        raise AssertionError("Python code evaluated")

    for name in ("eval", "exec", "compile"):
        monkeypatch.setattr(builtins, name, refuse)
    for text, value in VALID:
        assert _evaluate(text, VALUES) == value(VALUES)
    with pytest.raises(ExpressionError, match="not a function"):
        parse("__import__('os').system('true')")
    monkeypatch.undo()
    assert "ast" not in vars(ex) and "eval" not in vars(ex)


# ------------------------------------------------------------------------------ der()
def _der_series(y: np.ndarray, h: float, chunk: int) -> np.ndarray:
    """der of the samples ``y`` (y[0] at the reset), fed ``chunk`` samples at a time."""
    d = Derivatives(1, h)
    d.reset()
    out = [d(0, y[:1])]
    for k in range(1, y.size, chunk):
        out.append(d(0, y[k : k + chunk]))
    return np.concatenate(out)


def test_der_is_exact_for_a_quadratic_after_the_first_two_substeps():
    h = 1e-3
    t = np.arange(200) * h
    d = _der_series(3.0 * t**2 - 2.0 * t + 0.7, h, 10)
    assert d[0] == 0.0  # at the reset
    assert d[1] == pytest.approx((3.0 * h**2 - 2.0 * h) / h, rel=1e-9)  # first order
    np.testing.assert_allclose(d[2:], 6.0 * t[2:] - 2.0, rtol=0, atol=1e-10)


def test_der_of_a_sine_converges_with_order_two():
    w = 2.0 * math.pi * 8.0  # 8 Hz
    errors = []
    for h in (1e-3, 5e-4, 2.5e-4):
        t = np.arange(int(0.5 / h) + 1) * h
        d = _der_series(np.sin(w * t), h, 10)
        err = np.abs(d[2:] - w * np.cos(w * t[2:])).max()
        assert err <= 1.1 * (w * h) ** 2 / 3.0 * w  # h²/3·max|y'''|
        errors.append(err)
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(3.8 < r < 4.2 for r in ratios), ratios


def test_der_is_the_same_fed_one_substep_or_many_and_rereads_the_current_sample():
    h = 1e-3
    y = np.sin(np.arange(40) * 0.05)
    np.testing.assert_array_equal(_der_series(y, h, 1), _der_series(y, h, 10))
    d = Derivatives(1, h)
    d.reset()
    d(0, y[:1])
    d.replace = True  # the reset time read again with other inputs
    assert d(0, np.array([5.0]))[0] == 0.0
    d.replace = False
    assert d(0, y[1:2])[0] == (y[1] - 5.0) / h
    assert d(0, y[2:3])[0] == (3.0 * y[2] - 4.0 * y[1] + 5.0) / (2.0 * h)
    d.replace = True
    assert d(0, np.array([1.0]))[0] == (3.0 * 1.0 - 4.0 * y[1] + 5.0) / (2.0 * h)


# ----------------------------------------------------------------- end to end on an FMU
#: the reference FMU's outputs as expressions of its states x1, v1, x2, v2 (what a user's
#: FMU gives); carbody_acc is the FMU's own der(v2) variable, read by its name
STATE_OUTPUTS = {
    "deflection": "x1 - x2",
    "deflection_rate": "v1 - v2",
    "bogie_acc": {"expr": "der(v1)"},  # expr: the runner's derivative, though the FMU has one
    "carbody_acc": "der(v2)",  # a plain string that names a variable: that variable
    "carbody_vel": {"expr": "v2"},
    "carbody_disp": "-(-x2)",
}


def _run(fmu: Path, path: Path, actions: np.ndarray, seed: int = 3) -> np.ndarray:
    """Per step the env's float64 state ``x1, v1, x2, v2`` and accelerations
    ``ẍ1, ẍ2`` (from the FMU's outputs), and the observation."""
    env = gym.make(ID, backend="fmu", fmu=fmu, fmu_map=path, duration=1.5, track_class=4)
    env.reset(seed=seed)
    rows = []
    for a in actions:
        obs, *_ = env.step(a)
        sim = env.unwrapped.sim
        rows.append([*sim.state[0, :4], *sim.acc[0], *obs])
    env.close()
    return np.array(rows)


@needs_cc
@pytest.mark.parametrize("fmi_type", ["CoSimulation", "ModelExchange"])
def test_outputs_as_expressions_of_the_states_equal_the_fmus_outputs(reference, tmp_path, fmi_type):
    """Measured (150 steps, class 4, random actions): deflection, its rate, carbody velocity
    and displacement and the quoted der(v2) equal the plain mapping bit for bit; der(v1), the
    second-order backward difference at 1 ms, is within 0.2 % of the largest bogie
    acceleration (0.15 % RMS): asserted 1 % and 0.5 %."""
    fmu, doc = reference
    doc = {**doc, "fmi_type": fmi_type}
    plain = _write(doc, tmp_path / "plain.yaml")
    states = _write(doc, tmp_path / "states.yaml", **STATE_OUTPUTS)
    mapping = load_mapping(states)
    assert mapping.outputs["deflection"].expr.names == ("x1", "x2")
    assert mapping.outputs["bogie_acc"].expr.n_der == 1
    assert mapping.outputs["carbody_acc"].expr.n_der == 0  # the FMU's variable der(v2)
    assert [s.factor for s in mapping.outputs["deflection"].signals] == [1.0, 1.0]
    actions = np.random.default_rng(1).uniform(-1, 1, (150, 1)).astype(np.float32)
    ref, got = _run(fmu, plain, actions), _run(fmu, states, actions)
    assert ref.shape == got.shape == (150, 11)
    scale = np.abs(ref).max(axis=0)
    exact = [0, 1, 2, 3, 5, 6, 8, 9, 10]  # states, carbody acc; obs except bogie acc
    assert np.all(np.abs(got[:, exact] - ref[:, exact]) <= 1e-12 * scale[exact])
    err = np.abs(got[:, 4] - ref[:, 4])
    assert err.max() <= 0.01 * scale[4]
    assert np.sqrt(np.mean(err**2) / np.mean(ref[:, 4] ** 2)) < 0.005
    assert scale[4] > 1.0 and err.max() > 0.0  # a real ride, and a real difference


@needs_cc
def test_reset_restarts_the_derivative_history(reference, tmp_path):
    """Two episodes from the same seed give the same der(v1) from their first step: the
    second does not difference against the first's last samples."""
    fmu, doc = reference
    path = _write(doc, tmp_path / "states.yaml", **STATE_OUTPUTS)
    runner = FMURunner(load_mapping(path), 1e-3, 10)
    col = runner.out_keys.index("bogie_acc")
    t = np.arange(31) * 1e-3
    z = (0.01 * np.sin(40.0 * t))[None, :]
    zd = (0.4 * np.cos(40.0 * t))[None, :]
    runs = []
    for _ in range(2):
        first = runner.reset()
        assert first["bogie_acc"] == 0.0
        y = [runner.advance(z[:, k : k + 11], zd[:, k : k + 11], [500.0]) for k in (0, 10, 20)]
        runs.append(np.concatenate(y)[:, col])
    runner.close()
    np.testing.assert_array_equal(runs[0], runs[1])
    assert np.abs(runs[0]).max() > 0.1


# ------------------------------------------------------------------------------ units
def _without_units(fmu: Path, dst: Path, names: tuple[str, ...]) -> Path:
    """A copy of ``fmu`` whose variables ``names`` declare no unit."""
    with zipfile.ZipFile(fmu) as zf:
        files = {n: zf.read(n) for n in zf.namelist()}
    xml = files["modelDescription.xml"].decode()
    for name in names:
        head, rest = xml.split(f'<ScalarVariable name="{name}" ', 1)
        real, tail = rest.split("</ScalarVariable>", 1)
        real = real.replace(' unit="m"', "").replace(' unit="m/s"', "")
        xml = f'{head}<ScalarVariable name="{name}" {real}</ScalarVariable>{tail}'
    files["modelDescription.xml"] = xml.encode()
    with zipfile.ZipFile(dst, "w") as zf:
        for n, data in files.items():
            zf.writestr(n, data)
    return dst


@needs_cc
def test_a_unit_that_disagrees_with_the_declared_one_is_an_error(reference, tmp_path):
    _, doc = reference
    path = _write(doc, tmp_path / "map.yaml", deflection={"name": "deflection", "unit": "mm"})
    with pytest.raises(FMUError) as info:
        load_mapping(path)
    assert str(info.value) == (
        f"{path}: outputs.deflection: the FMU declares 'm' for variable 'deflection'; the "
        "mapping's unit 'mm' disagrees — remove unit: or fix the FMU"
    )
    # another spelling of the declared unit agrees; so does the declared unit itself
    path = _write(doc, tmp_path / "ok.yaml", bogie_acc={"name": "bogie_acc", "unit": "m/s^2"})
    assert load_mapping(path).outputs["bogie_acc"].signals[0].factor == 1.0
    path = _write(doc, tmp_path / "in.yaml")
    raw = yaml.safe_load(path.read_text())
    raw["inputs"]["track"][0]["displacement"] = {"name": "z", "unit": "cm"}
    path.write_text(yaml.safe_dump(raw))
    with pytest.raises(FMUError, match="inputs.track\\[0\\].displacement: the FMU declares 'm'"):
        load_mapping(path)


@needs_cc
def test_unit_of_an_undeclared_variable_or_expression_is_taken(reference, tmp_path):
    """Without declared units, ``unit:`` of a variable is its factor, and ``unit:`` of an
    expression scales its value (the variables taken as they are)."""
    fmu, doc = reference
    bare = _without_units(fmu, tmp_path / "bare.fmu", ("x1", "x2", "v2"))
    doc = {**doc, "fmu": str(bare)}
    path = _write(
        doc,
        tmp_path / "map.yaml",
        deflection={"expr": "1000 * x1 - 1000 * x2", "unit": "mm"},
        carbody_disp={"name": "x2", "unit": "mm"},
        carbody_vel="v2",  # no unit anywhere: SI
    )
    m = load_mapping(path)
    defl, disp = m.outputs["deflection"], m.outputs["carbody_disp"]
    assert defl.factor == 1e-3 and [s.factor for s in defl.signals] == [1.0, 1.0]
    assert disp.signals[0].factor == 1e-3 and m.outputs["carbody_vel"].signals[0].factor == 1.0
    runner = FMURunner(m, 1e-3, 10)
    runner.reset()
    z = np.linspace(0.0, 0.01, 11)[None, :]
    y = runner.advance(z, np.full((1, 11), 1.0), [0.0])
    runner.close()
    raw = FMURunner(load_mapping(_write(doc, tmp_path / "plain.yaml")), 1e-3, 10)
    raw.reset()
    want = raw.advance(z, np.full((1, 11), 1.0), [0.0])
    raw.close()
    keys = runner.out_keys
    d, want_d = y[:, keys.index("deflection")], want[:, raw.out_keys.index("deflection")]
    np.testing.assert_allclose(d, want_d, rtol=0, atol=1e-12 * np.abs(want_d).max())
    x2 = want[:, raw.out_keys.index("carbody_disp")]
    np.testing.assert_allclose(y[:, keys.index("carbody_disp")], 1e-3 * x2, rtol=1e-15)
    assert np.abs(want_d).max() > 1e-6


# ---------------------------------------------------------------------------- vehicle:
@needs_cc
def test_vehicle_key_is_a_path_beside_the_mapping_or_a_name(reference, tmp_path):
    _, doc = reference
    (tmp_path / "cars").mkdir()
    (tmp_path / "cars" / "car.yaml").write_text("vehicle: {}\n")
    cases = [("cars/car.yaml", str(tmp_path / "cars" / "car.yaml")), ("manchester", "manchester")]
    for value, want in cases:
        path = _write({**doc, "vehicle": value}, tmp_path / "map.yaml")
        assert load_mapping(path).vehicle == want
    bare = {k: v for k, v in doc.items() if k != "vehicle"}
    assert load_mapping(_write(bare, tmp_path / "none.yaml")).vehicle is None
    for bad in (3, ["manchester"], ""):
        path = _write({**doc, "vehicle": bad}, tmp_path / "bad.yaml")
        with pytest.raises(FMUError, match=f"^{re.escape(str(path))}: vehicle must be a"):
            load_mapping(path)
