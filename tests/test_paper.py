"""``railgym paper``: the quick report's tables and figures, and the Python RK4 co-simulation."""

from __future__ import annotations

import argparse
import math

import numpy as np
import pytest

from agents import paper
from agents.paper import OOB_NRMS_BOUND, PAPER_LABEL, make_report, simulate_python
from railgym.track import track_time_input
from railgym.vehicles.collect import collect_vertical
from railgym.vehicles.vertical import DIVERGENCE_DISPLACEMENT, load_vehicle, simulate
from surrogates.models.lpr import LegendreRegression

DT = 1e-3


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper")
    return out, make_report(out, quick=True, seed=0, progress=False)


def _sim_entries(report):
    """Every (label, entry) of a surrogate simulation in tables 5 and 8."""
    t5, t8 = report["table5"], report["table8"]
    for kind in ("lpr", "kriging"):
        for m, e in t5[kind].items():
            yield f"table5 {kind} M={m}", e
        for cls, row in t8["classes"].items():
            yield f"table8 {kind} class {cls}", row[kind]


# ------------------------------------------------------------------------- the report
def test_quick_report_has_every_table_with_finite_numbers(quick):
    _, r = quick
    plan = r["plan"]
    assert plan["quick"] and plan["sizes"] == [51, 101] and plan["duration_s"] == 5.0
    t3 = r["table3"]
    assert t3["m"] == 101 and t3["n"] == 1001
    for kind in ("lpr", "kriging"):
        for key in ("oob_error", "oob_error_normalised", "oob_nrms"):
            assert math.isfinite(t3[kind][key]) and t3[kind][key] > 0
    assert set(r["table5"]["lpr"]) == {51, 101} and set(r["table5"]["kriging"]) == {51}
    assert set(r["table8"]["classes"]) == {3, 4, 6}
    entries = list(_sim_entries(r))
    assert len(entries) == 3 + 6
    for label, e in entries:
        # an entry is either finite or explicitly marked diverged; with the extrapolation
        # guard none diverges (the paper's Kriging did, on class 4)
        assert not e["diverged"], label
        assert all(math.isfinite(e[q]) and e[q] > 0 for q in ("x", "v", "a")), label
        assert e["evaluations"] == 4 * 5000 and 0 <= e["out_of_domain"] <= e["evaluations"]
        assert e["t_end_s"] == pytest.approx(5.0)
    t6 = r["table6"]
    assert t6["reference_s"] > 0
    for kind in ("lpr", "kriging"):
        for e in t6[kind].values():
            assert e["T_t_fit_s"] > 0 and e["T_t_build_s"] >= e["T_t_fit_s"]
            assert e["predict_call_us"] > 0 and e["predict_point_us"] > 0
    assert t6["lpr"][51]["T_s_numba_s"] > 0 and t6["kriging"][51]["T_s_python_s"] > 0
    t10 = r["table10"]["variants"]["paper"]
    assert set(t10) == {"wall_loading", "wall_unloading", "interface_loading",
                        "interface_unloading"}  # fmt: skip
    for e in t10.values():
        assert 1 <= e["degree"] <= r["table10"]["max_degree"] and e["n_samples"] > e["degree"]
    t11 = r["table11"]["variants"]["paper"]
    for car in ("lead", "passenger"):
        assert all(math.isfinite(t11[car][q]) and t11[car][q] > 0 for q in ("x", "v", "a"))


def test_surrogates_track_the_reference(quick):
    """Eq. 9 errors well below the reference's own mean magnitude (a zero model scores 1)."""
    _, r = quick
    t5 = r["table5"]
    scale = t5["reference_mean_abs"]
    for e in [*t5["lpr"].values(), *t5["kriging"].values()]:
        for q in ("x", "v", "a"):
            assert e[q] < 0.6 * scale[q]
    # the crash surrogate's displacement error is a few cm on ~2 m of travel
    for car in ("lead", "passenger"):
        assert r["table11"]["variants"]["paper"][car]["x"] < 0.1


def test_lpr_oob_error_below_kriging_or_both_below_bound(quick):
    t3 = quick[1]["table3"]
    lpr, kr = t3["lpr"], t3["kriging"]
    assert lpr["oob_error_kind"] == kr["oob_error_kind"]
    assert lpr["oob_error"] < kr["oob_error"] or (
        lpr["oob_nrms"] < OOB_NRMS_BOUND and kr["oob_nrms"] < OOB_NRMS_BOUND
    )


def test_report_markdown_and_figures_exist(quick):
    out, r = quick
    text = (out / "report.md").read_text(encoding="utf-8")
    for title in ("Table 3", "Table 5", "Table 6", "Table 8", "Table 10", "Table 11"):
        assert f"## {title}" in text
    assert text.count(PAPER_LABEL) >= 6
    assert "diverged at" not in text
    assert len(r["figures"]) == 6
    for name in r["figures"]:
        data = (out / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000, name
        assert f"]({name})" in text


# -------------------------------------------------------- Python RK4 co-simulation
@pytest.fixture(scope="module")
def vehicle():
    return load_vehicle("manchester")


def test_python_loop_reproduces_the_linear_suspension(vehicle):
    """LPR of degree 1 fitted on F = k2·δ + c2·δ̇ is that law everywhere (linear
    extrapolation), so the Python loop must match the compiled ``linear`` variant."""
    rng = np.random.default_rng(1)
    U = rng.uniform([-0.02, -0.2], [0.02, 0.2], size=(50, 2))
    model = LegendreRegression(degree=1).fit(U, vehicle.k2 * U[:, 0] + vehicle.c2 * U[:, 1])
    _, z, zdot = track_time_input(4, 128 / 3.6, 2.0, DT, seed=3)
    got = simulate_python(model, vehicle, z, zdot, DT, sample_every=5)
    ref = simulate("linear", vehicle, z, zdot, DT, sample_every=5)
    assert got["out_of_domain"] > 0  # class 4 leaves the small box: extrapolation is exercised
    for key in ("x1", "v1", "x2", "v2", "a1", "a2", "F_s"):
        scale = np.max(np.abs(ref[key]))
        np.testing.assert_allclose(got[key], ref[key], rtol=0, atol=1e-9 * scale, err_msg=key)


def test_python_loop_matches_the_compiled_surrogate_kernel(vehicle):
    data = collect_vertical(track_class=5, speed=40.0, duration=5.0, seed=0)
    model = LegendreRegression(degree=(5, 4)).fit(data["U"], data["V"])
    _, z, zdot = track_time_input(4, 128 / 3.6, 2.0, DT, seed=1)
    got = simulate_python(model, vehicle, z, zdot, DT, sample_every=10)
    ref = simulate("surrogate", vehicle, z, zdot, DT, surrogate=model, sample_every=10)
    assert got["out_of_domain"] == ref["out_of_domain"] > 0
    assert got["evaluations"] == 4 * 2000 and not got["diverged"]
    np.testing.assert_allclose(got["t"], ref["t"])
    for key in ("x2", "v2", "a2"):
        np.testing.assert_allclose(got[key], ref[key], rtol=1e-7, atol=1e-9, err_msg=key)


def test_python_loop_flags_divergence(vehicle):
    """A negative secondary stiffness makes the carbody run away: flagged, record cut."""
    U = np.array([[-0.01, -0.1], [0.01, 0.1], [0.0, 0.05], [0.005, -0.05]])
    model = LegendreRegression(degree=1).fit(U, -5e6 * U[:, 0])
    _, z, zdot = track_time_input(5, 40.0, 5.0, DT, seed=0)
    got = simulate_python(model, vehicle, z, zdot, DT, sample_every=10)
    assert got["diverged"]
    assert got["t"][-1] < 5.0 and got["t"].size == got["x2"].size
    assert np.all(np.isfinite(got["x2"])) and np.max(np.abs(got["x2"])) <= DIVERGENCE_DISPLACEMENT


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"sample_every": 0}, "sample_every"), ({"dt": -1.0}, "dt"), ({"z": np.zeros(1)}, "z")],
)
def test_python_loop_bad_input(vehicle, kwargs, field):
    model = LegendreRegression(degree=1).fit(np.eye(3, 2), np.arange(3.0))
    args = {"model": model, "vehicle": vehicle, "z": np.zeros(11), "zdot": np.zeros(11),
            "dt": DT, **kwargs}  # fmt: skip
    if "z" in kwargs:
        args["zdot"] = np.zeros(1)
    with pytest.raises(ValueError, match=field):
        simulate_python(**args)


def test_python_loop_needs_a_two_input_model(vehicle):
    model = LegendreRegression(degree=1).fit(np.arange(3.0), np.arange(3.0))
    with pytest.raises(ValueError, match="2 inputs"):
        simulate_python(model, vehicle, np.zeros(11), np.zeros(11), DT)


# ------------------------------------------------------------------------------- CLI
def test_cli_arguments_and_run(quick, monkeypatch, capsys, tmp_path):
    parser = argparse.ArgumentParser()
    paper.add_arguments(parser)
    args = parser.parse_args([])
    assert (args.quick, str(args.out), args.seed) == (False, "railgym-paper", 0)
    args = parser.parse_args(["--quick", "--out", str(tmp_path), "--seed", "3"])
    calls = []

    def fake(out, quick, seed, progress):
        calls.append((out, quick, seed, progress))
        return quick_result

    quick_result = quick[1]
    monkeypatch.setattr(paper, "make_report", fake)
    assert paper.run(args) == 0
    assert calls == [(tmp_path, True, 3, True)]
    assert "report.md" in capsys.readouterr().out
