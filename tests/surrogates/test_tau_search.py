"""The τ the data ask for (surrogates.tau_search): the linear standard-linear-solid fit on a
synthetic Maxwell law with a known time constant, the bounded CV refinement, the edge flag
and the single check of the ``tau`` / ``--tau`` values."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from surrogates.memory import maxwell_state
from surrogates.tau_search import (
    DEFAULT_TAU_RANGE,
    LinearMemory,
    TauSearch,
    fit_linear_memory,
    memory_states,
    search_tau,
    tau_search,
)

K0, K1, C = 3.6e5, 4.7e5, 2.0e3  # N/m, N/m, N·s/m


def sls_runs(tau, n_runs=3, duration=12.0, rate=200.0, seed=0):
    """Runs of a standard linear solid (spring K0, dashpot C, spring K1 in series with a
    dashpot of relaxation time ``tau``) under a broadband deflection 0.1–25 Hz, the force
    integrated on a 10× finer grid (exact first-order hold) and sampled at ``rate``: ``force``
    at the ``rows`` after 5 τ, ``full`` at every sample."""
    rng = np.random.default_rng(seed)
    runs = []
    for _ in range(n_runs):
        fine = np.arange(0.0, duration, 0.1 / rate)
        f = np.geomspace(0.1, 25.0, 60)
        amp = 0.01 / np.sqrt(f) * rng.uniform(0.5, 1.0, f.size)
        ph = rng.uniform(0, 2 * np.pi, f.size)
        d = (amp * np.sin(2 * np.pi * np.outer(fine, f) + ph)).sum(axis=1)
        dd = (amp * 2 * np.pi * f * np.cos(2 * np.pi * np.outer(fine, f) + ph)).sum(axis=1)
        zeta = maxwell_state(d, fine, tau, 0.0)
        d, dd, zeta, t = d[::10], dd[::10], zeta[::10], fine[::10]
        rows = np.flatnonzero(t > 5 * tau)
        force = 500.0 + K0 * d + C * dd + K1 * zeta
        runs.append(
            {"t": t, "delta": d, "delta_dot": dd, "rows": rows, "force": force[rows], "full": force}
        )
    return runs


@pytest.mark.parametrize("tau", [10e-3, 64e-3, 150e-3])
def test_linear_fit_recovers_the_time_constant_and_the_loss_angle_peak(tau):
    fit = fit_linear_memory(sls_runs(tau), *DEFAULT_TAU_RANGE)
    assert fit.tau == pytest.approx(tau, rel=0.05)
    assert fit.k0 == pytest.approx(K0, rel=0.02) and fit.k1 == pytest.approx(K1, rel=0.02)
    assert fit.rms < 0.02 * fit.rms_static
    # without the dashpot, the loss angle peaks at f* = √(k0/k∞)/(2πτ), tan φ* = k1/(2√(k0 k∞))
    bare = LinearMemory(tau, K0, 0.0, K1, 0.0, 0.0)
    f_peak, phi = bare.loss_peak((0.05, 200.0))
    kinf = K0 + K1
    assert f_peak == pytest.approx(math.sqrt(K0 / kinf) / (2 * math.pi * tau), rel=0.02)
    assert math.tan(math.radians(phi)) == pytest.approx(K1 / (2 * math.sqrt(K0 * kinf)), rel=1e-3)


def test_search_refines_a_score_in_log_tau_and_flags_a_range_end():
    true = 0.064

    def score(tau):
        return (math.log(tau / true)) ** 2 + 1.0

    found = search_tau(score, TauSearch(2e-3, 1.0), guess=0.02)  # the guess is 3.2× off
    assert found.best == pytest.approx(true, rel=0.05)
    assert found.edge is None
    assert len(found.scores) < 40
    edge = search_tau(score, TauSearch(2e-3, 0.03), guess=0.01)
    assert edge.edge == "upper" and edge.best == pytest.approx(0.03, rel=0.06)
    low = search_tau(score, TauSearch(0.2, 1.0))
    assert low.edge == "lower"
    values = search_tau(score, TauSearch(4e-3, 16e-3, (4e-3, 8e-3, 16e-3)))
    assert values.best == 16e-3 and values.edge == "upper"
    assert [t for t, _ in values.scores] == [4e-3, 8e-3, 16e-3]


@pytest.mark.parametrize(
    "value, expected",
    [
        (None, TauSearch(*DEFAULT_TAU_RANGE)),
        (0.05, TauSearch(0.05, 0.05, (0.05,))),
        ([0.01, 0.2], TauSearch(0.01, 0.2)),
        ((0.016, 0.004, 0.008), TauSearch(0.004, 0.016, (0.004, 0.008, 0.016))),
    ],
)
def test_tau_values(value, expected):
    assert tau_search(value) == expected
    assert tau_search(expected) == expected


@pytest.mark.parametrize(
    "value, match",
    [
        ([0.2, 0.01], "LO < HI"),
        ([0.0], "> 0"),
        ([float("nan"), 0.1], "finite"),
        ([-0.01, 0.1, 0.2], "> 0"),
        ([0.01, 0.01, 0.02], "distinct"),
        ([], "needs one value"),
        ("0.1", "one time constant"),
        ([True, 0.1], "time constants"),
    ],
)
def test_bad_tau_values_name_the_parameter(value, match):
    with pytest.raises(ValueError, match=match) as err:
        tau_search(value, "--tau")
    assert str(err.value).startswith("--tau")


def test_memory_states():
    assert memory_states(None) is None
    assert memory_states(0) == 0 and memory_states(1) == 1
    for bad in (2, -1, 1.0, True):
        with pytest.raises(ValueError, match="memory_states"):
            memory_states(bad)


@given(
    st.lists(st.floats(1e-4, 10.0, allow_nan=False, allow_infinity=False), min_size=1, max_size=8)
)
def test_every_valid_spelling_is_one_search(values):
    if len(values) != 2 and len(set(values)) != len(values):
        with pytest.raises(ValueError, match="distinct"):
            tau_search(values, "--tau")
        return
    if len(values) == 2 and not values[0] < values[1]:
        with pytest.raises(ValueError, match="LO < HI"):
            tau_search(values, "--tau")
        return
    s = tau_search(values, "--tau")
    assert (s.lo, s.hi) == (min(values), max(values))
    assert s.values == (None if len(values) == 2 else tuple(sorted(values)))
    assert tau_search(s) is s
