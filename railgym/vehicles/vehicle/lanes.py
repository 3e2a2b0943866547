"""SIMD lane kernel of the whole vehicle with the surrogate secondary suspension.

As :mod:`railgym.vehicles.vertical.lanes` for the one-bogie model: vehicles are taken
``LANES`` at a time, each quantity of the RK4 step is a row of a block's work array and each
statement a loop over the block's vehicles that LLVM vectorises. The arithmetic per vehicle is
that of :func:`railgym.vehicles.vehicle.model._advance_one` operation for operation (the LPR
evaluation that of :func:`~surrogates.models.lpr.lpr_eval_into` for two inputs), so both
kernels give bit-identical results (tested). A memory element (three inputs, additive) adds
the two Maxwell states in rows of their own after those of the static layout (which keeps its
rows and loops; a nonlinear relaxation law is evaluated lane by lane) and is summed along its
Legendre recurrences as :func:`~surrogates.models.lpr.lpr_additive_inside` does. Element
inputs outside the training box are evaluated lane by lane by ``lpr_eval_into``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from railgym.vehicles.vertical.elements import bump_stop_force
from surrogates.memory import relaxation_rate
from surrogates.models.lpr import additive_terms, lpr_eval_into, lpr_scratch
from surrogates.models.lpr_grid import grid_eval

__all__ = ["LANES", "LANES_MIN", "hermite", "lanes_block"]

#: vehicles per block (the length of the vectorised loops)
LANES = 64
#: batches of fewer vehicles run the per-vehicle kernel (same results)
LANES_MIN = 8
_N = 14  # mechanical states
_DIV = 10.0  # |displacement| (m) above this counts as divergence (``model`` module)
_BIG = 1.7976931348623157e308  # |v| <= _BIG is False for NaN and ±inf

# rows of a block's work array
_X, _XT, _K = 0, 14, 28  # state, stage state, stage rates k1..k4 (4 × 14 rows)
_W, _WM = 84, 92  # wheel inputs (height, rate) × 4 at the substep ends, at its midpoint
_FA = 100  # actuator forces (2 rows), N
_U, _T = 102, 104  # element inputs (δ, δ̇) and their map to [-1, 1]
_FS, _FT = 106, 108  # secondary forces, and plus the actuator forces (2 rows each), N
_EL, _FB = 110, 111  # element value; 1.0 where the linear extension is needed
_OUT, _OSUM = 112, 113  # out-of-box evaluations of a stage, of a substep
_ALIVE, _CONTACT, _OOD = 114, 115, 116
_ROWS = 117
# rows of a memory element (after the static layout)
_M, _MT, _MK = 117, 119, 121  # Maxwell states s_0, s_1; stage states; stage rates (4 × 2 rows)
_UZ, _TM = 129, 130  # element input ζ; the three inputs mapped to [-1, 1]
_A, _B, _S = 133, 136, 139  # recurrence P_{k-1}, P_k and partial sums (3 rows each)
_ROWS_MEMORY = 142


@njit(cache=True, error_model="numpy")
def hermite(
    z: np.ndarray, zd: np.ndarray, pos: float, dt: float, start: int = 0
) -> tuple[float, float]:
    """Cubic Hermite value and rate (m, m/s) of the sampled track at fractional index ``pos``
    of the episode's track; ``z[0]`` is its sample ``start`` (a window of it)."""
    i0 = int(math.floor(pos))
    u = pos - i0
    i0 -= start
    if u == 0.0:
        return z[i0], zd[i0]
    z0, z1 = z[i0], z[i0 + 1]
    d0, d1 = zd[i0] * dt, zd[i0 + 1] * dt
    u2 = u * u
    u3 = u2 * u
    val = (
        (2 * u3 - 3 * u2 + 1) * z0
        + (u3 - 2 * u2 + u) * d0
        + (-2 * u3 + 3 * u2) * z1
        + (u3 - u2) * d1
    )
    rate = (6 * u2 - 6 * u) * z0 + (3 * u2 - 4 * u + 1) * d0 + (6 * u - 6 * u2) * z1
    rate += (3 * u2 - 2 * u) * d1
    return val, rate / dt


@njit(cache=True, error_model="numpy", _nrt=False)
def _inputs(block, arrays, i0, n_lanes, pos, dt, row):
    """Wheel inputs of the block's vehicles at sample index ``k + pos`` into rows ``row..``."""
    for l in range(n_lanes):
        i = i0 + l
        base = arrays.k[i] + pos
        z, zd = arrays.z[i], arrays.zdot[i]
        for j in range(4):
            v, r = hermite(z, zd, base + arrays.off[i, j], dt, arrays.start[i])
            block[row + 2 * j, l] = v
            block[row + 2 * j + 1, l] = r


@njit(cache=True, error_model="numpy", _nrt=False)
def _element(block, legendre, lpr, lpr_work, u, n_lanes):
    """LPR value of the inputs in rows ``_U`` into row ``_EL``; out-of-box flags added to
    row ``_OUT`` (as ``lpr_is_outside``)."""
    lo0, lo1, up0, up1 = lpr.lo[0], lpr.lo[1], lpr.up[0], lpr.up[1]
    s0, s1 = lpr_work[5, 0], lpr_work[5, 1]
    nmax = lpr_work.shape[1] - 1
    for l in range(n_lanes):
        v0, v1 = block[_U, l], block[_U + 1, l]
        out = (v0 < lo0) | (v0 > up0) | (v1 < lo1) | (v1 > up1)
        block[_OUT, l] += 1.0 if out else 0.0
        c0 = min(max(v0, lo0), up0)
        c1 = min(max(v1, lo1), up1)
        block[_FB, l] = 1.0 if (c0 != v0) | (c1 != v1) else 0.0
        t0 = (c0 - lo0) * s0 - 1.0
        t1 = (c1 - lo1) * s1 - 1.0
        block[_T, l], block[_T + 1, l] = t0, t1
        legendre[0, 0, l], legendre[1, 0, l], legendre[0, 1, l], legendre[1, 1, l] = (
            1.0,
            1.0,
            t0,
            t1,
        )
        block[_EL, l] = 0.0
    for k in range(1, nmax):
        ck, ek = lpr_work[3, k], lpr_work[4, k]
        for l in range(n_lanes):
            legendre[0, k + 1, l] = (
                ck * block[_T, l] * legendre[0, k, l] - ek * legendre[0, k - 1, l]
            )
            legendre[1, k + 1, l] = (
                ck * block[_T + 1, l] * legendre[1, k, l] - ek * legendre[1, k - 1, l]
            )
    for m in range(lpr.exps.shape[0]):
        c, e0, e1 = lpr.coef[m], lpr.exps[m, 0], lpr.exps[m, 1]
        for l in range(n_lanes):
            block[_EL, l] += c * legendre[0, e0, l] * legendre[1, e1, l]
    if lpr.mode == 1:
        return
    for l in range(n_lanes):
        if block[_FB, l] > 0.0:
            u[0], u[1] = block[_U, l], block[_U + 1, l]
            block[_EL, l] = lpr_eval_into(u, lpr.exps, lpr.coef, lpr.lo, lpr.up, lpr.mode, lpr_work)


@njit(cache=True, error_model="numpy", _nrt=False)
def _element_memory(block, lpr, lpr_work, u, n_lanes):
    """Value of an additive three-input (memory) element at the inputs in rows ``_U, _U + 1,
    _UZ`` into row ``_EL``: the operations of :func:`~surrogates.models.lpr.lpr_additive_inside`
    (three interleaved recurrences) or, for a gridded element, of
    :func:`~surrogates.models.lpr_grid.lpr_grid_inside` lane by lane; lanes outside the box by
    ``lpr_eval_into`` (their flags added to row ``_OUT``)."""
    lo, up = lpr.lo, lpr.up
    for l in range(n_lanes):
        block[_FB, l] = 0.0
    for j in range(3):
        row = _U + j if j < 2 else _UZ
        lj, uj = lo[j], up[j]
        for l in range(n_lanes):
            v = block[row, l]
            block[_FB, l] = max(block[_FB, l], 1.0 if (v < lj) | (v > uj) else 0.0)
    if lpr.gridded:
        coef, scale, top = lpr.grid, lpr.grid_scale, lpr.grid_top
        for j in range(3):
            row = _U + j if j < 2 else _UZ
            lj, sj, tj = lo[j], scale[j], top[j]
            for l in range(n_lanes):
                block[_S + j, l] = grid_eval(block[row, l], lj, sj, tj, coef, j)
    else:
        _memory_sums(block, lpr, lpr_work, n_lanes)
    outside = 0.0
    for l in range(n_lanes):
        block[_EL, l] = block[_S, l] + block[_S + 1, l] + block[_S + 2, l]
        block[_OUT, l] += block[_FB, l]
        outside += block[_FB, l]
    if outside > 0.0:
        for l in range(n_lanes):
            if block[_FB, l] > 0.0:
                u[0], u[1], u[2] = (
                    block[_U, l],
                    block[_U + 1, l],
                    block[_UZ, l],
                )
                block[_EL, l] = lpr_eval_into(u, lpr.exps, lpr.coef, lo, up, lpr.mode, lpr_work)


@njit(cache=True, error_model="numpy", _nrt=False)
def _memory_sums(block, lpr, lpr_work, n_lanes):
    """Rows ``_S + j``: the Legendre sums of the memory element's three inputs (the constant
    in row ``_S``), the recurrences of :func:`~surrogates.models.lpr.lpr_additive_inside`
    interleaved lane by lane."""
    table, lo = lpr.table, lpr.lo
    n = table.shape[1]
    for j in range(3):
        row = _U + j if j < 2 else _UZ
        lj, scale = lo[j], lpr_work[6, j]
        for l in range(n_lanes):
            t = (block[row, l] - lj) * scale - 1.0
            block[_TM + j, l] = t
            block[_A + j, l] = 1.0
            block[_B + j, l] = t
    c0 = table[0, 0] + table[1, 0] + table[2, 0]
    for l in range(n_lanes):
        block[_S, l] = c0
        block[_S + 1, l] = 0.0
        block[_S + 2, l] = 0.0
    if n > 1:
        for j in range(3):
            c1 = table[j, 1]
            for l in range(n_lanes):
                block[_S + j, l] += c1 * block[_TM + j, l]
    older, newer = _A, _B  # rows of P_{k-1}, P_k (3 each); P_{k+1} overwrites P_{k-1}
    m0, m1, m2 = additive_terms(table, 0), additive_terms(table, 1), additive_terms(table, 2)
    mi = min(m0, m1, m2)
    for k in range(1, mi - 1):
        ck, ek = lpr_work[4, k], lpr_work[5, k]
        c0, c1, c2 = table[0, k + 1], table[1, k + 1], table[2, k + 1]
        for l in range(n_lanes):  # the three chains interleaved, as lpr_additive_inside
            n0 = ck * block[_TM, l] * block[newer, l] - ek * block[older, l]
            n1 = ck * block[_TM + 1, l] * block[newer + 1, l] - ek * block[older + 1, l]
            n2 = ck * block[_TM + 2, l] * block[newer + 2, l] - ek * block[older + 2, l]
            block[_S, l] += c0 * n0
            block[_S + 1, l] += c1 * n1
            block[_S + 2, l] += c2 * n2
            block[older, l] = n0
            block[older + 1, l] = n1
            block[older + 2, l] = n2
        older, newer = newer, older
    for j, mj in ((0, m0), (1, m1), (2, m2)):  # the longer chains on their own
        o, nw = older + j, newer + j
        for k in range(max(mi - 1, 1), mj - 1):
            ck, ek, ct = lpr_work[4, k], lpr_work[5, k], table[j, k + 1]
            for l in range(n_lanes):
                nx = ck * block[_TM + j, l] * block[nw, l] - ek * block[o, l]
                block[_S + j, l] += ct * nx
                block[o, l] = nx
            o, nw = nw, o


@njit(cache=True, error_model="numpy", _nrt=False)
def _rhs(
    block,
    legendre,
    state_row,
    wheel_row,
    rate_row,
    maxwell_row,
    params,
    suspension,
    lpr,
    lpr_work,
    u,
    n_lanes,
):
    """Rates of the states in rows ``state_row`` of ``block`` into rows ``rate_row``
    (``_K + 14·stage``) with the wheel inputs in rows ``wheel_row``; secondary forces in rows
    ``_FS``; out-of-box evaluations in row ``_OUT``. A memory element's Maxwell states are read
    from rows ``maxwell_row`` (``_M`` or ``_MT``), their rates written to rows
    ``_MK + 2·stage``; ``suspension``: the suspension record (bump-stop law of an element with
    that known physics); ``legendre``, ``lpr_work`` and ``u`` (element inputs) are work arrays,
    ``n_lanes`` the block's vehicles."""
    tau = lpr.tau
    mdr = _MK + 2 * ((rate_row - _K) // 14)  # the stage's Maxwell-rate rows
    for l in range(n_lanes):
        block[_OUT, l] = 0.0
    for i in range(2):
        xi = params.a if i == 0 else -params.a
        for l in range(n_lanes):
            zb, vb = block[state_row + 3 + 2 * i, l], block[state_row + 10 + 2 * i, l]
            block[_U, l] = zb - (
                block[state_row, l]
                + xi * block[state_row + 1, l]
                + params.phi_a * block[state_row + 2, l]
            )
            block[_U + 1, l] = vb - (
                block[state_row + 7, l]
                + xi * block[state_row + 8, l]
                + params.phi_a * block[state_row + 9, l]
            )
        if tau > 0.0:
            if lpr.relax_z.shape[0] > 0:
                for l in range(n_lanes):
                    sm = block[maxwell_row + i, l]
                    block[_UZ, l] = block[_U, l] - sm
                    block[mdr + i, l] = relaxation_rate(block[_U, l] - sm, lpr.relax_z, lpr.relax_r)
            else:
                for l in range(n_lanes):
                    sm = block[maxwell_row + i, l]
                    block[_UZ, l] = block[_U, l] - sm
                    block[mdr + i, l] = (block[_U, l] - sm) / tau
            _element_memory(block, lpr, lpr_work, u, n_lanes)
        else:
            _element(block, legendre, lpr, lpr_work, u, n_lanes)
        if lpr.bump:
            for l in range(n_lanes):
                block[_EL, l] += bump_stop_force(block[_U, l], suspension)
        k1w, c1w, b = params.k1w, params.c1w, params.b
        g0, g1 = wheel_row + 4 * i, wheel_row + 4 * i + 2  # lead and trail wheelset of bogie i
        for l in range(n_lanes):
            f = block[_EL, l]
            block[_FS + i, l] = f
            ftot = f + block[_FA + i, l]
            block[_FT + i, l] = ftot
            zb, vb = block[state_row + 3 + 2 * i, l], block[state_row + 10 + 2 * i, l]
            tb, wb = block[state_row + 4 + 2 * i, l], block[state_row + 11 + 2 * i, l]
            lead = k1w * (block[g0, l] - zb - b * tb) + c1w * (block[g0 + 1, l] - vb - b * wb)
            trail = k1w * (block[g1, l] - zb + b * tb) + c1w * (block[g1 + 1, l] - vb + b * wb)
            block[rate_row + 3 + 2 * i, l] = vb
            block[rate_row + 4 + 2 * i, l] = wb
            block[rate_row + 10 + 2 * i, l] = (lead + trail - ftot) * params.inv_m_b
            block[rate_row + 11 + 2 * i, l] = b * (lead - trail) * params.inv_j_b
    for l in range(n_lanes):
        f0, f1 = block[_FT, l], block[_FT + 1, l]
        block[rate_row, l] = block[state_row + 7, l]
        block[rate_row + 1, l] = block[state_row + 8, l]
        block[rate_row + 2, l] = block[state_row + 9, l]
        block[rate_row + 7, l] = (f0 + f1) * params.inv_m_c
        block[rate_row + 8, l] = params.a * (f0 - f1) * params.inv_j_c
        block[rate_row + 9, l] = (
            params.phi_a * (f0 + f1)
            - params.k_q * block[state_row + 2, l]
            - params.c_q * block[state_row + 9, l]
        ) * params.inv_m_q


@njit(cache=True, error_model="numpy", _nrt=False)
def _stage(block, src, scale, n_lanes):
    """Stage state rows ``_XT = _X + scale · (rows src)``."""
    for j in range(_N):
        for l in range(n_lanes):
            block[_XT + j, l] = block[_X + j, l] + scale * block[src + j, l]


@njit(cache=True, error_model="numpy", _nrt=False)
def _stage_memory(block, stage, scale, n_lanes):
    """Maxwell stage rows ``_MT = _M + scale · (rates of stage)``."""
    for j in range(2):
        for l in range(n_lanes):
            block[_MT + j, l] = block[_M + j, l] + scale * block[_MK + 2 * stage + j, l]


@njit(cache=True, error_model="numpy", _nrt=True)
def lanes_block(arrays, i0, n_sub, dt, params, suspension_record, lpr, out):
    """Advance vehicles ``i0 .. i0 + LANES − 1`` (clipped to ``n``) of ``arrays`` by
    ``n_sub`` RK4 steps of ``dt`` (s); arguments as for ``vehicle.advance`` with the
    surrogate variant (track windows checked)."""
    suspension = suspension_record[0]
    memory = lpr.tau > 0.0
    n_lanes = min(LANES, arrays.state.shape[0] - i0)
    block = np.zeros((_ROWS_MEMORY if memory else _ROWS, n_lanes))
    lpr_work = lpr_scratch(lpr.exps, lpr.lo, lpr.up)
    legendre = np.zeros((2, lpr_work.shape[1], n_lanes))
    u = np.empty(lpr.lo.shape[0])
    for l in range(n_lanes):
        i = i0 + l
        for j in range(_N):
            block[_X + j, l] = arrays.state[i, j]
        if memory:
            block[_M, l], block[_M + 1, l] = arrays.state[i, _N], arrays.state[i, _N + 1]
        block[_FA, l], block[_FA + 1, l] = arrays.force[i, 0], arrays.force[i, 1]
        block[_ALIVE, l] = 1.0
    h6 = dt / 6.0
    half = 0.5 * dt
    _inputs(block, arrays, i0, n_lanes, 0.0, dt, _W)
    for m in range(n_sub):
        _rhs(block, legendre, _X, _W, _K, _M, params, suspension, lpr, lpr_work, u, n_lanes)
        for l in range(n_lanes):
            block[_OSUM, l] = block[_OUT, l]
        _inputs(block, arrays, i0, n_lanes, m + 0.5, dt, _WM)
        _stage(block, _K, half, n_lanes)
        if memory:
            _stage_memory(block, 0, half, n_lanes)
        _rhs(block, legendre, _XT, _WM, _K + 14, _MT, params, suspension, lpr, lpr_work, u, n_lanes)
        for l in range(n_lanes):
            block[_OSUM, l] += block[_OUT, l]
        _stage(block, _K + 14, half, n_lanes)
        if memory:
            _stage_memory(block, 1, half, n_lanes)
        _rhs(block, legendre, _XT, _WM, _K + 28, _MT, params, suspension, lpr, lpr_work, u, n_lanes)
        for l in range(n_lanes):
            block[_OSUM, l] += block[_OUT, l]
        _inputs(block, arrays, i0, n_lanes, m + 1.0, dt, _W)
        _stage(block, _K + 28, dt, n_lanes)
        if memory:
            _stage_memory(block, 2, dt, n_lanes)
        _rhs(block, legendre, _XT, _W, _K + 42, _MT, params, suspension, lpr, lpr_work, u, n_lanes)
        alive = 0.0
        for l in range(n_lanes):
            block[_OOD, l] += block[_ALIVE, l] * (block[_OSUM, l] + block[_OUT, l])
            ok = True
            for j in range(_N):
                v = block[_X + j, l] + h6 * (
                    block[_K + j, l]
                    + 2.0 * block[_K + 14 + j, l]
                    + 2.0 * block[_K + 28 + j, l]
                    + block[_K + 42 + j, l]
                )
                block[_XT + j, l] = v
                ok = ok and abs(v) <= _BIG
                if j < 7:
                    ok = ok and abs(v) <= _DIV
            if memory:
                for j in range(2):
                    v = block[_M + j, l] + h6 * (
                        block[_MK + j, l]
                        + 2.0 * block[_MK + 2 + j, l]
                        + 2.0 * block[_MK + 4 + j, l]
                        + block[_MK + 6 + j, l]
                    )
                    block[_MT + j, l] = v
                    ok = ok and abs(v) <= _BIG
            a = block[_ALIVE, l] if ok else 0.0
            block[_ALIVE, l] = a
            for j in range(_N):
                block[_X + j, l] = block[_XT + j, l] if a > 0.0 else block[_X + j, l]
            if memory:
                for j in range(2):
                    block[_M + j, l] = block[_MT + j, l] if a > 0.0 else block[_M + j, l]
            for b in range(2):
                xb = params.a if b == 0 else -params.a
                d = (
                    block[_X + 3 + 2 * b, l]
                    - block[_X, l]
                    - xb * block[_X + 1, l]
                    - params.phi_a * block[_X + 2, l]
                )
                touch = 1.0 if (d > suspension.free_c) | (d < -suspension.free_r) else 0.0
                block[_CONTACT, l] += a * touch
            alive += a
        if alive == 0.0:
            break
    _rhs(block, legendre, _X, _W, _K, _M, params, suspension, lpr, lpr_work, u, n_lanes)
    for l in range(n_lanes):
        i = i0 + l
        for j in range(_N):
            arrays.state[i, j] = block[_X + j, l]
        if memory:
            arrays.state[i, _N], arrays.state[i, _N + 1] = block[_M, l], block[_M + 1, l]
        d7, d8, d9 = block[_K + 7, l], block[_K + 8, l], block[_K + 9, l]
        acc = (
            d7 + params.a * d8 + params.phi_a * d9,
            d7 + params.phi_c * d9,
            d7 - params.a * d8 + params.phi_a * d9,
            block[_K + 10, l],
            block[_K + 12, l],
        )
        div = block[_ALIVE, l] == 0.0
        for j in range(5):
            div = div or not abs(acc[j]) <= _BIG
        for j in range(5):
            out.acc[i, j] = 0.0 if div else acc[j]
        out.fs[i, 0] = 0.0 if div else block[_FS, l]
        out.fs[i, 1] = 0.0 if div else block[_FS + 1, l]
        out.count[i, 0] = int(block[_CONTACT, l])
        out.count[i, 1] = int(block[_OOD, l])
        out.div[i] = div
