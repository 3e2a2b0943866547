"""railgym.vehicles.element_plausibility: an element's linearisation at the static equilibrium
and its training box against the vehicle's linearised secondary suspension and reach."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from railgym.vehicles.collect import build_vertical_surrogate, default_vertical_surrogate
from railgym.vehicles.element_plausibility import (
    MAX_RATE,
    PLAUSIBLE_RATIO,
    REACH_FACTOR,
    element_plausibility,
    implausible_element_warning,
)
from railgym.vehicles.vehicle.collect import default_vehicle_surrogate
from railgym.vehicles.vehicle.params import load_whole_vehicle
from railgym.vehicles.vertical.params import load_vehicle
from surrogates import LegendreRegression

VEHICLE = load_vehicle("manchester")
K2, C2 = VEHICLE.k2, VEHICLE.c2


def _box(n=400, reach=(0.05, 0.5), seed=0, centre=(0.0, 0.0)):
    rng = np.random.default_rng(seed)
    return np.asarray(centre) + rng.uniform(-1.0, 1.0, (n, 2)) * np.asarray(reach)


def _linear(k, c, **box):
    """A degree-1 element ``F = k·δ + c·δ̇ + 50`` (N) on a box of (δ, δ̇)."""
    U = _box(**box)
    return LegendreRegression(degree=1).fit(U, k * U[:, 0] + c * U[:, 1] + 50.0)


def test_a_linear_element_measures_its_own_stiffness_and_damping():
    p = element_plausibility(_linear(3.0e5, 6.0e4), VEHICLE)
    assert p.stiffness == pytest.approx(3.0e5, rel=1e-9)
    assert p.damping == pytest.approx(6.0e4, rel=1e-9)
    assert (p.k2, p.c2) == (K2, C2) and p.at == (0.0, 0.0)
    assert p.stiffness_ratio == pytest.approx(3.0e5 / K2) and p.plausible


@pytest.mark.parametrize(
    ("factor", "plausible"),
    [(1.0, True), (0.21, True), (4.9, True), (0.19, False), (5.1, False), (-1.0, False)],
)
def test_the_band_of_the_stiffness_and_damping_ratios(factor, plausible):
    assert PLAUSIBLE_RATIO == (0.2, 5.0)
    stiff = element_plausibility(_linear(factor * K2, C2), VEHICLE)
    damp = element_plausibility(_linear(K2, factor * C2), VEHICLE)
    assert stiff.plausible is plausible and damp.plausible is plausible
    if not plausible:
        assert stiff.findings == (f"dF/dδ = {factor * K2:.3g} N/m against k2 = {K2:.3g} N/m",)
        assert damp.findings == (f"dF/dδ̇ = {factor * C2:.3g} N·s/m against c2 = {C2:.3g} N·s/m",)


def test_an_undamped_vehicle_has_no_damping_ratio():
    from dataclasses import replace

    undamped = replace(VEHICLE, c2=0.0)
    p = element_plausibility(_linear(K2, 0.0), undamped)
    assert p.plausible and math.isnan(p.damping_ratio)


@pytest.mark.parametrize(
    ("box", "finding"),
    [
        ({"reach": (REACH_FACTOR * 0.06 * 1.1, 0.5)}, r"δ ∈ \[.*\] m reaches beyond ±0\.6 m"),
        ({"reach": (0.05, MAX_RATE * 1.1)}, r"δ̇ ∈ \[.*\] m/s reaches beyond ±10 m/s"),
        ({"reach": (4e-4, 0.5)}, r"δ ∈ \[.*\] m is narrower than 0\.001 m"),
        ({"reach": (0.05, 4e-4)}, r"δ̇ ∈ \[.*\] m/s is narrower than 0\.001 m/s"),
        (
            {"reach": (0.01, 0.5), "centre": (0.03, 0.0)},
            r"δ ∈ \[0\.02.*\] m does not contain the static equilibrium δ = 0",
        ),
    ],
    ids=["wide deflection", "wide rate", "narrow deflection", "narrow rate", "off zero"],
)
def test_a_training_box_the_vehicle_cannot_fill_is_reported(box, finding):
    p = element_plausibility(_linear(K2, C2, **box), VEHICLE)
    assert len(p.findings) == 1 and re.search(finding, p.findings[0]), p.findings


def test_outside_the_box_the_slopes_are_those_of_its_nearest_point_and_no_count_changes():
    model = _linear(K2, C2, reach=(0.01, 0.5), centre=(0.03, 0.0))
    model.n_out_of_domain_ = 7
    p = element_plausibility(model, VEHICLE)
    assert p.at[0] == model.lower_[0] and p.at[1] == 0.0
    assert p.stiffness == pytest.approx(K2, rel=1e-9)  # one-sided at the face
    assert model.n_out_of_domain_ == 7


def _memory(k_s, tau, relaxation=None):
    """A linear memory element ``F = k2·δ + k_s·ζ`` (inputs δ, δ̇, ζ)."""
    rng = np.random.default_rng(3)
    U = rng.uniform(-1.0, 1.0, (400, 3)) * [0.05, 0.5, 0.005]
    model = LegendreRegression(degree=1).fit(U, K2 * U[:, 0] + k_s * U[:, 2])
    model.features_ = {"form": "maxwell", "tau": tau, "known_physics": ["bump_stop"]}
    if relaxation is not None:
        model.features_["relaxation"] = relaxation
    return model


def test_a_memory_elements_damping_is_its_low_frequency_value():
    """A stiffness k_s in series with a dashpot c (τ = c/k_s): ζ → τ·δ̇ for slow motion, so
    the damping is k_s·τ = c; a relaxation law's slope at 0 (mean of the two segments)
    plays 1/τ."""
    k_s, c = 6.0e6, 4.2e4
    p = element_plausibility(_memory(k_s, c / k_s), VEHICLE)
    assert p.stiffness == pytest.approx(K2, rel=1e-9)
    assert p.damping == pytest.approx(c, rel=1e-9) and p.plausible and p.at == (0.0,) * 3
    law = {"zeta": [-0.002, -0.001, 0.0, 0.001], "rate": [-0.5, -0.2, 0.0, 0.1]}  # 200, 100 /s
    p = element_plausibility(_memory(k_s, 0.002, law), VEHICLE)
    assert p.damping == pytest.approx(k_s / 150.0, rel=1e-9)


def test_packaged_and_project_built_elements_are_plausible():
    """The packaged elements and one built from the project's data on the packaged vehicle
    (the paper's static build) are the vehicle's suspension, within a few % of k2 and
    within 0.6–1.2 of c2 (the damper's two slopes meet at δ̇ = 0)."""
    whole = load_whole_vehicle("manchester_whole")
    built, _, _ = build_vertical_surrogate()
    elements = {
        "maxwell": (default_vertical_surrogate(), VEHICLE),
        "static": (default_vertical_surrogate("static"), VEHICLE),
        "v0": (default_vertical_surrogate("maxwell", "v0"), VEHICLE),
        "vehicle": (default_vehicle_surrogate(), whole),
        "built": (built, VEHICLE),
    }
    for name, (model, vehicle) in elements.items():
        p = element_plausibility(model, vehicle)
        assert p.plausible, (name, p.findings)
        assert 0.95 < p.stiffness_ratio < 1.05 and 0.6 < p.damping_ratio < 1.2, name
        assert implausible_element_warning(model, vehicle, name) is None


def test_the_warning_names_the_element_the_vehicle_and_the_ratios():
    U = _box(reach=(1.0, 1.0))
    model = LegendreRegression(degree=5).fit(U, np.sin(U[:, 0]) + U[:, 1] ** 2)
    text = implausible_element_warning(model, VEHICLE, "'other.json'")
    assert text is not None
    assert text.startswith(
        "surrogate 'other.json' does not look like the secondary suspension of vehicle "
        "'manchester': dF/dδ = 1 N/m against k2 = 8.6e+05 N/m; dF/dδ̇ = "
    )
    assert "reaches beyond ±0.6 m" in text and "dF/dδ / k2 = 1.16e-06" in text
    assert "both ratios in 0.2–5" in text and "docs/envs/vertical.md" in text
