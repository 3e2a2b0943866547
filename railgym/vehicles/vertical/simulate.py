"""Recorded simulations of one vertical vehicle and the element characteristic curves.

:func:`simulate` drives the same compiled step (:mod:`~railgym.vehicles.vertical.kernels`)
as the envs, with ``n = 1``, recording after every control interval.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numba import njit

from railgym import _checks as val
from railgym.vehicles.vertical.elements import (
    LprArrays,
    bump_stop_force,
    damper_force,
    dynamic_element,
    rhs,
)
from railgym.vehicles.vertical.kernels import (
    RAISE_MODE,
    advance_kind,
    check_variant,
    initial_state,
    state_size,
    step_outputs,
    surrogate_arrays,
)
from railgym.vehicles.vertical.params import VerticalVehicle
from surrogates.models.lpr import lpr_scratch

__all__ = ["element_response", "simulate"]


class _Record(NamedTuple):
    """Recording buffers of :func:`_simulate_loop` (rows: the recorded instants)."""

    x: np.ndarray  #: float64 (m, s) states
    acc: np.ndarray  #: float64 (m, 2) accelerations, m/s²
    fs: np.ndarray  #: float64 (m,) secondary-suspension force, N
    counts: np.ndarray  #: int64 (2,) contacts, out-of-domain evaluations

    @classmethod
    def zeros(cls, m: int, s: int) -> _Record:
        """Zeroed buffers of ``m`` instants of ``s`` states."""
        return cls(np.zeros((m, s)), np.zeros((m, 2)), np.zeros(m), np.zeros(2, np.int64))


@njit(cache=True)
def _simulate_loop(kind, state, z, zdot, every, dt, fa, p, lpr, rec, out):
    """Run ``fa.size`` control steps of ``every`` substeps, recording after each; returns the
    number of completed steps (fewer if the run diverged)."""
    s = state.shape[1]
    dx = np.empty(s)
    u = np.empty(lpr.lo.shape[0])
    lw = lpr_scratch(lpr.exps, lpr.lo, lpr.up)
    fs, _ = rhs(
        kind, state[0], z[0, 0], zdot[0, 0], fa[0] if fa.size > 0 else 0.0, p[0], lpr, u, lw, dx
    )
    rec.x[0] = state[0]
    rec.acc[0, 0] = dx[1]
    rec.acc[0, 1] = dx[3]
    rec.fs[0] = fs
    k0 = np.zeros(1, np.int64)
    f1 = np.empty(1)
    for m in range(fa.size):
        k0[0] = m * every
        f1[0] = fa[m]
        advance_kind(kind, state, z, zdot, k0, every, dt, f1, p, lpr, out)
        rec.counts[0] += out.count[0, 0]
        rec.counts[1] += out.count[0, 1]
        if out.div[0]:
            return m
        rec.x[m + 1] = state[0]
        rec.acc[m + 1, 0] = out.acc[0, 0]
        rec.acc[m + 1, 1] = out.acc[0, 1]
        rec.fs[m + 1] = out.force[0]
    return fa.size


def simulate(
    variant: str,
    vehicle: VerticalVehicle,
    z: Any,
    zdot: Any,
    dt: float,
    force_a: Any = None,
    surrogate: Any = None,
    sample_every: int = 1,
    x0: Any = None,
) -> dict[str, Any]:
    """Simulate one vehicle over a sampled track input (for data collection).

    Parameters
    ----------
    variant
        One of ``VARIANTS``.
    z, zdot
        Track displacement (m) and velocity (m/s) sampled at ``dt``, shape (N+1,).
    dt
        Integration step, s.
    force_a
        Actuator force (N): ``None`` (zero), a scalar, or one value per recorded interval,
        shape (N // sample_every,), held over that interval.
    surrogate
        Fitted LPR or Kriging model (or an LPR's ``kernel_arrays()``), required for
        ``"surrogate"``. With the ``"raise"`` extrapolation policy an input outside the
        training box raises ``ValueError``.
    sample_every
        Record every ``sample_every``-th step (the substeps of one kernel call).
    x0
        Initial state (``state_size(variant, element)``,); default the static equilibrium.
        For a memory surrogate element the 4 mechanical states are enough: the Maxwell state
        then starts relaxed, ``s = x1 − x2``.

    Returns
    -------
    dict
        ``t, x1, v1, x2, v2, a1, a2, F_s`` (n_samples,) in SI, ``states`` (n_samples, s),
        for ``"dynamic"`` also ``dp_b, dp_r`` (Pa) and ``y`` (m); ``contacts`` (substeps in
        bump-stop contact), ``out_of_domain`` (surrogate stage evaluations), ``diverged``.
        Surrogate training pairs are ``u = (x1 − x2, v1 − v2)`` and ``v = F_s`` (equal to
        ``m2·a2`` when ``force_a`` is zero). After a divergence the record stops there.
    """
    kind = check_variant(variant)
    if not isinstance(vehicle, VerticalVehicle):
        raise ValueError(f"vehicle must be a VerticalVehicle, got {type(vehicle).__name__}")
    vehicle.require_variant(variant)
    z, zdot = _track_input(z, zdot)
    dt = val.positive(dt, "dt")
    sample_every = val.integer(sample_every, "sample_every", min=1)
    n_int = (z.size - 1) // sample_every
    fa = _actuator_force(force_a, n_int)
    if variant == "surrogate" and surrogate is None:
        raise ValueError("surrogate is required for variant 'surrogate'")
    lpr = surrogate_arrays(surrogate if variant == "surrogate" else None, dt, kriging=True)
    state = _start_state(variant, lpr, x0)
    rec = _Record.zeros(n_int + 1, state.shape[1])
    done = _simulate_loop(
        kind,
        state,
        z[None, :],
        zdot[None, :],
        sample_every,
        dt,
        fa,
        vehicle.kernel_params().record(),
        lpr,
        rec,
        step_outputs(1),
    )
    if lpr.mode == RAISE_MODE and rec.counts[1] > 0:
        raise ValueError(
            f"surrogate input left its training box ({int(rec.counts[1])} evaluations) and "
            "its extrapolation policy is 'raise'"
        )
    return _result(variant, rec, done, n_int, sample_every, dt)


def _track_input(z: Any, zdot: Any) -> tuple[np.ndarray, np.ndarray]:
    """``z`` (m) and ``zdot`` (m/s) as contiguous float arrays of one shape (N+1,), N ≥ 1."""
    z = np.ascontiguousarray(val.numeric_array(z, "z"))
    zdot = np.ascontiguousarray(val.numeric_array(zdot, "zdot"))
    if z.ndim != 1 or z.size < 2:
        raise ValueError(f"z must be 1-D with at least 2 samples, got shape {z.shape}")
    if zdot.shape != z.shape:
        raise ValueError(f"zdot has shape {zdot.shape}, expected {z.shape} like z")
    return z, zdot


def _actuator_force(force_a: Any, n_int: int) -> np.ndarray:
    """Actuator force (N) of each of the ``n_int`` recorded intervals (see :func:`simulate`)."""
    if force_a is None:
        return np.zeros(n_int)
    if np.ndim(force_a) == 0:
        return np.full(n_int, val.real(force_a, "force_a"))
    fa = val.numeric_array(force_a, "force_a")
    if fa.shape != (n_int,):
        raise ValueError(f"force_a must be a scalar or have shape ({n_int},), got {fa.shape}")
    return fa


def _start_state(variant: str, lpr: LprArrays, x0: Any) -> np.ndarray:
    """Initial state (1, s) of :func:`simulate`: ``x0`` or the static equilibrium."""
    s = state_size(variant, lpr)
    state = initial_state(variant, lpr=lpr)
    if x0 is not None:
        x0 = val.numeric_array(x0, "x0")
        if s == 5 and variant == "surrogate" and x0.shape == (4,):
            x0 = np.append(x0, x0[0] - x0[2])  # Maxwell state started relaxed, s = δ
        state[0] = val.numeric_array(x0, "x0", (s,))
    return state


def _result(
    variant: str, rec: _Record, done: int, n_int: int, sample_every: int, dt: float
) -> dict[str, Any]:
    """The record of :func:`simulate` up to sample ``done`` (every ``sample_every`` steps of
    ``dt`` s)."""
    m = done + 1
    out: dict[str, Any] = {
        "t": np.arange(m) * sample_every * dt,
        "x1": rec.x[:m, 0],
        "v1": rec.x[:m, 1],
        "x2": rec.x[:m, 2],
        "v2": rec.x[:m, 3],
        "a1": rec.acc[:m, 0],
        "a2": rec.acc[:m, 1],
        "F_s": rec.fs[:m],
        "states": rec.x[:m],
        "contacts": int(rec.counts[0]),
        "out_of_domain": int(rec.counts[1]),
        "diverged": done < n_int,
    }
    if variant == "dynamic":
        out["dp_b"], out["dp_r"], out["y"] = rec.x[:m, 4], rec.x[:m, 5], rec.x[:m, 6]
    return out


@njit(cache=True)
def _element_loop(kind, d, dd, dt, p, out):
    """Secondary element driven by a prescribed δ(t), δ̇(t); out (N+1, 7):
    total, spring, damper, bump-stop force, Δp_b, Δp_r, y."""
    rates = np.empty(3)
    r1 = np.empty(3)
    r2 = np.empty(3)
    r3 = np.empty(3)
    r4 = np.empty(3)
    st = np.zeros(3)
    stt = np.empty(3)
    for k in range(d.size):
        if kind == 2 and k > 0:
            dm = 0.5 * (d[k - 1] + d[k]) + 0.125 * dt * (dd[k - 1] - dd[k])
            ddm = 1.5 / dt * (d[k] - d[k - 1]) - 0.25 * (dd[k - 1] + dd[k])
            dynamic_element(d[k - 1], dd[k - 1], st[0], st[1], st[2], p, r1)
            for j in range(3):
                stt[j] = st[j] + 0.5 * dt * r1[j]
            dynamic_element(dm, ddm, stt[0], stt[1], stt[2], p, r2)
            for j in range(3):
                stt[j] = st[j] + 0.5 * dt * r2[j]
            dynamic_element(dm, ddm, stt[0], stt[1], stt[2], p, r3)
            for j in range(3):
                stt[j] = st[j] + dt * r3[j]
            dynamic_element(d[k], dd[k], stt[0], stt[1], stt[2], p, r4)
            for j in range(3):
                st[j] += dt / 6.0 * (r1[j] + 2.0 * r2[j] + 2.0 * r3[j] + r4[j])
        if kind == 0:
            spring = p.k2 * d[k]
            damp = p.c2 * dd[k]
            bump = 0.0
        elif kind == 1:
            spring = p.k2 * d[k] * (1.0 + p.progression * d[k] * d[k])
            damp = damper_force(dd[k], p)
            bump = bump_stop_force(d[k], p)
        else:
            spring, damp = dynamic_element(d[k], dd[k], st[0], st[1], st[2], p, rates)
            bump = bump_stop_force(d[k], p)
        out[k, 0] = spring + damp + bump
        out[k, 1] = spring
        out[k, 2] = damp
        out[k, 3] = bump
        out[k, 4] = st[0]
        out[k, 5] = st[1]
        out[k, 6] = st[2]


def element_response(
    variant: str, vehicle: VerticalVehicle, delta: Any, delta_dot: Any, dt: float
) -> dict[str, np.ndarray]:
    """Secondary-suspension force for a prescribed deflection history (characteristic curves).

    ``delta`` (m) and ``delta_dot`` (m/s) are sampled at ``dt`` (s), shape (N+1,); the
    dynamic element's internal states start at equilibrium and are integrated by RK4 with
    the same cubic Hermite midpoint rule as the vehicle kernels. Variants ``"linear"``,
    ``"static"``, ``"dynamic"``.

    Returns
    -------
    dict
        ``force`` (total), ``spring`` (air spring or spring), ``damper``, ``bump_stop`` in N;
        ``dp_b``, ``dp_r`` (Pa) and ``y`` (m) for ``"dynamic"`` (zeros otherwise).
    """
    kind = check_variant(variant)
    if variant == "surrogate":
        raise ValueError("element_response needs a physical variant: linear, static or dynamic")
    vehicle.require_variant(variant)
    d = np.ascontiguousarray(val.numeric_array(delta, "delta"))
    dd = np.ascontiguousarray(val.numeric_array(delta_dot, "delta_dot"))
    if d.ndim != 1 or d.shape != dd.shape:
        raise ValueError(
            f"delta and delta_dot must be 1-D of equal length, got {d.shape}, {dd.shape}"
        )
    dt = val.positive(dt, "dt")
    out = np.empty((d.size, 7))
    _element_loop(kind, d, dd, dt, vehicle.kernel_params(), out)
    keys = ("force", "spring", "damper", "bump_stop", "dp_b", "dp_r", "y")
    return {k: out[:, i] for i, k in enumerate(keys)}
