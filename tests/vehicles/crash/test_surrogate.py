"""Training samples of the crash elements' envelope: only those inside plastic flow."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from railgym.vehicles.crash.elements import envelope_runs
from railgym.vehicles.crash.scenario import load_scenario
from railgym.vehicles.crash.surrogate import (
    _unloading_stiffness,
    build_crash_surrogate,
    plastic_loading,
    virgin_loading,
)
from railgym.vehicles.crash.zone import absorber_zone_force

ZONE = load_scenario("paper").interface
KU = ZONE.unloading_stiffness
DT = 1e-3


def _law(crush: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Force (N) of the reference zone law along ``crush`` (m) with the absorber ``scale`` of
    each sample, and the scaled envelope there."""
    z, dp = ZONE, 0.0
    args = (z.stroke, z.force, len(z.stroke), z.fold_amplitude, z.fold_wavelength, KU)
    force, env = np.zeros(crush.size), np.zeros(crush.size)
    for i, (d, s) in enumerate(zip(crush, scale, strict=True)):
        force[i], dp = absorber_zone_force(d, dp, *args, z.absorber_stroke, s)
        env[i] = absorber_zone_force(d, -1.0, *args[:-1], np.inf, z.absorber_stroke, s)[0]
    return force, env


@settings(max_examples=40, deadline=None)
@given(
    speeds=st.lists(st.floats(-2.0, 6.0), min_size=4, max_size=12),
    scales=st.lists(st.sampled_from((0.7, 1.0, 1.3)), min_size=4, max_size=12),
    hold=st.integers(5, 60),
)
def test_every_selected_sample_lies_on_the_scaled_envelope(speeds, scales, hold):
    """Crush histories with unloading, reloading and absorber scale steps through the
    reference's own zone law: each sample the mask keeps carries the envelope's force."""
    n = min(len(speeds), len(scales)) * hold
    rate = np.repeat(speeds[: n // hold], hold)
    crush = np.clip(np.cumsum(rate * DT), 0.0, 1.7)
    scale = np.where(crush <= ZONE.absorber_stroke, np.repeat(scales[: n // hold], hold), 1.0)
    force, env = _law(crush, scale)
    mask = plastic_loading(crush, force, np.gradient(crush, DT), KU, scale=scale) & (force > 0)
    np.testing.assert_allclose(force[mask], env[mask], rtol=1e-9)


def test_a_stiff_absorbers_elastic_rise_is_not_taken_for_its_envelope():
    """Scale 1.3 on the interface's first rise: the scaled envelope (260 MN/m) is steeper
    than k_u (200 MN/m), so the crush runs up the elastic line to 6.5 mm. Samples at the
    largest crush so far (``virgin_loading``) take those forces for the envelope; the plastic
    mask does not, and the fitted envelope's first stage starts at its 1000 kN."""
    crush = np.linspace(0.0, 0.03, 301)
    scale = np.full(crush.size, 1.3)
    force, env = _law(crush, scale)
    rate = np.gradient(crush, DT)
    elastic = (crush > 0.005) & (crush < 0.0064)
    assert np.all(force[elastic] < 0.99 * env[elastic])
    assert np.all(virgin_loading(crush, rate)[elastic])
    mask = plastic_loading(crush, force, rate, KU, scale=scale)
    assert not mask[elastic].any() and mask[crush > 0.007][:-1].all()
    runs = envelope_runs("paper", speeds_kmh=(30.0,), scales=((1.3, 1.3), (1.0, 1.0)))
    wall = load_scenario("paper").wall
    knots = {"wall": (*wall.stroke,), "interface": (*ZONE.stroke,)}
    sur = build_crash_surrogate(runs, nodes_per_car=8, knots=knots, degrees=(1, 2, 4, 8, 16, 24))
    first = sur.elements["interface"].loading.predict(np.array([[0.0051], [0.0055]]))
    np.testing.assert_allclose(first, 1e6, rtol=0.01)  # 861 / 899 kN on virgin_loading


@settings(max_examples=20, deadline=None)
@given(ku=st.floats(5e7, 3e8), seed=st.integers(0, 2**16))
def test_unloading_stiffness_on_force_is_not_diluted_by_errors_in_the_crush(ku, seed):
    """Three elastic unloading lines of a known ``k_u``, each with its own permanent set,
    whose crush carries a seeded error (RMS 0.05 mm, as a reconstructed crush does): crush
    fitted on force gives ``k_u`` within 2 %, and the lines' levels do not leak into it."""
    rng = np.random.default_rng(seed)
    u, f, series = [], [], []
    for k, (u_p, f_top) in enumerate(((0.3, 2e6), (0.8, 3e6), (1.5, 2.5e6))):
        ff = np.linspace(f_top, 0.05 * f_top, 20)
        u.append(u_p + ff / ku + 5e-5 * rng.standard_normal(ff.size))
        f.append(ff)
        series.append(np.full(ff.size, k))
    uu, fv, sv = np.concatenate(u), np.concatenate(f), np.concatenate(series)
    on_force = _unloading_stiffness(uu, fv, np.full(uu.size, -1.0), sv, on_force=True)
    assert on_force == pytest.approx(ku, rel=0.02)
