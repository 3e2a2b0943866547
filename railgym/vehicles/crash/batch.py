"""Batch stepping (:func:`crash_batch_model`) for the gymnasium envs.

Either model of a scenario advanced sample by sample for many trains in one compiled call, with
a controllable absorber in every zone: a force scale per zone multiplies its loading envelope
(surrogate: its element force) up to the absorber stroke (:func:`absorber_zone_force`). With
all scales 1 it reproduces :func:`simulate_reference` and :func:`simulate_surrogate` step for
step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numba import njit

from railgym.vehicles.crash.reference import V_EPS, _build_chain, _chain_forces, _check_run, _steps
from railgym.vehicles.crash.scenario import CrashScenario, load_scenario
from railgym.vehicles.crash.surrogate import (
    CrashSurrogate,
    _element_force,
    _element_model,
    _lpr_work,
    _surrogate_system,
)
from surrogates.models.lpr import lpr_eval_into

__all__ = [
    "BATCH_BACKENDS",
    "BatchOutputs",
    "CrashBatchModel",
    "crash_batch_model",
    "reference_batch_step",
    "surrogate_batch_step",
]

#: models of :func:`crash_batch_model`
BATCH_BACKENDS = ("reference", "surrogate")


class BatchOutputs(NamedTuple):
    """What the batch kernels report after each call, one row per simulation.

    Attributes
    ----------
    x, v, a : (n, bodies) centre-of-mass displacement (m), velocity (m/s) and acceleration
        (m/s²) of each body (cars front to back, then the obstacle if any).
    crush : (n, zones) crush of each zone (surrogate: element feature ``u``), m.
    force : (n, zones) zone force, compression positive (coupler damping included), N.
    rate : (n, zones) closing rate of each zone, m/s.
    work : (n, zones) net work done on each zone since the start, J.
    dissipated : (n, 2) friction work and carbody/coupler damping work since the start, J.
    stored : (n,) kinetic energy plus elastic carbody energy, J.
    """

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    crush: np.ndarray
    force: np.ndarray
    rate: np.ndarray
    work: np.ndarray
    dissipated: np.ndarray
    stored: np.ndarray


@njit(cache=True)
def _healthy(x, v, a, limit):  # fmt: skip
    """True if every entry is finite and |x|, |v| ≤ ``limit``."""
    for j in range(x.shape[0]):
        if not (abs(x[j]) <= limit and abs(v[j]) <= limit and math.isfinite(a[j])):
            return False
    return True


@njit(cache=True)
def reference_batch_step(state, out, params, scale, active, init, dt, n_sub, limit, div):
    """Advance every ``active`` reference simulation by ``n_sub`` velocity-Verlet steps.

    Parameters
    ----------
    state : (x, v, a, dp, fz, fd, ff) node and zone arrays from
        :meth:`CrashBatchModel.new_state`, updated in place.
    out : :class:`BatchOutputs`; ``crush``, ``work`` and ``dissipated`` are also read back.
    params : static arrays of :attr:`CrashBatchModel.params`.
    scale : (n, zones) absorber force scale of each zone (:func:`absorber_zone_force`).
    active : (n,) which simulations to advance.
    init : evaluate the forces at the current state instead of stepping (after a reset).
    dt, n_sub : integration step (s) and number of steps.
    limit : a simulation whose |x| (m) or |v| (m/s) exceeds ``limit`` or that becomes
        non-finite keeps its state from before the call and gets ``div[i] = True``.
    """
    x, v, a, dp, fz, fd, ff = state
    (m, mu, g, veps, link_k, link_c, elem_zone, zone_type, zone_cc, zone_front, zone_back,
     t_s, t_f, t_n, t_amp, t_lam, t_ku, t_kt, t_slack, t_abs, body_start,
     body_end) = params  # fmt: skip
    N = m.shape[0]
    nz = zone_type.shape[0]
    nodes = np.empty((8, N))
    xl, vl, al, vp, F, dx, ffl, ff_o = (nodes[0], nodes[1], nodes[2], nodes[3], nodes[4],
                                        nodes[5], nodes[6], nodes[7])  # fmt: skip
    zones = np.empty((7, nz))
    dpl, fzl, fz_o, fzel, dzl, dz_o, wzl = (zones[0], zones[1], zones[2], zones[3], zones[4],
                                            zones[5], zones[6])  # fmt: skip
    fdl, fd_o = np.empty(fd.shape[1]), np.empty(fd.shape[1])
    for i in range(x.shape[0]):
        if not active[i]:
            continue
        xl[:], vl[:], al[:], dpl[:], fzl[:] = x[i], v[i], a[i], dp[i], fz[i]
        fdl[:], ffl[:], dzl[:], wzl[:] = fd[i], ff[i], out.crush[i], out.work[i]
        w_fric, w_damp = out.dissipated[i, 0], out.dissipated[i, 1]
        sc = scale[i]
        if init:
            _chain_forces(xl, vl, dpl, m, mu, g, veps, link_k, link_c, elem_zone, zone_type,
                          zone_cc, zone_front, zone_back, t_s, t_f, t_n, t_amp, t_lam, t_ku,
                          t_kt, t_slack, t_abs, sc, F, fzl, fzel, fdl, ffl, dzl)  # fmt: skip
            for j in range(N):
                al[j] = F[j] / m[j]
        for _ in range(0 if init else n_sub):
            fz_o[:], fd_o[:], ff_o[:], dz_o[:] = fzl, fdl, ffl, dzl
            for j in range(N):
                dx[j] = vl[j] * dt + 0.5 * al[j] * dt * dt
                xl[j] += dx[j]
                vp[j] = vl[j] + al[j] * dt
            _chain_forces(xl, vp, dpl, m, mu, g, veps, link_k, link_c, elem_zone, zone_type,
                          zone_cc, zone_front, zone_back, t_s, t_f, t_n, t_amp, t_lam, t_ku,
                          t_kt, t_slack, t_abs, sc, F, fzl, fzel, fdl, ffl, dzl)  # fmt: skip
            for j in range(N):
                a_new = F[j] / m[j]
                vl[j] += 0.5 * (al[j] + a_new) * dt
                al[j] = a_new
            for z in range(nz):
                wzl[z] += 0.5 * (fz_o[z] + fzl[z]) * (dzl[z] - dz_o[z])
            for e in range(N - 1):
                w_damp += 0.5 * (fd_o[e] + fdl[e]) * (dx[e + 1] - dx[e])
            for j in range(N):
                w_fric += 0.5 * (ff_o[j] + ffl[j]) * dx[j]
        if not _healthy(xl, vl, al, limit):
            div[i] = True
            continue
        x[i], v[i], a[i], dp[i], fz[i], fd[i], ff[i] = xl, vl, al, dpl, fzl, fdl, ffl
        out.crush[i], out.work[i] = dzl, wzl
        out.dissipated[i, 0], out.dissipated[i, 1] = w_fric, w_damp
        energy = 0.0
        for j in range(N):
            energy += 0.5 * m[j] * vl[j] * vl[j]
            if j < N - 1 and elem_zone[j] < 0:
                energy += 0.5 * link_k[j] * (xl[j + 1] - xl[j]) ** 2
        out.stored[i] = energy
        for z in range(nz):
            fr, bk = zone_front[z], zone_back[z]
            out.force[i, z] = fzl[z] + (fdl[bk - 1] if fr >= 0 else 0.0)
            out.rate[i, z] = vl[bk] - (vl[fr] if fr >= 0 else 0.0)
        for b in range(body_start.shape[0]):
            mb = sx = sv = sf = 0.0
            for j in range(body_start[b], body_end[b]):
                mb += m[j]
                sx += m[j] * xl[j]
                sv += m[j] * vl[j]
                sf += F[j]
            out.x[i, b], out.v[i, b], out.a[i, b] = sx / mb, sv / mb, sf / mb


@njit(cache=True)
def surrogate_batch_step(state, out, params, scale, active, init, dt, n_sub, limit, div):
    """:func:`reference_batch_step` for the surrogate model (paper eq. 4).

    ``state`` = (x, v, a, up, fel, ff) per body and element; ``params`` = (m, mu, g, v_ε,
    elements, types, lpr) as in :func:`_surrogate_kernel`. No dampers: ``dissipated[:, 1]``
    stays 0.
    """
    x, v, a, up, fel, ff = state
    m, mu, g, veps, elements, types, lpr = params
    el_front, el_back, el_type = elements[:, 0], elements[:, 1], elements[:, 2]
    variant, i_load, i_unload, unilateral = types[0].T
    ku, kt, slack, absorber = types[1].T
    E, C, LO, UP, MODE, FR = lpr
    N = m.shape[0]
    ne = el_front.shape[0]
    nodes = np.empty((8, N))
    xl, vl, al, vp, F, dx, ffl, ff_o = (nodes[0], nodes[1], nodes[2], nodes[3], nodes[4],
                                        nodes[5], nodes[6], nodes[7])  # fmt: skip
    els = np.empty((6, ne))
    upl, fl, f_o, ul, u_o, wl = els[0], els[1], els[2], els[3], els[4], els[5]
    ubuf = np.zeros(1)
    work = _lpr_work(lpr)
    ox, ov, oa, crush, force, rate_out, work_done, dissipated, stored = out
    # rows are copied element by element: a row view per array and train costs two atomic
    # reference-count operations, about a quarter of the time of a step of 1024 trains
    for i in range(x.shape[0]):
        if not active[i]:
            continue
        for j in range(N):
            xl[j], vl[j], al[j], ffl[j] = x[i, j], v[i, j], a[i, j], ff[i, j]
        for e in range(ne):
            upl[e], fl[e], ul[e], wl[e] = up[i, e], fel[i, e], crush[i, e], work_done[i, e]
        w_fric = dissipated[i, 0]
        # init: forces at the current state; else n_sub velocity-Verlet steps
        for _ in range(1 if init else n_sub):
            if init:
                vp[:] = vl
            else:
                f_o[:], ff_o[:], u_o[:] = fl, ffl, ul
                for j in range(N):
                    dx[j] = vl[j] * dt + 0.5 * al[j] * dt * dt
                    xl[j] += dx[j]
                    vp[j] = vl[j] + al[j] * dt
            for j in range(N):
                ffl[j] = mu[j] * m[j] * g * math.tanh(vp[j] / veps)
                F[j] = -ffl[j]
            for e in range(ne):
                fr, bk, ty = el_front[e], el_back[e], el_type[e]
                u = xl[bk] - (xl[fr] if fr >= 0 else 0.0)
                rate = vp[bk] - (vp[fr] if fr >= 0 else 0.0)
                mdl = _element_model(u, rate, upl[e], variant[ty], unilateral[ty], ku[ty],
                                     i_load[ty], i_unload[ty])  # fmt: skip
                f_lpr = f_min = f_max = 0.0
                if mdl >= 0:
                    ubuf[0] = u
                    f_lpr = lpr_eval_into(ubuf, E[mdl], C[mdl], LO[mdl], UP[mdl], MODE[mdl],
                                          work[mdl])  # fmt: skip
                    f_min, f_max = FR[mdl, 0], FR[mdl, 1]
                s = scale[i, e] if u <= absorber[ty] else 1.0
                f, upl[e] = _element_force(u, upl[e], f_lpr, f_min, f_max, s, variant[ty],
                                           unilateral[ty], ku[ty], kt[ty], slack[ty])  # fmt: skip
                fl[e] = f
                ul[e] = u
                if fr >= 0:
                    F[fr] += f
                F[bk] -= f
            for j in range(N):
                a_new = F[j] / m[j]
                if not init:
                    vl[j] += 0.5 * (al[j] + a_new) * dt
                    w_fric += 0.5 * (ff_o[j] + ffl[j]) * dx[j]
                al[j] = a_new
            if not init:
                for e in range(ne):
                    wl[e] += 0.5 * (f_o[e] + fl[e]) * (ul[e] - u_o[e])
        if not _healthy(xl, vl, al, limit):
            div[i] = True
            continue
        energy = 0.0
        for j in range(N):
            x[i, j], v[i, j], a[i, j], ff[i, j] = xl[j], vl[j], al[j], ffl[j]
            ox[i, j], ov[i, j], oa[i, j] = xl[j], vl[j], al[j]
            energy += 0.5 * m[j] * vl[j] * vl[j]
        stored[i] = energy
        dissipated[i, 0] = w_fric
        for e in range(ne):
            up[i, e], fel[i, e] = upl[e], fl[e]
            crush[i, e], force[i, e], work_done[i, e] = ul[e], fl[e], wl[e]
            fr = el_front[e]
            rate_out[i, e] = vl[el_back[e]] - (vl[fr] if fr >= 0 else 0.0)


@dataclass(frozen=True)
class CrashBatchModel:
    """A scenario's reference or surrogate model, ready for batch stepping.

    Made by :func:`crash_batch_model`. Holds no simulation state: :meth:`new_state` and
    :meth:`new_outputs` allocate the arrays of ``n`` simulations, :meth:`reset` puts one at
    first contact, :meth:`step` advances the active ones by ``sample_dt`` in one compiled call.

    Attributes
    ----------
    backend : ``"reference"`` or ``"surrogate"``.
    scenario : the simulated scenario (its ``speed`` is the nominal initial speed).
    sample_dt : time advanced by one :meth:`step`, s.
    dt, n_sub : integration step (s) and steps per :meth:`step`.
    params : static kernel arrays.
    masses : mass of each integration node (reference) or body (surrogate), kg.
    v_unit : initial velocity of each node per unit train speed (1 train, 0 obstacle).
    body_names, zone_names : as in :class:`CrashResult`.
    zone_absorber : absorber stroke of each zone, m.
    """

    backend: str
    scenario: CrashScenario
    sample_dt: float
    dt: float
    n_sub: int
    params: tuple
    masses: np.ndarray
    v_unit: np.ndarray
    body_names: list[str]
    zone_names: list[str]
    zone_absorber: np.ndarray

    def new_state(self, n: int) -> tuple[np.ndarray, ...]:
        """Zeroed kernel state of ``n`` simulations."""
        N, nz = self.masses.size, len(self.zone_names)
        node = [np.zeros((n, N)) for _ in range(3)]
        zone = [np.zeros((n, nz)) for _ in range(2)]
        damp = [np.zeros((n, max(N - 1, 1)))] if self.backend == "reference" else []
        return (*node, *zone, *damp, np.zeros((n, N)))

    def new_outputs(self, n: int) -> BatchOutputs:
        """Zeroed outputs of ``n`` simulations."""
        nb, nz = len(self.body_names), len(self.zone_names)
        return BatchOutputs(*(np.zeros((n, nb)) for _ in range(3)),
                            *(np.zeros((n, nz)) for _ in range(4)),
                            np.zeros((n, 2)), np.zeros(n))  # fmt: skip

    def reset(self, state: tuple, out: BatchOutputs, i: int, speed: float) -> None:
        """Simulation ``i`` at first contact, the train at ``speed`` (m/s); call :meth:`step`
        with ``init=True`` afterwards to evaluate its forces."""
        for arr in (*state, *out):
            arr[i] = 0.0
        state[1][i] = self.v_unit * speed

    def step(
        self,
        state: tuple,
        out: BatchOutputs,
        scale: np.ndarray,
        active: np.ndarray,
        div: np.ndarray,
        init: bool = False,
        limit: float = 1e3,
    ) -> None:
        """Advance the ``active`` simulations by ``sample_dt`` (:func:`reference_batch_step`)."""
        kernel = reference_batch_step if self.backend == "reference" else surrogate_batch_step
        kernel(state, out, self.params, scale, active, init, self.dt, self.n_sub, limit, div)


def crash_batch_model(
    scenario: CrashScenario | str,
    backend: str = "reference",
    sample_dt: float = 1e-3,
    surrogate: CrashSurrogate | None = None,
    safety: float = 0.2,
    dt: float = 5e-4,
) -> CrashBatchModel:
    """Batch-steppable model of a scenario.

    Parameters
    ----------
    scenario : a :class:`CrashScenario` or a name/path for :func:`load_scenario`.
    backend : ``"reference"`` (lumped-mass chain, :func:`simulate_reference`) or
        ``"surrogate"`` (paper eq. 4, :func:`simulate_surrogate`; needs ``surrogate``).
    sample_dt : time advanced per :meth:`CrashBatchModel.step`, s.
    safety : reference time-step safety factor; dt : largest surrogate step, s (both as in
        the ``simulate_*`` functions, which the batch kernels reproduce step for step).
    """
    sc = load_scenario(scenario) if isinstance(scenario, str | Path) else scenario
    if backend not in BATCH_BACKENDS:
        raise ValueError(f"backend must be one of {BATCH_BACKENDS}, got {backend!r}")
    _check_run(sample_dt, sample_dt)
    if backend == "reference":
        if not 0 < safety <= 1:
            raise ValueError(f"safety must be in (0, 1], got {safety!r}")
        ch = _build_chain(sc)
        step, n_sub = _steps(sample_dt, safety * 2.0 / ch.omega_max)
        params = (ch.m, ch.mu, sc.gravity, V_EPS, ch.link_k, ch.link_c, ch.elem_zone,
                  ch.zone_type, ch.zone_cc, ch.zone_front, ch.zone_back, ch.t_s, ch.t_f, ch.t_n,
                  ch.t_amp, ch.t_lam, ch.t_ku, ch.t_kt, ch.t_slack, ch.t_abs, ch.body_start,
                  ch.body_end)  # fmt: skip
        return CrashBatchModel(
            backend=backend, scenario=sc, sample_dt=float(sample_dt), dt=step, n_sub=n_sub,
            params=params, masses=ch.m, v_unit=ch.v0 / sc.speed, body_names=ch.body_names,
            zone_names=ch.zone_names, zone_absorber=ch.t_abs[ch.zone_type],
        )  # fmt: skip
    if surrogate is None:
        raise ValueError("surrogate is required for backend='surrogate'")
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive finite number (s), got {dt!r}")
    sy = _surrogate_system(sc, surrogate)
    step, n_sub = _steps(sample_dt, dt)
    return CrashBatchModel(
        backend=backend, scenario=sc, sample_dt=float(sample_dt), dt=step, n_sub=n_sub,
        params=(sy.m, sy.mu, sc.gravity, V_EPS, sy.elements, sy.types, sy.lpr), masses=sy.m,
        v_unit=sy.v0 / sc.speed, body_names=sy.body_names, zone_names=sy.zone_names,
        zone_absorber=sy.types[1][sy.elements[:, 2], 3],
    )  # fmt: skip
