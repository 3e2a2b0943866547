"""The operating envelope of an element (:mod:`railgym.vehicles.element_envelope`): what the
packaged files declare against the designs they were built on, and the bounds."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from railgym.track import class_speed
from railgym.vehicles.collect import TRAINING_CASE, default_vertical_surrogate
from railgym.vehicles.collect_design import ENVELOPE
from railgym.vehicles.element_envelope import (
    OperatingEnvelope,
    design_envelope,
    element_envelope,
    parse_envelope,
)
from railgym.vehicles.vehicle.collect import VEHICLE_DESIGN, default_vehicle_surrogate


def test_the_packaged_memory_element_declares_its_design():
    """vertical_lpr.json was fitted on the envelope design: classes 3-6 at 0.7 and 1.0 of
    each class's maximum speed (a rebuild that drops the envelope fails here)."""
    got = element_envelope(default_vertical_surrogate())
    assert got == design_envelope(ENVELOPE) == OperatingEnvelope((3, 4, 5, 6), (0.7, 1.0))


@pytest.mark.parametrize("release", ["", "v0"])
def test_the_paper_run_elements_declare_class_5_at_its_speed(release):
    """vertical_lpr_static.json and v0's memory element: the paper's one class-5 run."""
    form = "static" if release == "" else "maxwell"
    got = element_envelope(default_vertical_surrogate(form, release))
    assert got == OperatingEnvelope((TRAINING_CASE["track_class"],), (1.0, 1.0))
    assert class_speed(5) * 3.6 == pytest.approx(TRAINING_CASE["speed_kmh"])


def test_the_whole_vehicle_element_declares_its_speeds_up_to_the_validated_factor():
    """vehicle_lpr.json: its design's classes and speed range (60-200 km/h), and at most
    each class's maximum speed, where its accuracy was measured (docs/validation.md)."""
    got = element_envelope(default_vehicle_surrogate())
    design = design_envelope(VEHICLE_DESIGN)
    assert got.track_classes == design.track_classes == (3, 4, 5, 6)
    assert got.speed == pytest.approx(design.speed) and design.speed_factor is None
    assert got.speed_factor == (0.0, 1.0)


def test_contains_each_bound_and_class():
    env = OperatingEnvelope((3, 4), (0.7, 1.0), (15.0, 30.0))
    assert env.contains(3, 0.7 * class_speed(3)) and env.contains(3, class_speed(3))
    assert not env.contains(3, 0.69 * class_speed(3))
    assert not env.contains(4, class_speed(4))  # 35.6 m/s: above the absolute bound
    assert not env.contains(5, class_speed(5))
    assert not env.contains(3, class_speed(3), measured=True)
    assert OperatingEnvelope((5,)).contains(5, 99.0)


@given(st.integers(1, 6), st.floats(0.0, 3.0), st.floats(0.0, 3.0))
def test_a_factor_envelope_is_the_interval_of_the_factor(track_class, lo, hi):
    lo, hi = min(lo, hi), max(lo, hi)
    env = parse_envelope({"track_classes": [track_class], "speed_factor": [lo, hi]})
    for f in (0.5 * lo, lo, 0.5 * (lo + hi), hi, 1.5 * hi + 1e-3):
        assert env.contains(track_class, f * class_speed(track_class)) is (lo <= f <= hi)


def test_the_document_round_trips():
    env = OperatingEnvelope((3, 4, 5, 6), (0.0, 1.0), (60 / 3.6, 200 / 3.6))
    assert parse_envelope(env.document()) == env
    assert parse_envelope({"track_classes": [6, 3, 3]}).track_classes == (3, 6)


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ({"track_classes": []}, r"^where\.track_classes must be a non-empty list"),
        ({"track_classes": [True]}, r"track_classes must be a non-empty list"),
        ({"track_classes": [3], "speed_factor": [0.1, float("nan")]}, r"two finite numbers"),
        ({"track_classes": [3], "speed": [-1.0, 3.0]}, r"^where\.speed must have 0 <= low"),
        ({"track_classes": [3], "speed": "fast"}, r"^where\.speed must be \[low, high\] \(m/s\)"),
        ({"track_classes": [3], "class": 3}, r"^where\.class is not a known field"),
        ("3-6", r"^where must be an object"),
    ],
)
def test_bad_envelopes_name_the_field(doc, message):
    with pytest.raises(ValueError, match=message):
        parse_envelope(doc, "where")


def test_an_element_without_metadata_has_no_envelope():
    class Fitted:
        pass

    assert element_envelope(Fitted()) is None
    fitted = Fitted()
    fitted.metadata_ = {"source": "x"}
    assert element_envelope(fitted) is None
