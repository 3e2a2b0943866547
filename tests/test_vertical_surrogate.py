"""The packaged surrogate element and its accuracy against the reference model (eq. 9)."""

import numpy as np
import pytest

from railgym.vehicles.collect import (
    build_vertical_surrogate,
    collect_vertical,
    default_vertical_surrogate,
)
from surrogates.metrics import average_absolute_error, rms_normalised_error


@pytest.fixture(scope="module")
def packaged():
    return default_vertical_surrogate()


def test_rebuilding_the_packaged_surrogate_gives_the_same_model(packaged):
    model, report, data = build_vertical_surrogate(m=101)
    assert model.degree == packaged.degree
    U = data["U"]
    # the same element up to rounding of the least-squares solve on another machine
    np.testing.assert_allclose(model.predict(U), packaged.predict(U), rtol=1e-8, atol=1e-6)
    assert packaged.metadata_["report"]["chosen"] == report.to_dict()["chosen"]
    assert data["U"].shape == (1001, 2)  # 20 s at 50 Hz, as in the paper


def _errors(track_class, model, seed=1, duration=20.0):
    ref = collect_vertical(track_class=track_class, seed=seed, duration=duration)
    sur = collect_vertical(
        "surrogate", track_class=track_class, seed=seed, duration=duration, surrogate=model
    )
    assert not sur["diverged"]
    return {k: average_absolute_error(sur[k], ref[k]) for k in ("x2", "v2", "a2")} | {
        "nrms_a2": rms_normalised_error(sur["a2"], ref["a2"]),
        "rms_a2": float(np.sqrt(np.mean(ref["a2"] ** 2))),
    }


def test_surrogate_matches_reference_on_the_training_class(packaged):
    # unseen track (seed 1) of the training class 5 at 144 km/h; stated bounds
    e = _errors(5, packaged)
    assert e["x2"] < 1.0e-3  # m   (measured 0.6 mm against a 11 mm mean |x2|)
    assert e["v2"] < 8.0e-3  # m/s
    assert e["a2"] < 0.06  # m/s²
    assert e["nrms_a2"] < 0.10


@pytest.mark.parametrize("track_class, bound", [(6, 0.2), (3, 1.0), (4, 1.5)])
def test_surrogate_stays_finite_on_other_track_classes(packaged, track_class, bound):
    """Paper table 8: trained on class 5, run on classes 3, 4, 6 (at their own speeds).

    Class 6 is smoother and stays inside the training box. Classes 3 and 4 drive the
    reference into its bump stops, which the class-5 data never showed: the element
    extrapolates linearly (no blow-up like the paper's Kriging on class 4), but its
    acceleration error there is of the order of the signal (measured 0.55 and 0.84 relative
    RMS) — the same loss of accuracy the paper reports for class 4.
    """
    e = _errors(track_class, packaged)
    assert all(np.isfinite(v) for v in e.values())
    assert e["nrms_a2"] < bound
