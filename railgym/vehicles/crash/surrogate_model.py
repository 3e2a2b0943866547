"""The surrogate crash model of paper eq. (4), compiled: element law, batch step, recorder and
:func:`simulate_surrogate` (elements from :mod:`~railgym.vehicles.crash.surrogate`)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numba import njit, prange

from railgym.vehicles.crash.outputs import (
    V_EPS,
    CrashResult,
    StopRule,
    check_run,
    crash_over,
    one_train,
    recorded_result,
    sub_steps,
)
from railgym.vehicles.crash.piecewise import PiecewiseEnvelope
from railgym.vehicles.crash.scenario import CrashScenario, load_scenario
from railgym.vehicles.crash.surrogate import VARIANTS, CrashSurrogate
from surrogates.models.lpr import EXTRAPOLATION_MODES

__all__ = [
    "ElementTypes",
    "LprModels",
    "SurrogateParams",
    "SurrogateState",
    "simulate_surrogate",
    "surrogate_batch_step",
    "surrogate_batch_step_parallel",
]


class LprModels(NamedTuple):
    """The element LPR models (:func:`_pack_models`), one row per model: each a 1-input
    Legendre series ``f(u) = Σ_k c_k P_k(t)``, ``t = 2 (u − lower) / (upper − lower) − 1``.

    Attributes
    ----------
    coef : (models, degrees + 1) coefficient ``c_k`` of each degree, contiguous, zero-padded.
    degree : (models,) int64 highest degree of each model.
    lower, upper : (models,) input domain, m.
    mode : (models,) extrapolation mode (:data:`surrogates.models.lpr.EXTRAPOLATION_MODES`):
        1 clips, 0 extends the series linearly beyond the domain; ``"raise"`` (2) is rejected
        when the models are packed (:func:`_pack_models`), the kernels cannot raise.
    force_range : (models, 2) lowest and highest training force of each model, N.
    ends : (models, 2, 2) value and slope ``df/dt`` (both N) of each model at ``t = −1``
        (row 0) and ``t = +1`` (row 1), for the linear extension (:func:`_series_ends`).
    """

    coef: np.ndarray
    degree: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    mode: np.ndarray
    force_range: np.ndarray
    ends: np.ndarray


class ElementTypes(NamedTuple):
    """Element characteristics, one row per element type (wall, interface).

    Attributes
    ----------
    variant : 0 ``"paper"``, 1 ``"hysteretic"``.
    load_model, unload_model : row of the loading / unloading LPR in :class:`LprModels`.
    n_pieces : number of loading LPRs, rows ``load_model …`` in order along ``u``
        (:class:`~railgym.vehicles.crash.piecewise.PiecewiseEnvelope`; 1 = one LPR): at ``u``
        the first whose ``upper`` is ≥ ``u`` applies, the last beyond.
    unilateral : 1 if the element never pulls.
    unloading_stiffness, tension_stiffness, slack : ``k̂_u``, ``k̂_t`` (N/m) and ``ŝ`` (m).
    absorber : absorber stroke in the feature ``u``, m.
    """

    variant: np.ndarray
    load_model: np.ndarray
    unload_model: np.ndarray
    n_pieces: np.ndarray
    unilateral: np.ndarray
    unloading_stiffness: np.ndarray
    tension_stiffness: np.ndarray
    slack: np.ndarray
    absorber: np.ndarray


class SurrogateParams(NamedTuple):
    """Static arrays of the surrogate model (paper eq. 4), passed into the kernels.

    A car is ``nodes_per_car`` lumped masses (:attr:`CrashSurrogate.nodes_per_car`; 1 is
    paper eq. 4) joined by elastic carbody links; the elements join the end nodes.

    Attributes
    ----------
    m, mu : (nodes,) node mass (kg) and friction coefficient.
    gravity, v_eps : m/s² and the friction regularisation velocity, m/s.
    front, back, kind : (elements,) nodes each element joins (front −1 = wall) and its row
        of ``types``.
    link_front, link_k, link_c : (links,) first node of each carbody link (it joins
        ``link_front`` and ``link_front + 1``), its stiffness (N/m) and damping (N s/m).
    body_start, body_end : (bodies,) node range of each body (car, obstacle).
    types : the :class:`ElementTypes` table. lpr : the :class:`LprModels`.
    """

    m: np.ndarray
    mu: np.ndarray
    gravity: float
    v_eps: float
    front: np.ndarray
    back: np.ndarray
    kind: np.ndarray
    link_front: np.ndarray
    link_k: np.ndarray
    link_c: np.ndarray
    body_start: np.ndarray
    body_end: np.ndarray
    types: ElementTypes
    lpr: LprModels


class SurrogateState(NamedTuple):
    """Per-simulation state of :func:`surrogate_batch_step`, one row per simulation.

    Attributes
    ----------
    x, v, a : (n, nodes) displacement (m), velocity (m/s), acceleration (m/s²).
    up, fz : (n, elements) permanent set in ``u`` (m) and force (N) of each element.
    ff : (n, nodes) friction force magnitude along v, N.
    m : (n, nodes) node mass of each simulation (a car's payload included), kg; the link
        damping coefficients stay those of :attr:`SurrogateParams.m`.
    """

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    up: np.ndarray
    fz: np.ndarray
    ff: np.ndarray
    m: np.ndarray


def new_surrogate_state(n: int, masses: np.ndarray, n_elements: int) -> SurrogateState:
    """Zeroed :class:`SurrogateState` of ``n`` simulations with node ``masses`` (kg)."""
    n_bodies = masses.size
    body = [np.zeros((n, n_bodies)) for _ in range(3)]
    el = [np.zeros((n, n_elements)) for _ in range(2)]
    return SurrogateState(*body, *el, np.zeros((n, n_bodies)), np.tile(masses, (n, 1)))


@njit(cache=True, error_model="numpy")
def _series_ends(c, n):
    """Value and slope ``dΣ/dt`` of ``Σ_{k≤n} c_k P_k(t)`` at ``t = −1`` and ``t = +1``
    (``P_k(±1) = (±1)^k``, ``P'_k(±1) = (±1)^{k+1} k (k + 1) / 2``), as ``(value, slope)``
    rows of a (2, 2) array."""
    ends = np.zeros((2, 2))
    for row, s in enumerate((-1.0, 1.0)):
        value = slope = 0.0
        sign = 1.0
        for k in range(n + 1):
            value += c[k] * sign
            slope += c[k] * sign * s * 0.5 * k * (k + 1)
            sign *= s
        ends[row, 0], ends[row, 1] = value, slope
    return ends


@njit(cache=True, error_model="numpy", _nrt=False)
def _legendre_rows(u, q, lpr, nb, t, b1, b2, f):
    """``f[:nb]`` = model ``q`` of ``lpr`` (:class:`LprModels`) at each ``u[:nb]`` (m):
    ``Σ_k c_k P_k(t)`` at ``t = 2 (u − lower) / (upper − lower) − 1`` by Clenshaw's recurrence,
    all lanes at once (the loop over lanes innermost); outside ``[lower, upper]`` the value at
    the nearer end, extended linearly with the slope there unless the mode is 1 (clip).
    ``t``, ``b1``, ``b2`` are scratch rows."""
    lower, upper, n, c = lpr.lower[q], lpr.upper[q], lpr.degree[q], lpr.coef[q]
    scale = 2.0 / (upper - lower)
    for b in range(nb):
        t[b] = (u[b] - lower) * scale - 1.0
        b1[b] = 0.0
        b2[b] = 0.0
    for k in range(n, 0, -1):
        ck, alpha, beta = c[k], (2.0 * k + 1.0) / (k + 1.0), (k + 1.0) / (k + 2.0)
        for b in range(nb):
            b0 = ck + alpha * t[b] * b1[b] - beta * b2[b]
            b2[b] = b1[b]
            b1[b] = b0
    clip = lpr.mode[q] == 1
    for b in range(nb):
        x = u[b]
        if lower <= x <= upper:
            f[b] = c[0] + t[b] * b1[b] - 0.5 * b2[b]
            continue
        side = 1 if x > upper else 0
        value = lpr.ends[q, side, 0]
        end = upper if side == 1 else lower
        f[b] = value if clip else value + lpr.ends[q, side, 1] * scale * (x - end)


@njit(cache=True, error_model="numpy", _nrt=False)
def _piece_rows(u, q0, n_pieces, lpr, nb, t, b1, b2, f, fc, piece):
    """``f[:nb]`` = the piecewise envelope of models ``q0 … q0 + n_pieces − 1`` at each
    ``u[:nb]`` (m): each lane's first model whose ``upper`` is ≥ ``u`` (the last beyond), each
    model evaluated (:func:`_legendre_rows`) only if a lane needs it; ``fc``, ``piece``, ``t``,
    ``b1``, ``b2`` are scratch rows."""
    last = q0 + n_pieces - 1
    for b in range(nb):
        q = q0
        while q < last and u[b] > lpr.upper[q]:
            q += 1
        piece[b] = q
    for q in range(q0, last + 1):
        need = False
        for b in range(nb):
            need = need or piece[b] == q
        if not need:
            continue
        _legendre_rows(u, q, lpr, nb, t, b1, b2, fc)
        for b in range(nb):
            if piece[b] == q:
                f[b] = fc[b]


@njit(cache=True, inline="always")
def crash_element_model(u, rate, up, variant, unilateral, ku, i_load, i_unload):
    """Index of the LPR model the element law (:func:`crash_element_force`) reads at feature ``u``,
    rate ``u̇`` and permanent set ``up``; −1 where it needs none."""
    if unilateral and u <= 0.0:
        return -1
    if variant == 0:
        return i_load if rate >= 0.0 else i_unload
    return i_load if ku * (u - up) > 0.0 else -1


@njit(cache=True, inline="always")
def crash_element_force(u, up, f_lpr, f_min, f_max, s, variant, unilateral, ku, kt, slack):
    """Force (N, compression positive) and new permanent set of one surrogate element.

    ``f_lpr`` is the value at ``u`` of the LPR model chosen by :func:`crash_element_model` and
    ``[f_min, f_max]`` that model's force range, N (unused where it chose none). ``s``
    multiplies the LPR force (controllable absorber, 1 beyond the absorber stroke, as
    :func:`absorber_zone_force`). ``variant`` 0 is ``"paper"``, 1 ``"hysteretic"``; ``k_u``,
    ``k_t`` (N/m) and ``slack`` (m) as in :class:`CrashElement`.
    """
    if unilateral and u <= 0.0:
        return 0.0, up
    if variant == 0:
        f = s * min(max(f_lpr, f_min), f_max)
        if unilateral and f < 0.0:
            f = 0.0
        return f, up
    trial = ku * (u - up)
    if trial > 0.0:
        env = s * min(f_lpr, f_max)
        if env <= 0.0:
            return 0.0, up
        if trial >= env:
            return env, u - env / ku
        return trial, up
    if kt > 0.0 and u < up - slack:
        return kt * (u - up + slack), up
    return 0.0, up


@njit(cache=True, inline="always")
def _tanh(x):
    """``math.tanh(x)``, without calling it where it rounds to ±1 (from |x| ≥ 22)."""
    if x >= 22.0:
        return 1.0
    if x <= -22.0:
        return -1.0
    return math.tanh(x)


class _Scratch(NamedTuple):
    """Working rows of :func:`_step_block`, ``BLOCK`` lanes (trains) each: ``body`` (9,
    nodes, lanes), ``element`` (7, elements, lanes), ``link`` (2, links, lanes), ``lane`` (10,
    lanes), ``idx`` (lanes,) the train of each lane."""

    body: np.ndarray
    element: np.ndarray
    link: np.ndarray
    lane: np.ndarray
    idx: np.ndarray


#: trains stepped together by :func:`_step_block` (the lanes of its inner loops)
BLOCK = 64


@njit(cache=True)
def _scratch(n_nodes, n_elements, n_links, lanes):
    """A :class:`_Scratch` of ``lanes`` lanes."""
    return _Scratch(
        np.zeros((9, n_nodes, lanes)),
        np.zeros((7, n_elements, lanes)),
        np.zeros((2, n_links, lanes)),
        np.zeros((10, lanes)),
        np.zeros(lanes, np.int64),
    )


# Structure of arrays: the trains of a block are the lanes of every inner loop, so the Legendre
# sums (the bulk of the work) run over contiguous rows; without reference counting (_nrt=False,
# nothing allocated) the NamedTuple arguments cost nothing per call.
@njit(cache=True, error_model="numpy", _nrt=False)
def _step_block(state, out, params, scale, init, dt, n_sub, limit, div, w, nb):
    """Step the trains ``w.idx[:nb]`` as :func:`surrogate_batch_step` does, with scratch ``w``
    (:class:`_Scratch`)."""
    x, v, a, up, fel, ff, mass = state
    mu, g, veps = params.mu, params.gravity, params.v_eps
    el_front, el_back, el_type = params.front, params.back, params.kind
    ty_, lpr = params.types, params.lpr
    FR = lpr.force_range
    N, ne = mu.shape[0], el_front.shape[0]
    idx = w.idx
    bw, ew, lw, kw = w.body, w.element, w.lane, w.link
    lk_front, lk_k, lk_c = params.link_front, params.link_k, params.link_c
    nl = lk_front.shape[0]
    fd, fd_o = kw[0], kw[1]
    xl, vl, al, ffl, vp, F, dx, ff_o, m = (
        bw[0],
        bw[1],
        bw[2],
        bw[3],
        bw[4],
        bw[5],
        bw[6],
        bw[7],
        bw[8],
    )
    upl, fl, f_o, ul, u_o, wl, rate = ew[0], ew[1], ew[2], ew[3], ew[4], ew[5], ew[6]
    t, b1, b2, fa, fb, zero, w_fric, w_damp = lw[0], lw[1], lw[2], lw[3], lw[4], lw[5], lw[6], lw[7]
    fc, piece = lw[8], lw[9]
    ox, ov, oa, crush, force, rate_out = out.x, out.v, out.a, out.crush, out.force, out.rate
    work_done, dissipated, stored = out.work, out.dissipated, out.stored
    for b in range(nb):
        i = idx[b]
        for j in range(N):
            xl[j, b], vl[j, b], al[j, b], ffl[j, b] = x[i, j], v[i, j], a[i, j], ff[i, j]
            m[j, b] = mass[i, j]
        for e in range(ne):
            upl[e, b], fl[e, b] = up[i, e], fel[i, e]
            ul[e, b], wl[e, b] = crush[i, e], work_done[i, e]
        w_fric[b], w_damp[b] = dissipated[i, 0], dissipated[i, 1]
        zero[b] = 0.0
        for k in range(nl):
            j = lk_front[k]
            fd[k, b] = lk_c[k] * (v[i, j + 1] - v[i, j])
    # init: forces at the current state; else n_sub velocity-Verlet steps
    for _ in range(1 if init else n_sub):
        for j in range(N):
            if init:
                for b in range(nb):
                    vp[j, b] = vl[j, b]
            else:
                for b in range(nb):
                    ff_o[j, b] = ffl[j, b]
                    dx[j, b] = vl[j, b] * dt + 0.5 * al[j, b] * dt * dt
                    xl[j, b] += dx[j, b]
                    vp[j, b] = vl[j, b] + al[j, b] * dt
            for b in range(nb):
                ffl[j, b] = mu[j] * m[j, b] * g * _tanh(vp[j, b] / veps)
                F[j, b] = -ffl[j, b]
        for e in range(ne):
            front, back, ty = el_front[e], el_back[e], el_type[e]
            x_fr, v_fr = (xl[front], vp[front]) if front >= 0 else (zero, zero)
            u_e = ul[e]
            for b in range(nb):
                f_o[e, b], u_o[e, b] = fl[e, b], u_e[b]
                u_e[b] = xl[back, b] - x_fr[b]
                rate[e, b] = vp[back, b] - v_fr[b]
            variant, unilateral, ku = (
                ty_.variant[ty],
                ty_.unilateral[ty],
                ty_.unloading_stiffness[ty],
            )
            q_load, q_unload = ty_.load_model[ty], ty_.unload_model[ty]
            use_load = use_unload = False
            for b in range(nb):
                mdl = crash_element_model(
                    u_e[b], rate[e, b], upl[e, b], variant, unilateral, ku, q_load, q_unload
                )
                use_load = use_load or mdl == q_load
                use_unload = use_unload or (mdl >= 0 and mdl != q_load)
            n_pieces = ty_.n_pieces[ty]
            if use_load and n_pieces == 1:
                _legendre_rows(u_e, q_load, lpr, nb, t, b1, b2, fa)
            elif use_load:
                _piece_rows(u_e, q_load, n_pieces, lpr, nb, t, b1, b2, fa, fc, piece)
            if use_unload:
                _legendre_rows(u_e, q_unload, lpr, nb, t, b1, b2, fb)
            absorber, kt, slack = ty_.absorber[ty], ty_.tension_stiffness[ty], ty_.slack[ty]
            for b in range(nb):
                u = u_e[b]
                mdl = crash_element_model(
                    u, rate[e, b], upl[e, b], variant, unilateral, ku, q_load, q_unload
                )
                f_lpr = f_min = f_max = 0.0
                if mdl >= 0:
                    f_lpr = fa[b] if mdl == q_load else fb[b]
                    f_min, f_max = FR[mdl, 0], FR[mdl, 1]
                s = scale[idx[b], e] if u <= absorber else 1.0
                f, upl[e, b] = crash_element_force(
                    u, upl[e, b], f_lpr, f_min, f_max, s, variant, unilateral, ku, kt, slack
                )
                fl[e, b] = f
                if front >= 0:
                    F[front, b] += f
                F[back, b] -= f
        for k in range(nl):  # carbody links: f = k d + c ḋ, tension positive
            j, kk, cc = lk_front[k], lk_k[k], lk_c[k]
            for b in range(nb):
                fd_o[k, b] = fd[k, b]
                fd[k, b] = cc * (vp[j + 1, b] - vp[j, b])
                f = kk * (xl[j + 1, b] - xl[j, b]) + fd[k, b]
                F[j, b] += f
                F[j + 1, b] -= f
        for j in range(N):
            for b in range(nb):
                a_new = F[j, b] / m[j, b]
                if not init:
                    vl[j, b] += 0.5 * (al[j, b] + a_new) * dt
                    w_fric[b] += 0.5 * (ff_o[j, b] + ffl[j, b]) * dx[j, b]
                al[j, b] = a_new
        if not init:
            for e in range(ne):
                for b in range(nb):
                    wl[e, b] += 0.5 * (f_o[e, b] + fl[e, b]) * (ul[e, b] - u_o[e, b])
            for k in range(nl):
                j = lk_front[k]
                for b in range(nb):
                    w_damp[b] += 0.5 * (fd_o[k, b] + fd[k, b]) * (dx[j + 1, b] - dx[j, b])
    for b in range(nb):
        i = idx[b]
        healthy = True
        for j in range(N):
            if not (abs(xl[j, b]) <= limit and abs(vl[j, b]) <= limit and math.isfinite(al[j, b])):
                healthy = False
        if not healthy:
            div[i] = True
            continue
        energy = 0.0
        for j in range(N):
            x[i, j], v[i, j], a[i, j], ff[i, j] = xl[j, b], vl[j, b], al[j, b], ffl[j, b]
            energy += 0.5 * m[j, b] * vl[j, b] * vl[j, b]
        for k in range(nl):
            j = lk_front[k]
            energy += 0.5 * lk_k[k] * (xl[j + 1, b] - xl[j, b]) ** 2
        for body in range(params.body_start.shape[0]):
            j0, j1 = params.body_start[body], params.body_end[body]
            if j1 - j0 == 1:
                ox[i, body], ov[i, body], oa[i, body] = xl[j0, b], vl[j0, b], al[j0, b]
                continue
            mb = sx = sv = sa = 0.0
            for j in range(j0, j1):
                mb += m[j, b]
                sx += m[j, b] * xl[j, b]
                sv += m[j, b] * vl[j, b]
                sa += m[j, b] * al[j, b]
            ox[i, body], ov[i, body], oa[i, body] = sx / mb, sv / mb, sa / mb
        stored[i] = energy
        dissipated[i, 0], dissipated[i, 1] = w_fric[b], w_damp[b]
        for e in range(ne):
            up[i, e], fel[i, e] = upl[e, b], fl[e, b]
            crush[i, e], force[i, e], work_done[i, e] = ul[e, b], fl[e, b], wl[e, b]
            front = el_front[e]
            rate_out[i, e] = vl[el_back[e], b] - (vl[front, b] if front >= 0 else 0.0)


@njit(cache=True, error_model="numpy")
def _step_range(state, out, params, scale, active, first, last, init, dt, n_sub, limit, div):
    """Step the active trains among ``first`` ≤ i < ``last`` in blocks of :data:`BLOCK`."""
    w = _scratch(params.mu.shape[0], params.front.shape[0], params.link_front.shape[0], BLOCK)
    nb = 0
    for i in range(first, last):
        if active[i]:
            w.idx[nb] = i
            nb += 1
        if nb == BLOCK or (i == last - 1 and nb > 0):
            _step_block(state, out, params, scale, init, dt, n_sub, limit, div, w, nb)
            nb = 0


@njit(cache=True, error_model="numpy")
def surrogate_batch_step(state, out, params, scale, active, init, dt, n_sub, limit, div):
    """:func:`reference_batch_step` for the surrogate model (paper eq. 4).

    ``state`` is a :class:`SurrogateState`, ``params`` :class:`SurrogateParams`;
    ``dissipated[:, 1]`` is the work of the carbody links' damping (0 with one node per car);
    ``out.x``, ``out.v``, ``out.a`` are per body (a car's centre of mass). The active trains
    are stepped in blocks of :data:`BLOCK`, each train on its own: the results do not depend
    on the blocking.
    """
    n = active.shape[0]
    _step_range(state, out, params, scale, active, 0, n, init, dt, n_sub, limit, div)


@njit(cache=True, error_model="numpy", parallel=True)
def surrogate_batch_step_parallel(state, out, params, scale, active, init, dt, n_sub, limit, div):
    """:func:`surrogate_batch_step` on all numba threads: ``prange`` over runs of
    :data:`BLOCK` trains (full blocks: a shorter run fills only part of the lanes), each
    stepped as the serial kernel steps them: bit-identical results.

    The parameters are taken apart and rebuilt inside the loop: numba's parallel loop cannot
    capture a NamedTuple that nests NamedTuples of arrays.
    """
    m, mu, g, v_eps = params.m, params.mu, params.gravity, params.v_eps
    front, back, kind = params.front, params.back, params.kind
    lf, lk, lc = params.link_front, params.link_k, params.link_c
    bs, be = params.body_start, params.body_end
    types, lpr = ElementTypes(*params.types), LprModels(*params.lpr)
    n = active.shape[0]
    blocks = (n + BLOCK - 1) // BLOCK
    for c in prange(blocks):
        p = SurrogateParams(m, mu, g, v_eps, front, back, kind, lf, lk, lc, bs, be, types, lpr)
        first, last = c * BLOCK, min(n, (c + 1) * BLOCK)
        _step_range(state, out, p, scale, active, first, last, init, dt, n_sub, limit, div)


@njit(cache=True)
def _record_surrogate(state, out, params, dt, n_sub, stop, rec):
    """Record simulation 0 of ``state`` sample by sample (:func:`surrogate_batch_step`) into
    ``rec`` (:class:`Record`); returns the number of samples taken."""
    scale = np.ones((1, params.front.shape[0]))
    div = np.zeros(1, np.bool_)
    w = _scratch(params.mu.shape[0], params.front.shape[0], params.link_front.shape[0], 1)
    for k in range(rec.x.shape[0]):
        _step_block(state, out, params, scale, k == 0, dt, n_sub, math.inf, div, w, 1)
        rec.x[k], rec.v[k], rec.a[k] = out.x[0], out.v[0], out.a[0]
        rec.crush[k], rec.force[k], rec.permanent_set[k] = out.crush[0], out.force[0], state.up[0]
        if stop.enabled and k > 0 and crash_over(out, state.fz, stop):
            return k + 1
    return rec.x.shape[0]


def _pack_models(models: list[Any], ranges: list[tuple[float, float]]) -> LprModels:
    """:class:`LprModels` of several 1-input LPR models (their coefficients summed per
    Legendre degree) and their output ranges, N."""
    arrays = [mdl.kernel_arrays() for mdl in models]
    for i, (e, *_, mode) in enumerate(arrays):
        if e.ndim != 2 or e.shape[1] != 1:
            raise ValueError(f"surrogate element model {i} has {e.shape[-1]} inputs, expected 1")
        if mode == EXTRAPOLATION_MODES["raise"]:
            raise ValueError(
                f"surrogate element model {i} has extrapolation='raise', which the compiled "
                "crash kernels cannot honour (they would extrapolate linearly): use 'clip' or "
                "'linear'"
            )
    degree = np.array([int(e.max()) for e, *_ in arrays], dtype=np.int64)
    C = np.zeros((len(arrays), int(degree.max()) + 1))
    LO, UP = np.zeros(len(arrays)), np.zeros(len(arrays))
    MODE = np.zeros(len(arrays), dtype=np.int64)
    for i, (e, c, lo, up, mode) in enumerate(arrays):
        np.add.at(C[i], e[:, 0], c)
        LO[i], UP[i], MODE[i] = lo[0], up[0], mode
    FR = np.array(ranges, dtype=np.float64).reshape(len(arrays), 2)
    ends = np.array([_series_ends(C[i], degree[i]) for i in range(len(arrays))])
    return LprModels(C, degree, LO, UP, MODE, FR, ends)


@dataclass
class _System:
    """The surrogate model of one scenario: kernel parameters plus what the kernels do not
    need."""

    params: SurrogateParams
    v0: np.ndarray  # initial velocities, m/s
    body_names: list[str]
    zone_names: list[str]


def surrogate_system(scenario: CrashScenario, surrogate: CrashSurrogate) -> _System:
    """Bodies, elements and packed LPR models of ``surrogate`` on scenario ``sc``."""
    for key in ("wall", "interface"):
        if key not in surrogate.elements and (key == "wall" or scenario.n_cars > 1):
            raise ValueError(f"surrogate has no {key!r} element")
    n = surrogate.nodes_per_car
    masses: list[float] = []
    links: list[tuple[int, float, float]] = []  # (first node, k N/m, c N s/m)
    for k, mass in enumerate(scenario.car_masses):
        car = scenario.lead if k == 0 else scenario.passenger
        first = len(masses)
        mi = np.full(n, mass / max(n - 1, 1))  # row-sum lumping, as the reference chain
        if n > 1:
            mi[[0, -1]] *= 0.5
        masses += mi.tolist()
        k_link = car.axial_rigidity / (car.length / max(n - 1, 1))
        for j in range(n - 1):
            mred = mi[j] * mi[j + 1] / (mi[j] + mi[j + 1])
            links.append((first + j, k_link, 2 * car.damping_ratio * math.sqrt(k_link * mred)))
    start = np.arange(scenario.n_cars, dtype=np.int64) * n
    mu = [scenario.friction] * len(masses)
    v0 = [scenario.speed] * len(masses)
    names = ["lead"] + [f"car{k + 1}" for k in range(1, scenario.n_cars)]
    wall_front = -1
    if scenario.obstacle is not None:
        wall_front = len(masses)
        masses.append(scenario.obstacle.mass)
        mu.append(scenario.obstacle.friction)
        v0.append(0.0)
        names.append("obstacle")
    body_start = np.append(start, [wall_front] if scenario.obstacle is not None else [])
    body_start = body_start.astype(np.int64)
    body_end = np.append(start + n, [wall_front + 1] if scenario.obstacle is not None else [])
    el_front = np.array([wall_front] + list(start[1:] - 1), dtype=np.int64)
    el_back = start.copy()
    el_type = np.array([0] + [1] * (scenario.n_cars - 1), dtype=np.int64)
    el_names = ["wall"] + [f"interface_{k}" for k in range(1, scenario.n_cars)]
    types = [surrogate.elements["wall"], surrogate.elements.get("interface")]
    types = [ty for ty in types if ty is not None]
    models, ranges, load_idx, unload_idx, n_pieces = [], [], [], [], []
    for ty in types:
        load_idx.append(len(models))
        pieces = ty.loading.pieces if isinstance(ty.loading, PiecewiseEnvelope) else [ty.loading]
        n_pieces.append(len(pieces))
        models += pieces
        ranges += [ty.force_range["loading"]] * len(pieces)
        unload_idx.append(len(models) if ty.unloading is not None else load_idx[-1])
        if ty.unloading is not None:
            models.append(ty.unloading)
            ranges.append(ty.force_range["unloading"])
    zone_stroke = [scenario.wall.absorber_stroke, scenario.interface.absorber_stroke][: len(types)]
    element_types = ElementTypes(
        variant=np.array([VARIANTS.index(ty.variant) for ty in types], np.int64),
        load_model=np.array(load_idx, np.int64),
        unload_model=np.array(unload_idx, np.int64),
        n_pieces=np.array(n_pieces, np.int64),
        unilateral=np.array([ty.unilateral for ty in types], np.int64),
        unloading_stiffness=np.array([ty.unloading_stiffness for ty in types]),
        tension_stiffness=np.array([ty.tension_stiffness for ty in types]),
        slack=np.array([ty.slack for ty in types]),
        absorber=np.array(zone_stroke, dtype=np.float64),
    )
    params = SurrogateParams(
        m=np.array(masses),
        mu=np.array(mu),
        gravity=float(scenario.gravity),
        v_eps=V_EPS,
        front=el_front,
        back=el_back,
        kind=el_type,
        link_front=np.array([j for j, _, _ in links], dtype=np.int64),
        link_k=np.array([kk for _, kk, _ in links], dtype=np.float64),
        link_c=np.array([c for _, _, c in links], dtype=np.float64),
        body_start=body_start,
        body_end=body_end.astype(np.int64),
        types=element_types,
        lpr=_pack_models(models, ranges),
    )
    return _System(params=params, v0=np.array(v0), body_names=names, zone_names=el_names)


def simulate_surrogate(
    scenario: CrashScenario | str,
    surrogate: CrashSurrogate,
    n_cars: int | None = None,
    speed: float | None = None,
    duration: float = 2.0,
    sample_dt: float = 1e-3,
    dt: float = 5e-4,
    stop_when_over: bool = True,
    v_stop: float = 0.01,
    f_stop: float = 1e3,
) -> CrashResult:
    """Run the surrogate crash model (paper eq. 4): ``surrogate.nodes_per_car`` masses per car
    (+ obstacle).

    Parameters
    ----------
    scenario : a :class:`CrashScenario` or a name/path for :func:`load_scenario`.
    surrogate : elements from :func:`build_crash_surrogate`.
    n_cars, speed : optional overrides (number of cars; initial speed in m/s).
    duration, sample_dt : longest simulated time and output interval, s.
    dt : largest integration step, s (rounded down to divide ``sample_dt``); the stiffest
        mode is the carbody links' and the zones' ``k̂_u`` on the end masses
        (docs/envs/crash.md).
    stop_when_over, v_stop, f_stop : stop as :func:`simulate_reference` does.

    Returns
    -------
    :class:`CrashResult` with ``crush``/``force`` holding each element's feature ``u`` and force
    and ``permanent_set`` its permanent set in ``u``; ``energy`` is empty.
    """
    scenario = load_scenario(scenario) if isinstance(scenario, str | Path) else scenario
    scenario = scenario.with_overrides(n_cars=n_cars, speed=speed)
    check_run(duration, sample_dt)
    dt, n_sub = sub_steps(sample_dt, dt)
    sy = surrogate_system(scenario, surrogate)
    state, out, rec = one_train(sy, new_surrogate_state, duration, sample_dt, energies=False)
    stop, t0 = StopRule(stop_when_over, v_stop, f_stop), time.perf_counter()
    n = _record_surrogate(state, out, sy.params, dt, n_sub, stop, rec)
    wall, model = time.perf_counter() - t0, f"surrogate:{surrogate.variant}"
    return recorded_result(
        rec, n, sample_dt, sy, energy={}, dt=dt, wall_time=wall, scenario=scenario, model=model
    )
