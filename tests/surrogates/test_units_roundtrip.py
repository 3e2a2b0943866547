"""An element from the user's data keeps its names and units from the build through save/load
into the env: ``surrogates build --units`` or a ``name [unit]`` CSV header, ``build(units=)``;
units for some names only, an unknown name or unit are refused where they are given."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import railgym  # noqa: F401  (registers the envs)
import surrogates
from surrogates import io
from surrogates.cli import main
from surrogates.units import KNOWN_UNITS
from tests.fresh_process import run_python

SI = {"defl": "m", "rate": "m/s", "force": "N"}
N_ROWS = 300


def _damper(n: int = N_ROWS, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A linear spring-damper (not the packaged element): F = 4.3e5 N/m·δ + 2.0e4 N·s/m·δ̇."""
    rng = np.random.default_rng(seed)
    U = np.column_stack([rng.uniform(-0.05, 0.05, n), rng.uniform(-0.5, 0.5, n)])
    return U, 4.3e5 * U[:, 0] + 2.0e4 * U[:, 1]


def _csv(path: Path, header: str = "defl,rate,force") -> Path:
    U, F = _damper()
    rows = "\n".join(
        f"{a!r},{b!r},{c!r}" for a, b, c in zip(*U.T.tolist(), F.tolist(), strict=True)
    )
    path.write_text(header + "\n" + rows + "\n")
    return path


def _argv(data: Path, model: Path, *extra: str) -> list[str]:
    return [
        "build",
        str(data),
        "--inputs",
        "defl",
        "rate",
        "--target",
        "force",
        "-o",
        str(model),
        "--m",
        "61",
        "--sampling",
        "greedy",
        "--max-degree",
        "3",
        *extra,
    ]


def _run(argv: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    """``python -m surrogates`` in a fresh process."""
    return run_python("-m", "surrogates", *argv, cwd=cwd, timeout=300)


def _steps(model: object, n: int = 20) -> np.ndarray:
    """Observations of ``n`` seeded random steps of VerticalSuspension-v1 with ``model``."""
    env = gym.make("railgym/VerticalSuspension-v1", backend="surrogate", surrogate=model)
    env.reset(seed=0)
    env.action_space.seed(0)
    obs = [env.step(env.action_space.sample())[0] for _ in range(n)]
    env.close()
    return np.array(obs)


@pytest.mark.parametrize(
    ("header", "units"),
    [
        ("defl,rate,force", ["--units", "defl=m", "rate=m/s", "force=N"]),
        ("defl [m],rate [m/s],force [N]", []),
    ],
    ids=["--units", "header"],
)
def test_a_cli_element_with_units_runs_in_the_env(tmp_path, header, units):
    data, out = _csv(tmp_path / "damper.csv", header), tmp_path / "model.json"
    proc = _run(_argv(data, out, *units, "--quiet"), tmp_path)
    assert proc.returncode == 0, proc.stderr
    model = io.load(out)
    assert model.features_["inputs"] == ["defl", "rate"]
    assert model.features_["output"] == "force" and model.features_["units"] == SI
    U, F = _damper(50, seed=7)  # fresh points of the law inside the training box
    lo, hi = model.domain_
    inside = np.all((U >= lo) & (U <= hi), axis=1)
    assert inside.sum() > 30
    np.testing.assert_allclose(model.predict(U[inside]), F[inside], rtol=1e-9, atol=1e-6)
    obs = _steps(model)
    assert obs.shape[0] == 20 and np.all(np.isfinite(obs))
    # --quiet: the summary (and a warning of a winner at the search cap, which the linear law
    # may give: the candidates' errors are round-off) and the file, no candidate table,
    # nothing on stderr
    lines = [x for x in proc.stdout.splitlines() if not x.startswith("warning: the winner")]
    assert lines[0].startswith("model: lpr") and lines[-1] == f"model written to {out}"
    assert len(lines) == 4 and "mae (eq.9)" not in proc.stdout and "<- best" not in proc.stdout
    assert "OOB error (eq. 9 absolute) = " in lines[2] and " N   OOB" in lines[2]
    assert proc.stderr == ""


def test_without_quiet_the_table_and_the_training_share_are_shown(tmp_path):
    data = _csv(tmp_path / "damper.csv")
    proc = _run(
        _argv(data, tmp_path / "m.json", "--units", *(f"{k}={v}" for k, v in SI.items())), tmp_path
    )
    assert proc.returncode == 0, proc.stderr
    assert "mae (eq.9)" in proc.stdout and "<- best" in proc.stdout
    share = 100 * 61 / N_ROWS
    assert (
        f"training on 61 of {N_ROWS} rows ({share:.3g} %); the rest are out-of-bag" in proc.stderr
    )


def test_an_element_without_units_is_refused_with_the_fix_then_taken(tmp_path, capsys):
    data, out = _csv(tmp_path / "damper.csv"), tmp_path / "m.json"
    assert main(_argv(data, out)) == 0
    assert "note: no units given (--units)" in capsys.readouterr().err
    model = io.load(out)
    with pytest.raises(
        ValueError, match=r"^surrogate input 'defl' has no unit in features\.units"
    ) as exc:
        _steps(model, 1)
    message = str(exc.value)
    for fix in (
        "surrogates build DATA.csv --inputs defl rate --target force "
        "--units defl=m rate=m/s force=N",
        "surrogates.build(U, V, ..., inputs=['defl', 'rate'], output='force', units=",
        "surrogates.io.save(model, path, units=",
        "model.features_['units'] = {'defl': 'm', 'rate': 'm/s', 'force': 'N'}",
    ):
        assert fix in message
    model.features_["units"] = dict(SI)  # the last fix the message names
    assert np.all(np.isfinite(_steps(model, 5)))


@pytest.mark.parametrize(
    ("header", "extra", "texts"),
    [
        ("defl,rate,force", ["--units", "defl=m"], ["--units", "no unit for ['rate', 'force']"]),
        ("defl [m],rate,force [N]", [], ["--units", "no unit for ['rate']", "CSV header"]),
        (
            "defl,rate,force",
            ["--units", *(f"{k}={v}" for k, v in SI.items()), "t=s"],
            ["--units names ['t']"],
        ),
        (
            "defl,rate,force",
            ["--units", "defl=meter", "rate=m/s", "force=N"],
            ["--units", "'meter' of 'defl' is not a known unit"],
        ),
        (
            "defl [metres],rate [m/s],force [N]",
            [],
            ["damper.csv: line 1", "'metres' of column 'defl'"],
        ),
        (
            "defl [m],rate [m/s],force [N]",
            ["--units", "defl=mm"],
            ["--units defl=mm contradicts the header", "defl [m]"],
        ),
        ("defl,rate,force", ["--units", "defl=m", "defl=m"], ["'defl' twice"]),
    ],
    ids=[
        "partial-flag",
        "partial-header",
        "unknown-name",
        "bad-unit",
        "bad-header-unit",
        "contradiction",
        "twice",
    ],
)
def test_bad_units_are_refused_at_build_time(tmp_path, capsys, header, extra, texts):
    data, out = _csv(tmp_path / "damper.csv", header), tmp_path / "m.json"
    assert main(_argv(data, out, "--quiet", *extra)) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    for text in texts:
        assert text in err
    assert not out.exists()


def test_partial_units_are_refused_in_a_fresh_process(tmp_path):
    data, out = _csv(tmp_path / "damper.csv"), tmp_path / "m.json"
    proc = _run(_argv(data, out, "--units", "defl=m"), tmp_path)
    assert proc.returncode == 2 and not out.exists()
    assert "--units: no unit for ['rate', 'force']" in proc.stderr
    assert "--units defl=m rate=UNIT force=UNIT" in proc.stderr


def test_help_shows_the_defaults_and_where_the_output_goes(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["build", "--help"])
    assert exc.value.code == 0
    text = " ".join(capsys.readouterr().out.split())  # argparse wraps the lines
    for default in ("lpr", "101", "ga", "oob"):
        assert f"(default: {default})" in text
    assert "--quiet prints the summary alone" in text and "stderr" in text


def _api_build(inputs=None, output=None, units=None):
    U, F = _damper(40)
    return surrogates.build(
        U,
        F,
        m=20,
        sampling="random",
        candidates=[(1, 1)],
        inputs=inputs,
        output=output,
        units=units,
    )


def test_readme_api_element_round_trips_names_and_units_into_the_env(tmp_path):
    U, F = _damper()
    model, _ = surrogates.build(
        U,
        F,
        kind="lpr",
        m=101,
        sampling="ga",
        selection="oob",
        units={"u1": "m", "u2": "m/s", "v": "N"},
    )
    path = io.save(model, tmp_path / "element.json")
    back = io.load(path)
    assert back.features_["inputs"] == ["u1", "u2"] and back.features_["output"] == "v"
    assert back.features_["units"] == {"u1": "m", "u2": "m/s", "v": "N"}
    assert np.all(np.isfinite(_steps(back)))
    # without names an element fitted here is taken as SI, and so is its file (issue 44: a
    # round trip does not change the answer): the same observations bit for bit
    bare, _ = _api_build()
    assert not hasattr(bare, "features_")
    io.save(bare, tmp_path / "bare.json")
    np.testing.assert_array_equal(_steps(io.load(tmp_path / "bare.json")), _steps(bare))


NAMES = st.lists(st.text(min_size=1, max_size=8), min_size=3, max_size=3, unique=True)
UNITS = st.none() | st.lists(st.sampled_from(sorted(KNOWN_UNITS)), min_size=3, max_size=3)


@settings(max_examples=25)
@given(names=NAMES, units=UNITS)
def test_save_load_keeps_names_and_units_exactly(tmp_path_factory, names, units):
    unit_map = None if units is None else dict(zip(names, units, strict=True))
    model, _ = _api_build(inputs=names[:2], output=names[2], units=unit_map)
    path = io.save(model, tmp_path_factory.mktemp("rt") / "element.json")
    back = io.load(path)
    assert back.features_["inputs"] == names[:2] and back.features_["output"] == names[2]
    assert back.features_["units"] == (unit_map or {})
    assert list(back.features_["units"]) == list(unit_map or {})
    assert json.loads(path.read_text())["features"]["units"] == (unit_map or {})
    np.testing.assert_array_equal(back.predict(_damper(5)[0]), model.predict(_damper(5)[0]))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"units": {"u1": "m"}}, r"units: no unit for \['u2', 'v'\].*units=\{'u1': 'm'"),
        ({"units": {"u1": "m", "u2": "m/s", "F": "N"}}, r"units names \['F'\]"),
        ({"units": {"u1": "m", "u2": "m/s", "v": "newton"}}, r"unit 'newton' of 'v'"),
        ({"inputs": ["a"]}, r"inputs names 1 inputs, the data has 2"),
        ({"inputs": ["a", "a"]}, r"inputs names \['a'\] more than once"),
        ({"inputs": ["a", "b"], "output": "a"}, r"output 'a' is also an input name"),
    ],
    ids=["partial", "unknown-name", "bad-unit", "count", "duplicate", "output-is-input"],
)
def test_build_refuses_bad_names_and_units(kwargs, message):
    with pytest.raises(ValueError, match=message):
        _api_build(**kwargs)


def test_the_unit_vocabulary_holds_the_env_and_fmu_units(tmp_path):
    from railgym.envs.track_shell import ELEMENT_OUTPUT_UNIT, ELEMENT_UNITS
    from surrogates.fmi.model_description import BASE_UNITS

    assert {*ELEMENT_UNITS, ELEMENT_OUTPUT_UNIT} <= KNOWN_UNITS
    assert set(BASE_UNITS) <= KNOWN_UNITS
    path = tmp_path / "d.csv"
    path.write_text("t [s],defl [mm],rate,force [kN]\n0,1,2,3\n0.1,2,3,4\n")
    cols, units = io.read_csv_units(path, ["defl", "force", "rate"])
    assert units == {"defl": "mm", "force": "kN"} and sorted(cols) == ["defl", "force", "rate"]
    assert sorted(io.read_csv(path)) == ["defl", "force", "rate", "t"]
