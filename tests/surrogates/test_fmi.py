"""FMI 2.0 export of Legendre elements: validation, simulation vs ``predict``, co-simulation."""

from __future__ import annotations

import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from surrogates import io
from surrogates.fmi import FMUExportError, export_fmu
from surrogates.fmi.export import CFLAGS, fmi_platform
from surrogates.fmi.model_description import fmi_names
from surrogates.models.kriging import Kriging
from surrogates.models.lpr import LegendreRegression
from tests.markers import needs_cc

fmpy = pytest.importorskip("fmpy", reason="the 'fmi' extra (fmpy) is not installed")
from fmpy.validation import validate_fmu  # noqa: E402

N_POINTS = 10_000
RTOL = 1e-12


def _element(policy: str, interactions: bool = False) -> LegendreRegression:
    """An LPR element of F(δ, δ̇) (or of three inputs with interactions) with units."""
    rng = np.random.default_rng(3)
    d = 3 if interactions else 2
    U = rng.uniform(-1.0, 1.0, size=(400, d)) * np.array([0.02, 0.3, 5.0][:d])
    V = 8e5 * U[:, 0] * (1 + 2e3 * U[:, 0] ** 2) + 2e4 * np.tanh(3 * U[:, 1])
    if interactions:
        V += 1e3 * U[:, 2] * U[:, 0] * 50
        model = LegendreRegression(degree=5, interactions=True, extrapolation=policy)
    else:
        model = LegendreRegression(degree=(7, 9), extrapolation=policy)
    model.fit(U, V)
    names = ["x1-x2", "v1-v2", "T (degC)"][:d]
    model.features_ = {
        "inputs": names,
        "output": "F_s",
        "units": {"x1-x2": "m", "v1-v2": "m/s", "F_s": "N"},
    }
    return model


def _points(model: LegendreRegression, seed: int = 0) -> np.ndarray:
    """10⁴ points in a box twice as wide as the training box (about 3/4 outside it)."""
    lo, up = model.domain_
    rng = np.random.default_rng(seed)
    return rng.uniform(lo - 0.5 * (up - lo), up + 0.5 * (up - lo), size=(N_POINTS, lo.size))


def _simulate(fmu: Path, U: np.ndarray, fmi_type: str) -> np.ndarray:
    """FMPy driven by an input table (one row per second); output of row k ↔ input k."""
    md = fmpy.read_model_description(str(fmu))
    ins = [v.name for v in md.modelVariables if v.causality == "input"]
    (out,) = [v.name for v in md.modelVariables if v.causality == "output"]
    n = U.shape[0]
    # co-simulation records after each step, with the inputs of the step's start: one extra row
    rows = n + (fmi_type == "CoSimulation")
    sig = np.zeros(rows, dtype=[("time", float)] + [(name, float) for name in ins])
    sig["time"] = np.arange(rows)
    for j, name in enumerate(ins):
        sig[name][:n] = U[:, j]
        sig[name][n:] = U[-1, j]
    res = fmpy.simulate_fmu(
        str(fmu),
        fmi_type=fmi_type,
        start_time=0.0,
        stop_time=rows - 1.0,
        output_interval=1.0,
        input=sig,
        output=[out],
    )
    y = res[out]
    return y[1:] if fmi_type == "CoSimulation" else y


def _relative_error(y: np.ndarray, v: np.ndarray) -> tuple[float, float]:
    """(max pointwise |y − v|/|v|, max |y − v| / max |v|)."""
    diff = np.abs(y - v)
    return float(np.max(diff / np.abs(v))), float(diff.max() / np.abs(v).max())


@needs_cc
@pytest.mark.parametrize("policy", ["linear", "clip"])
@pytest.mark.parametrize("interactions", [False, True])
def test_fmu_reproduces_predict_inside_and_outside_the_box(tmp_path, policy, interactions):
    model = _element(policy, interactions)
    fmu = export_fmu(model, tmp_path / "element.fmu")
    assert validate_fmu(str(fmu)) == []
    U = _points(model)
    lo, up = model.domain_
    assert np.mean(np.any((U < lo) | (U > up), axis=1)) > 0.5
    v = model.predict(U)
    for fmi_type in ("ModelExchange", "CoSimulation"):
        y = _simulate(fmu, U, fmi_type)
        assert y.shape == v.shape
        pointwise, scaled = _relative_error(y, v)
        # rounding of the term sum (another summation order than numpy's matmul): within
        # RTOL of the force scale everywhere, and pointwise except where terms cancel
        assert scaled < RTOL
        assert np.mean(np.abs(y - v) <= RTOL * np.abs(v)) > 0.999
        assert pointwise < 1e-10


@needs_cc
def test_raise_policy_matches_inside_and_errors_outside(tmp_path):
    model = _element("raise")
    fmu = export_fmu(model, tmp_path / "element.fmu", kind="me")
    assert validate_fmu(str(fmu)) == []
    lo, up = model.domain_
    U = np.random.default_rng(1).uniform(lo, up, size=(N_POINTS, 2))
    y = _simulate(fmu, U, "ModelExchange")
    assert _relative_error(y, model.predict(U))[1] < RTOL
    outside = np.array([[up[0] * 1.5, 0.5 * (lo[1] + up[1])]])
    with pytest.raises(ValueError, match="outside the training domain"):
        model.predict(outside)
    with pytest.raises(Exception, match="fmi2GetReal"):
        _simulate(fmu, outside, "ModelExchange")


@needs_cc
def test_model_description_names_units_and_sources(tmp_path):
    model = _element("linear")
    path = io.save(
        model,
        tmp_path / "model.json",
        **{
            "inputs": model.features_["inputs"],
            "output": "F_s",
            "units": model.features_["units"],
        },
    )
    fmu = export_fmu(path, tmp_path / "from_json.fmu", kind="cs")
    md = fmpy.read_model_description(str(fmu))
    by_name = {v.name: v for v in md.modelVariables}
    assert list(by_name) == ["x1_x2", "v1_v2", "F_s"]
    assert by_name["x1_x2"].unit == "m" and by_name["F_s"].unit == "N"
    assert "'x1-x2'" in by_name["x1_x2"].description
    # plain numbers, no Python reprs such as np.float64(...)
    lo, up = model.domain_
    assert f"training range [{float(lo[0])!r}, {float(up[0])!r}] m" in by_name["x1_x2"].description
    with zipfile.ZipFile(fmu) as zf:
        xml = zf.read("modelDescription.xml").decode()
    assert "np." not in xml and "float64" not in xml
    assert md.modelExchange is None and md.coSimulation is not None
    folder, ext = fmi_platform()
    with zipfile.ZipFile(fmu) as zf:
        names = set(zf.namelist())
    assert {
        "sources/element.c",
        "sources/element_data.h",
        "sources/fmi2Functions.h",
        f"binaries/{folder}/from_json{ext}",
        "resources/element.json",
    } <= names
    with pytest.raises(FileExistsError):
        export_fmu(path, fmu)


@needs_cc
def test_sources_build_alone_in_a_fresh_folder(tmp_path):
    """The FMU's sources compile with nothing but the C compiler, to the same element."""
    model = _element("linear")
    fmu = export_fmu(model, tmp_path / "element.fmu", binary=False)
    with zipfile.ZipFile(fmu) as zf:
        assert not any(n.startswith("binaries/") for n in zf.namelist())
        zf.extractall(tmp_path / "unpacked")
    fresh = tmp_path / "fresh"
    shutil.copytree(tmp_path / "unpacked" / "sources", fresh)
    cc = shutil.which("cc") or shutil.which("gcc")
    folder, ext = fmi_platform()
    lib = tmp_path / "unpacked" / "binaries" / folder / f"element{ext}"
    lib.parent.mkdir(parents=True)
    subprocess.run([cc, *CFLAGS, "-o", str(lib), "element.c", "-lm"], cwd=fresh, check=True)
    U = _points(model, seed=5)[:2000]
    y = _simulate(tmp_path / "unpacked", U, "ModelExchange")
    assert _relative_error(y, model.predict(U))[1] < RTOL


def test_missing_compiler_is_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv("CC", raising=False)
    with pytest.raises(FMUExportError, match="no C compiler found"):
        export_fmu(_element("linear"), tmp_path / "element.fmu")
    assert not (tmp_path / "element.fmu").exists()


def test_kriging_and_bad_kind_are_rejected(tmp_path):
    rng = np.random.default_rng(0)
    U = rng.uniform(size=(30, 2))
    kriging = Kriging().fit(U, U[:, 0] + U[:, 1] ** 2)
    with pytest.raises(FMUExportError, match="not supported"):
        export_fmu(kriging, tmp_path / "k.fmu")
    with pytest.raises(ValueError, match="kind must be one of"):
        export_fmu(_element("linear"), tmp_path / "e.fmu", kind="xx")


@given(st.lists(st.text(min_size=0, max_size=8), min_size=1, max_size=6))
def test_fmi_names_are_unique_c_identifiers(names):
    out = fmi_names(names)
    assert len(out) == len(names) and len(set(out)) == len(out)
    assert all(re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", n) for n in out)


@needs_cc
def test_cosimulation_with_fmpy_converges_to_the_native_embedded_run(tmp_path, load_example):
    """FMPy hosts the packaged vertical element as a CS slave coupled with the vehicle.

    Zero-order-hold (Jacobi) coupling is first order in the communication step H: the error
    against railgym's native embedded simulation halves with H (measured in docs/fmi.md:
    0.9 % relative RMS carbody acceleration at H = 1 ms, ratio 2.0 per halving).
    """
    from railgym.vehicles.collect import default_vertical_surrogate

    model = default_vertical_surrogate("static")  # the FMU element is memoryless
    fmu = export_fmu(model, tmp_path / "vertical.fmu", kind="cs")
    rows = load_example("fmu_cosimulation").coupling_errors(
        fmu, model, steps=(8, 4, 2), duration=2.0
    )
    for name in ("x2", "a2"):
        errors = np.array([r[name] for r in rows])
        ratios = errors[:-1] / errors[1:]
        assert np.all((ratios > 1.7) & (ratios < 2.3)), (name, errors)
    assert rows[-1]["a2"] < 0.03  # H = 2 ms


@needs_cc
def test_export_fmu_command(tmp_path, capsys):
    from surrogates.cli import main

    model = _element("clip")
    path = io.save(model, tmp_path / "model.json", **model.features_)
    fmu = tmp_path / "element.fmu"
    assert main(["export-fmu", str(path), "-o", str(fmu)]) == 0
    assert validate_fmu(str(fmu)) == []
    assert main(["export-fmu", str(path), "-o", str(fmu)]) == 2
    err = capsys.readouterr().err
    assert "pass --overwrite to replace it" in err and "overwrite=True" not in err
    assert main(["export-fmu", str(path), "-o", str(fmu), "--overwrite", "--fmu-kind", "me"]) == 0
    assert fmpy.read_model_description(str(fmu)).coSimulation is None


@needs_cc
def test_cosimulation_output_lags_one_interval_as_documented(tmp_path):
    """docs/fmi.md's worked example: FMPy's co-simulation row k holds F(u[k-1])."""
    u = np.linspace(0.0, 10.0, 50)
    model = LegendreRegression(degree=1).fit(u[:, None], 100.0 * u)
    model.features_ = {"inputs": ["u"], "output": "F", "units": {"u": "m", "F": "N"}}
    fmu = export_fmu(model, tmp_path / "element.fmu")
    sig = np.zeros(5, dtype=[("time", float), ("u", float)])
    sig["time"], sig["u"] = np.arange(5.0), [1.0, 2.0, 3.0, 4.0, 5.0]
    out = {}
    for kind in ("ModelExchange", "CoSimulation"):
        res = fmpy.simulate_fmu(
            str(fmu), fmi_type=kind, stop_time=4.0, output_interval=1.0, input=sig, output=["F"]
        )
        np.testing.assert_array_equal(res["time"], sig["time"])
        out[kind] = res["F"]
    predicted = model.predict(sig["u"][:, None])
    np.testing.assert_allclose(predicted, [100, 200, 300, 400, 500], rtol=1e-12)
    np.testing.assert_allclose(out["ModelExchange"], predicted, rtol=1e-12)
    np.testing.assert_allclose(out["CoSimulation"], [100, 100, 200, 300, 400], rtol=1e-12)
    np.testing.assert_allclose(out["CoSimulation"][1:], predicted[:-1], rtol=1e-12)
