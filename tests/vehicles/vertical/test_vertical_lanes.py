"""The SIMD lane kernel of the vertical surrogate equals the scalar kernel bit for bit.

Both integrate the same RK4 step with the same operations; the lane kernel takes the vehicles
``LANES`` at a time as structure-of-arrays rows, the scalar one vehicle after another. The
batches below run through bump-stop contact, inputs outside the element's box (the scalar
fallback of the lane kernel) and divergence, in full and partial blocks, serial and parallel,
with the Legendre recurrence and with the Hermite tables of a gridded element.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from railgym.track import track_time_input
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.vertical.kernels import (
    KERNELS,
    _advance_scalar,
    initial_state,
    step_outputs,
    surrogate_arrays,
)
from railgym.vehicles.vertical.lanes import (
    LANES,
    LANES_MIN,
    PARALLEL_MIN,
    advance_lanes,
    advance_lanes_parallel,
)
from railgym.vehicles.vertical.params import load_vehicle
from surrogates.models.lpr import LegendreRegression

P = load_vehicle("manchester").kernel_params().record()
N_SUB, DT = 10, 1e-3


def _product_element() -> LegendreRegression:
    """An additive element of form ``"maxwell_product"`` on the packaged memory element's
    box: its law plus a term in the product input δ·ζ."""
    base = default_vertical_surrogate("maxwell")
    lo, up = base.domain_
    U3 = lo + (up - lo) * np.random.default_rng(5).uniform(0.0, 1.0, (3000, 3))
    U = np.column_stack([U3, U3[:, 0] * U3[:, 2]])
    model = LegendreRegression(degree=(8, 8, 8, 2)).fit(U, base.predict(U3) + 4e7 * U[:, 3])
    model.features_ = {**base.features_, "form": "maxwell_product"}
    return model


ELEMENTS = {
    f"{form}{'-grid' * grid}": surrogate_arrays(
        _product_element() if form == "maxwell_product" else default_vertical_surrogate(form),
        grid=grid,
    )
    for form in ("maxwell", "static", "maxwell_product")
    for grid in (False, True)
}


def _batch(n: int, seed: int, severity: float) -> tuple:
    """Tracks scaled by up to ``severity`` and actuator forces up to 40 kN; every 7th vehicle
    gets 1e13 N (it diverges) and vehicle 3 a NaN force."""
    rng = np.random.default_rng(seed)
    rows = [track_time_input(6, 60.0, 0.5, DT, seed=seed + i) for i in range(n)]
    scale = rng.uniform(0.5, severity, (n, 1))
    z = np.stack([r[1] for r in rows]) * scale
    zdot = np.stack([r[2] for r in rows]) * scale
    fa = rng.uniform(-4e4, 4e4, n)
    fa[::7] = 1e13
    if n > 3:
        fa[3] = np.nan
    return z, zdot, fa


def _run(advance, lpr, z, zdot, fa, steps: int) -> list[np.ndarray]:
    """States and outputs after each of ``steps`` control steps."""
    n = z.shape[0]
    state = initial_state("surrogate", n, lpr)
    out = step_outputs(n)
    k0 = np.zeros(n, np.int64)
    rows = []
    for m in range(steps):
        k0[:] = m * N_SUB
        advance(state, z, zdot, k0, N_SUB, DT, fa, P, lpr, out)
        rows += [state.copy(), *(a.copy() for a in out)]
    return rows


def _scalar(state, z, zdot, k0, n_sub, dt, fa, p, lpr, out) -> None:
    _advance_scalar(3, state, z, zdot, k0, n_sub, dt, fa, p, lpr, out)


@pytest.mark.parametrize("form", list(ELEMENTS))
def test_lanes_equal_the_scalar_kernel_through_contact_extrapolation_and_divergence(form):
    lpr = ELEMENTS[form]
    n = 2 * LANES + 5  # two full blocks and a partial one
    z, zdot, fa = _batch(n, seed=1, severity=25.0)
    lanes = _run(advance_lanes, lpr, z, zdot, fa, steps=40)
    scalar = _run(_scalar, lpr, z, zdot, fa, steps=40)
    for a, b in zip(lanes, scalar, strict=True):
        np.testing.assert_array_equal(a, b)
    # the batch really exercised every path: contact, out-of-box inputs, divergence
    counts = sum(r for r in lanes[3::5])
    ever_div = np.logical_or.reduce(lanes[4::5])
    assert counts[:, 0].sum() > 0 and counts[:, 1].sum() > 0
    assert ever_div[::7].all() and ever_div[3] and not ever_div[1]
    assert np.isfinite(lanes[-5]).all()


@pytest.mark.parametrize("name", ["maxwell", "maxwell-grid", "maxwell_product"])
def test_parallel_lanes_equal_serial_lanes(name):
    lpr = ELEMENTS[name]
    z, zdot, fa = _batch(PARALLEL_MIN + 3, seed=4, severity=10.0)
    serial = _run(advance_lanes, lpr, z, zdot, fa, steps=6)
    parallel = _run(advance_lanes_parallel, lpr, z, zdot, fa, steps=6)
    for a, b in zip(serial, parallel, strict=True):
        np.testing.assert_array_equal(a, b)


@settings(max_examples=15, deadline=None)
@given(n=st.integers(LANES_MIN, 3 * LANES), seed=st.integers(0, 2**16))
def test_lanes_equal_scalar_for_any_batch_size(n, seed):
    lpr = ELEMENTS["maxwell"]
    z, zdot, fa = _batch(n, seed, severity=15.0)
    for a, b in zip(
        _run(advance_lanes, lpr, z, zdot, fa, steps=3),
        _run(_scalar, lpr, z, zdot, fa, steps=3),
        strict=True,
    ):
        np.testing.assert_array_equal(a, b)


def test_surrogate_kernel_takes_the_parallel_lanes_above_the_threshold():
    """``advance_surrogate`` (what the envs call) equals the scalar kernel on a batch that runs
    the parallel lane kernel."""
    lpr = ELEMENTS["maxwell"]
    z, zdot, fa = _batch(PARALLEL_MIN + 9, seed=7, severity=10.0)
    for a, b in zip(
        _run(KERNELS["surrogate"], lpr, z, zdot, fa, steps=3),
        _run(_scalar, lpr, z, zdot, fa, steps=3),
        strict=True,
    ):
        np.testing.assert_array_equal(a, b)


def test_lane_kernel_checks_the_track_window_and_the_memory_state():
    lpr = ELEMENTS["maxwell"]
    z, zdot, fa = _batch(LANES, seed=0, severity=1.0)
    state, out = initial_state("surrogate", LANES, lpr), step_outputs(LANES)
    k0 = np.full(LANES, z.shape[1] - N_SUB)  # one sample short
    with pytest.raises(ValueError, match="track index out of range"):
        advance_lanes(state, z, zdot, k0, N_SUB, DT, fa, P, lpr, out)
    with pytest.raises(ValueError, match="5 states"):
        advance_lanes(state[:, :4].copy(), z, zdot, k0 * 0, N_SUB, DT, fa, P, lpr, out)
