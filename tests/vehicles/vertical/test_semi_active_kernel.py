"""The damper element (:mod:`railgym.vehicles.semi_active_element`) inside the kernels: the
``"element"`` law of :class:`~railgym.vehicles.vertical.elements.DamperLaw` against an independent
integration with the fitted model's own ``predict``."""

from __future__ import annotations

import numpy as np
import pytest

from railgym.track import track_time_input
from railgym.vehicles.semi_active import load_damper
from railgym.vehicles.semi_active_element import load_damper_element
from railgym.vehicles.vehicle.damper import DAMPER_COLUMNS, damper_stage
from railgym.vehicles.vehicle.model import N_MECH, Params, kernel_params
from railgym.vehicles.vehicle.params import load_whole_vehicle
from railgym.vehicles.vertical.elements import DAMPER_LAWS
from railgym.vehicles.vertical.kernels import (
    advance_semi_active,
    check_variant,
    damper_law,
    initial_state,
    step_outputs,
    surrogate_arrays,
)
from railgym.vehicles.vertical.params import load_vehicle

DAMPER = load_damper("mr_secondary")
ELEMENT = load_damper_element("mr_secondary")
DT, N_SUB, STEPS = 1e-3, 10, 40


def _predict(v: float, u: float, m: float) -> float:
    """The element's force from the fitted model (not the kernels' power basis), with the
    passivity cut; ``u`` and ``m`` clipped to the training box (as the element does), ``v``
    inside it."""
    lo, up = ELEMENT.model.lower_, ELEMENT.model.upper_
    assert lo[0] <= v <= up[0], "the run left the element's velocity range"
    x = np.array([v, np.clip(u, lo[1], up[1]), np.clip(m, lo[2], up[2])])
    f = float(ELEMENT.model.predict(x[None, :])[0])
    return f if f * v > 0.0 else 0.0


def _rates(x: np.ndarray, zc: float, zdc: float, command: float, p) -> np.ndarray:
    """Linear quarter car with the element between bogie and carbody (state
    ``[x1, v1, x2, v2, u, m]``), written out in numpy."""
    d, dd = x[0] - x[2], x[1] - x[3]
    fs = p.k2 * d + p.c2 * dd
    fd = _predict(dd, x[4], x[5])
    return np.array(
        [
            x[1],
            (p.k1 * (zc - x[0]) + p.c1 * (zdc - x[1]) - fs - fd) / p.m1,
            x[3],
            (fs + fd) / p.m2,
            ELEMENT.eta * (command - x[4]),
            dd - abs(dd) * x[5] / ELEMENT.length,
        ]
    )


def test_damper_law_of_an_element_takes_its_arrays_and_filter():
    exact, element = damper_law(DAMPER), damper_law(DAMPER, ELEMENT)
    assert exact.law == DAMPER_LAWS["exact"] and element.law == DAMPER_LAWS["element"]
    assert element.params.eta == ELEMENT.eta and element.element.length == ELEMENT.length
    np.testing.assert_array_equal(element.element.coef, ELEMENT.arrays().coef)
    assert exact.element.coef.dtype == element.element.coef.dtype == np.float64
    assert exact.element.coef.ndim == element.element.coef.ndim == 3
    with pytest.raises(TypeError, match="DamperElement"):
        damper_law(DAMPER, ELEMENT.arrays())


def test_kernel_with_the_element_equals_an_independent_integration():
    """40 control steps of the linear vehicle on a class-5 track with random held commands:
    the kernel's state, damper force and carbody acceleration equal an RK4 written here with
    the model's ``predict`` (same track midpoints), within rounding of the power basis."""
    veh = load_vehicle("manchester")
    p = veh.kernel_params()
    tr = track_time_input(5, 44.0, STEPS * N_SUB * DT, DT, 3, wheelbase=2.56)
    z, zd = tr.z[None, :], tr.zdot[None, :]
    law = damper_law(DAMPER, ELEMENT)
    state = initial_state("linear", 1, damper=True)
    out, f_d = step_outputs(1), np.zeros(1)
    commands = np.random.default_rng(4).uniform(0.0, 1.0, STEPS)
    x = state[0].copy()
    forces = []
    for k, c in enumerate(commands):
        advance_semi_active(
            check_variant("linear"),
            state,
            z,
            zd,
            np.array([k * N_SUB]),
            N_SUB,
            DT,
            np.array([c]),
            p.record(),
            surrogate_arrays(),
            law,
            out,
            f_d,
        )
        for j in range(k * N_SUB, (k + 1) * N_SUB):
            za, zda, zb, zdb = z[0, j], zd[0, j], z[0, j + 1], zd[0, j + 1]
            zm = 0.5 * (za + zb) + DT / 8.0 * (zda - zdb)
            zdm = 1.5 / DT * (zb - za) - 0.25 * (zda + zdb)
            r1 = _rates(x, za, zda, c, p)
            r2 = _rates(x + 0.5 * DT * r1, zm, zdm, c, p)
            r3 = _rates(x + 0.5 * DT * r2, zm, zdm, c, p)
            r4 = _rates(x + DT * r3, zb, zdb, c, p)
            x = x + DT / 6.0 * (r1 + 2.0 * r2 + 2.0 * r3 + r4)
        scale = np.maximum(np.abs(x), 1e-9)
        np.testing.assert_allclose(state[0], x, rtol=0, atol=1e-7 * scale.max())
        assert abs(state[0][5] - x[5]) <= 1e-7 * ELEMENT.length
        f_ref = _predict(x[1] - x[3], x[4], x[5])
        assert f_d[0] == pytest.approx(f_ref, rel=1e-7, abs=1e-6)
        ke = (k + 1) * N_SUB
        assert out.acc[0, 1] == pytest.approx(
            _rates(x, z[0, ke], zd[0, ke], c, p)[3], rel=1e-7, abs=1e-7
        )
        forces.append(f_d[0])
    assert np.abs(forces).max() > 100.0  # the element works in this run
    assert np.count_nonzero(forces) > STEPS // 2


def test_whole_vehicle_damper_stage_runs_the_element_at_both_bogies():
    """``damper_stage`` with the element law: each bogie's force is the element's at that
    bogie's compression rate, ``u̇ = η (command − u)`` and ``ṁ = v − |v| m/ℓ``."""
    params: Params = kernel_params(load_whole_vehicle())
    law = damper_law(DAMPER, ELEMENT)
    rng = np.random.default_rng(7)
    hits = 0
    for _ in range(20):
        state = np.zeros(N_MECH + DAMPER_COLUMNS)
        state[7:N_MECH] = rng.uniform(-0.05, 0.05, 7)  # rates of carbody and bogies
        state[8] *= 0.1  # pitch rate, rad/s (the carbody's ends at ±a move faster)
        state[N_MECH:] = np.column_stack(
            [rng.uniform(0, 1, 2), rng.uniform(-2e-3, 2e-3, 2)]
        ).ravel()
        command = rng.uniform(0.0, 1.0, 2)
        force, rates = np.zeros(2), np.zeros(state.size)
        damper_stage(state, params, law, command, force, rates)
        for b in range(2):
            xb = params.a if b == 0 else -params.a
            v = state[10 + 2 * b] - (state[7] + xb * state[8] + params.phi_a * state[9])
            j = N_MECH + 2 * b
            u, m = state[j], state[j + 1]
            assert force[b] == pytest.approx(_predict(v, u, m), rel=1e-7, abs=1e-6)
            assert force[b] * v >= 0.0
            hits += force[b] != 0.0
            assert rates[j] == pytest.approx(ELEMENT.eta * (command[b] - u))
            assert rates[j + 1] == pytest.approx(v - abs(v) * m / ELEMENT.length)
    assert hits > 10
