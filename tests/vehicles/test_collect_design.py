"""Tests of the envelope-wide data-collection designs of the vertical model."""

from __future__ import annotations

import numpy as np
import pytest

from railgym.vehicles.collect import collect_vertical
from railgym.vehicles.collect_design import (
    PAPER,
    CollectionDesign,
    band_limited_force,
    collect_design,
    design_named,
)
from railgym.vehicles.vertical.params import load_vehicle

SMALL = CollectionDesign(track_classes=(4, 6), speed_factors=(1.0,), seeds=(3,), duration=2.0)


def test_paper_design_reproduces_the_paper_collection():
    """The paper design's samples equal collect_vertical's (independent sampling path)."""
    short = CollectionDesign(
        track_classes=(5,), speeds=(40.0,), seeds=(0,), duration=2.0, f_max=0.0
    )
    ours = collect_design(short)
    ref = collect_vertical(track_class=5, speed=40.0, duration=2.0, sample_rate=50.0, seed=0)
    assert ours["U"].shape == (101, 2)
    np.testing.assert_array_equal(ours["U"], ref["U"])
    np.testing.assert_allclose(ours["V"], ref["V"], rtol=1e-12, atol=1e-9)
    assert design_named("paper") is PAPER
    assert PAPER.cases() == [(5, 40.0, 0)]


def test_envelope_runs_balance_forces_and_cover_more_states():
    data = collect_design(SMALL)
    runs = data["runs"]
    assert [(r["track_class"], r["excited"]) for r in runs] == [
        (4, False),
        (4, True),
        (6, False),
        (6, True),
    ]
    m2 = load_vehicle("manchester").m2
    for r in runs:
        # carbody: m2·ẍ2 = F_s + F_a, with F_a held over the step before each sample
        np.testing.assert_allclose(m2 * r["a2"][1:], r["force"][1:] + r["force_a"], atol=1e-6)
        assert r["rows"][1] - r["rows"][0] == 20  # 50 Hz of 1 ms steps
    excited = runs[3]
    assert np.max(np.abs(excited["force_a"])) == pytest.approx(8000.0)
    assert np.ptp(excited["delta"]) > np.ptp(runs[2]["delta"])  # the actuator widens the box
    assert data["U"].shape == (sum(r["rows"].size for r in runs), 2)
    again = collect_design(SMALL)
    np.testing.assert_array_equal(again["V"], data["V"])  # seeded: bit for bit


def test_band_limited_force_spectrum_and_peak():
    f = band_limited_force(4000, 1e-3, 5.0, 8000.0, seed=1)
    assert np.max(np.abs(f)) == pytest.approx(8000.0)
    spectrum = np.abs(np.fft.rfft(f))
    freq = np.fft.rfftfreq(4000, 1e-3)
    assert np.max(spectrum[freq > 5.0]) < 1e-9 * np.max(spectrum)
    np.testing.assert_array_equal(f, band_limited_force(4000, 1e-3, 5.0, 8000.0, seed=1))
    with pytest.raises(ValueError, match="band"):
        band_limited_force(100, 1e-3, 1.0, 8000.0, seed=1)  # below 1/(n·dt) = 10 Hz


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"track_classes": ()}, "track_classes"),
        ({"seeds": (-1,)}, "seeds"),
        ({"speed_factors": (0.0,)}, "speed_factors"),
        ({"f_max": -1.0}, "f_max"),
        ({"duration": float("nan")}, "duration"),
    ],
)
def test_bad_design_names_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        CollectionDesign(**kwargs)


def test_bad_design_name_and_sample_rate():
    with pytest.raises(ValueError, match="design must be one of"):
        collect_design("everything")
    with pytest.raises(ValueError, match="sample_rate"):
        collect_design(CollectionDesign(sample_rate=300.0, duration=1.0))


def test_paper_figures_are_parameters_of_the_build():
    """1001 samples / 101 training points are the paper's 20 s × 50 Hz and M; both change."""
    from railgym.vehicles.collect import build_vertical_surrogate

    model, report, data = build_vertical_surrogate(
        m=31, duration=5.0, sample_rate=20.0, sampling="greedy", candidates=[(2, 2), (3, 3)]
    )
    assert data["U"].shape == (101, 2) and report.m == 31 and report.n == 101
    env, _, edata = build_vertical_surrogate(
        m=31,
        design="envelope",
        duration=1.0,
        sample_rate=20.0,
        sampling="greedy",
        candidates=[(2, 2)],
    )
    # 4 classes × 2 speeds × (passive + excited) runs of 21 samples each
    assert edata["U"].shape == (16 * 21, 2) and len(edata["runs"]) == 16
    assert any(r["excited"] for r in edata["runs"])
