"""SIMD lane kernel of the whole vehicle with the surrogate secondary suspension.

As :mod:`railgym.vehicles.vertical.lanes` for the one-bogie model: vehicles are taken
``LANES`` at a time, each quantity of the RK4 step is a row of a block's work array and each
statement a loop over the block's vehicles that LLVM vectorises. The arithmetic per vehicle is
that of :func:`railgym.vehicles.vehicle._advance_one` operation for operation (the LPR
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

__all__ = ["LANES", "LANES_MIN", "hermite", "lanes_block"]

#: vehicles per block (the length of the vectorised loops)
LANES = 64
#: batches of fewer vehicles run the per-vehicle kernel (same results)
LANES_MIN = 8
_N = 14  # mechanical states
_DIV = 10.0  # |displacement| (m) above this counts as divergence (``vehicle`` module)
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
def hermite(z: np.ndarray, zd: np.ndarray, pos: float, dt: float) -> tuple[float, float]:
    """Cubic Hermite value and rate of the sampled track at fractional index ``pos``."""
    i0 = int(math.floor(pos))
    u = pos - i0
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
def _inputs(w, bt, i0, nb, pos, dt, row):
    """Wheel inputs of the block's vehicles at sample index ``k + pos`` into rows ``row..``."""
    for l in range(nb):
        i = i0 + l
        base = bt.k[i] + pos
        z, zd = bt.z[i], bt.zdot[i]
        for j in range(4):
            v, r = hermite(z, zd, base + bt.off[i, j], dt)
            w[row + 2 * j, l] = v
            w[row + 2 * j + 1, l] = r


@njit(cache=True, error_model="numpy", _nrt=False)
def _element(w, pt, lpr, lw, u, nb):
    """LPR value of the inputs in rows ``_U`` into row ``_EL``; out-of-box flags added to
    row ``_OUT`` (as ``lpr_is_outside``)."""
    lo0, lo1, up0, up1 = lpr.lo[0], lpr.lo[1], lpr.up[0], lpr.up[1]
    s0, s1 = lw[5, 0], lw[5, 1]
    nmax = lw.shape[1] - 1
    for l in range(nb):
        v0, v1 = w[_U, l], w[_U + 1, l]
        out = (v0 < lo0) | (v0 > up0) | (v1 < lo1) | (v1 > up1)
        w[_OUT, l] += 1.0 if out else 0.0
        c0 = min(max(v0, lo0), up0)
        c1 = min(max(v1, lo1), up1)
        w[_FB, l] = 1.0 if (c0 != v0) | (c1 != v1) else 0.0
        t0 = (c0 - lo0) * s0 - 1.0
        t1 = (c1 - lo1) * s1 - 1.0
        w[_T, l], w[_T + 1, l] = t0, t1
        pt[0, 0, l], pt[1, 0, l], pt[0, 1, l], pt[1, 1, l] = 1.0, 1.0, t0, t1
        w[_EL, l] = 0.0
    for k in range(1, nmax):
        ck, ek = lw[3, k], lw[4, k]
        for l in range(nb):
            pt[0, k + 1, l] = ck * w[_T, l] * pt[0, k, l] - ek * pt[0, k - 1, l]
            pt[1, k + 1, l] = ck * w[_T + 1, l] * pt[1, k, l] - ek * pt[1, k - 1, l]
    for m in range(lpr.exps.shape[0]):
        c, e0, e1 = lpr.coef[m], lpr.exps[m, 0], lpr.exps[m, 1]
        for l in range(nb):
            w[_EL, l] += c * pt[0, e0, l] * pt[1, e1, l]
    if lpr.mode == 1:
        return
    for l in range(nb):
        if w[_FB, l] > 0.0:
            u[0], u[1] = w[_U, l], w[_U + 1, l]
            w[_EL, l] = lpr_eval_into(u, lpr.exps, lpr.coef, lpr.lo, lpr.up, lpr.mode, lw)


@njit(cache=True, error_model="numpy", _nrt=False)
def _element_memory(w, lpr, lw, u, nb):
    """Value of an additive three-input (memory) element at the inputs in rows ``_U, _U + 1,
    _UZ`` into row ``_EL``: the operations of :func:`~surrogates.models.lpr.lpr_additive_inside`
    (three interleaved recurrences) lane by lane; lanes outside the box by ``lpr_eval_into``
    (their flags added to row ``_OUT``)."""
    table, lo, up = lpr.table, lpr.lo, lpr.up
    n = table.shape[1]
    for l in range(nb):
        w[_FB, l] = 0.0
    for j in range(3):
        row = _U + j if j < 2 else _UZ
        lj, uj, sc = lo[j], up[j], lw[6, j]
        for l in range(nb):
            v = w[row, l]
            w[_FB, l] = max(w[_FB, l], 1.0 if (v < lj) | (v > uj) else 0.0)
            t = (v - lj) * sc - 1.0
            w[_TM + j, l] = t
            w[_A + j, l] = 1.0
            w[_B + j, l] = t
    c0 = table[0, 0] + table[1, 0] + table[2, 0]
    for l in range(nb):
        w[_S, l] = c0
        w[_S + 1, l] = 0.0
        w[_S + 2, l] = 0.0
    if n > 1:
        for j in range(3):
            c1 = table[j, 1]
            for l in range(nb):
                w[_S + j, l] += c1 * w[_TM + j, l]
    older, newer = _A, _B  # rows of P_{k-1}, P_k (3 each); P_{k+1} overwrites P_{k-1}
    m0, m1, m2 = additive_terms(table, 0), additive_terms(table, 1), additive_terms(table, 2)
    mi = min(m0, m1, m2)
    for k in range(1, mi - 1):
        ck, ek = lw[4, k], lw[5, k]
        c0, c1, c2 = table[0, k + 1], table[1, k + 1], table[2, k + 1]
        for l in range(nb):  # the three chains interleaved, as lpr_additive_inside
            n0 = ck * w[_TM, l] * w[newer, l] - ek * w[older, l]
            n1 = ck * w[_TM + 1, l] * w[newer + 1, l] - ek * w[older + 1, l]
            n2 = ck * w[_TM + 2, l] * w[newer + 2, l] - ek * w[older + 2, l]
            w[_S, l] += c0 * n0
            w[_S + 1, l] += c1 * n1
            w[_S + 2, l] += c2 * n2
            w[older, l] = n0
            w[older + 1, l] = n1
            w[older + 2, l] = n2
        older, newer = newer, older
    for j, mj in ((0, m0), (1, m1), (2, m2)):  # the longer chains on their own
        o, nw = older + j, newer + j
        for k in range(max(mi - 1, 1), mj - 1):
            ck, ek, ct = lw[4, k], lw[5, k], table[j, k + 1]
            for l in range(nb):
                nx = ck * w[_TM + j, l] * w[nw, l] - ek * w[o, l]
                w[_S + j, l] += ct * nx
                w[o, l] = nx
            o, nw = nw, o
    outside = 0.0
    for l in range(nb):
        w[_EL, l] = w[_S, l] + w[_S + 1, l] + w[_S + 2, l]
        w[_OUT, l] += w[_FB, l]
        outside += w[_FB, l]
    if outside > 0.0:
        for l in range(nb):
            if w[_FB, l] > 0.0:
                u[0], u[1], u[2] = w[_U, l], w[_U + 1, l], w[_UZ, l]
                w[_EL, l] = lpr_eval_into(u, lpr.exps, lpr.coef, lo, up, lpr.mode, lw)


@njit(cache=True, error_model="numpy", _nrt=False)
def _rhs(w, pt, xr, wr, dr, mr, p, q, lpr, lw, u, nb):
    """Rates of the states in rows ``xr`` into rows ``dr`` (``_K + 14·stage``) with the wheel
    inputs in rows ``wr``; secondary forces in rows ``_FS``; out-of-box evaluations in row
    ``_OUT``. A memory element's Maxwell states are read from rows ``mr`` (``_M`` or ``_MT``),
    their rates written to rows ``_MK + 2·stage``; ``q``: the suspension record (bump-stop
    law of an element with that known physics)."""
    tau = lpr.tau
    mdr = _MK + 2 * ((dr - _K) // 14)  # the stage's Maxwell-rate rows
    for l in range(nb):
        w[_OUT, l] = 0.0
    for i in range(2):
        xi = p.a if i == 0 else -p.a
        for l in range(nb):
            zb, vb = w[xr + 3 + 2 * i, l], w[xr + 10 + 2 * i, l]
            w[_U, l] = zb - (w[xr, l] + xi * w[xr + 1, l] + p.phi_a * w[xr + 2, l])
            w[_U + 1, l] = vb - (w[xr + 7, l] + xi * w[xr + 8, l] + p.phi_a * w[xr + 9, l])
        if tau > 0.0:
            if lpr.relax_z.shape[0] > 0:
                for l in range(nb):
                    sm = w[mr + i, l]
                    w[_UZ, l] = w[_U, l] - sm
                    w[mdr + i, l] = relaxation_rate(w[_U, l] - sm, lpr.relax_z, lpr.relax_r)
            else:
                for l in range(nb):
                    sm = w[mr + i, l]
                    w[_UZ, l] = w[_U, l] - sm
                    w[mdr + i, l] = (w[_U, l] - sm) / tau
            _element_memory(w, lpr, lw, u, nb)
        else:
            _element(w, pt, lpr, lw, u, nb)
        if lpr.bump:
            for l in range(nb):
                w[_EL, l] += bump_stop_force(w[_U, l], q)
        k1w, c1w, b = p.k1w, p.c1w, p.b
        g0, g1 = wr + 4 * i, wr + 4 * i + 2  # lead and trail wheelset of bogie i
        for l in range(nb):
            f = w[_EL, l]
            w[_FS + i, l] = f
            ftot = f + w[_FA + i, l]
            w[_FT + i, l] = ftot
            zb, vb = w[xr + 3 + 2 * i, l], w[xr + 10 + 2 * i, l]
            tb, wb = w[xr + 4 + 2 * i, l], w[xr + 11 + 2 * i, l]
            lead = k1w * (w[g0, l] - zb - b * tb) + c1w * (w[g0 + 1, l] - vb - b * wb)
            trail = k1w * (w[g1, l] - zb + b * tb) + c1w * (w[g1 + 1, l] - vb + b * wb)
            w[dr + 3 + 2 * i, l] = vb
            w[dr + 4 + 2 * i, l] = wb
            w[dr + 10 + 2 * i, l] = (lead + trail - ftot) * p.inv_m_b
            w[dr + 11 + 2 * i, l] = b * (lead - trail) * p.inv_j_b
    for l in range(nb):
        f0, f1 = w[_FT, l], w[_FT + 1, l]
        w[dr, l] = w[xr + 7, l]
        w[dr + 1, l] = w[xr + 8, l]
        w[dr + 2, l] = w[xr + 9, l]
        w[dr + 7, l] = (f0 + f1) * p.inv_m_c
        w[dr + 8, l] = p.a * (f0 - f1) * p.inv_j_c
        w[dr + 9, l] = (
            p.phi_a * (f0 + f1) - p.k_q * w[xr + 2, l] - p.c_q * w[xr + 9, l]
        ) * p.inv_m_q


@njit(cache=True, error_model="numpy", _nrt=False)
def _stage(w, src, scale, nb):
    """Stage state rows ``_XT = _X + scale · (rows src)``."""
    for j in range(_N):
        for l in range(nb):
            w[_XT + j, l] = w[_X + j, l] + scale * w[src + j, l]


@njit(cache=True, error_model="numpy", _nrt=False)
def _stage_memory(w, stage, scale, nb):
    """Maxwell stage rows ``_MT = _M + scale · (rates of stage)``."""
    for j in range(2):
        for l in range(nb):
            w[_MT + j, l] = w[_M + j, l] + scale * w[_MK + 2 * stage + j, l]


@njit(cache=True, error_model="numpy", _nrt=True)
def lanes_block(bt, i0, n_sub, dt, p, e, lpr, out):
    """Advance vehicles ``i0 .. i0 + LANES − 1`` (clipped to ``n``) of the batch ``bt`` by
    ``n_sub`` RK4 steps of ``dt`` (s); arguments as for ``vehicle.advance`` with the
    surrogate variant (``e``: the suspension record array, track windows checked)."""
    q = e[0]
    memory = lpr.tau > 0.0
    nb = min(LANES, bt.state.shape[0] - i0)
    w = np.zeros((_ROWS_MEMORY if memory else _ROWS, nb))
    lw = lpr_scratch(lpr.exps, lpr.lo, lpr.up)
    pt = np.zeros((2, lw.shape[1], nb))
    u = np.empty(lpr.lo.shape[0])
    for l in range(nb):
        i = i0 + l
        for j in range(_N):
            w[_X + j, l] = bt.state[i, j]
        if memory:
            w[_M, l], w[_M + 1, l] = bt.state[i, _N], bt.state[i, _N + 1]
        w[_FA, l], w[_FA + 1, l] = bt.force[i, 0], bt.force[i, 1]
        w[_ALIVE, l] = 1.0
    h6 = dt / 6.0
    half = 0.5 * dt
    _inputs(w, bt, i0, nb, 0.0, dt, _W)
    for m in range(n_sub):
        _rhs(w, pt, _X, _W, _K, _M, p, q, lpr, lw, u, nb)
        for l in range(nb):
            w[_OSUM, l] = w[_OUT, l]
        _inputs(w, bt, i0, nb, m + 0.5, dt, _WM)
        _stage(w, _K, half, nb)
        if memory:
            _stage_memory(w, 0, half, nb)
        _rhs(w, pt, _XT, _WM, _K + 14, _MT, p, q, lpr, lw, u, nb)
        for l in range(nb):
            w[_OSUM, l] += w[_OUT, l]
        _stage(w, _K + 14, half, nb)
        if memory:
            _stage_memory(w, 1, half, nb)
        _rhs(w, pt, _XT, _WM, _K + 28, _MT, p, q, lpr, lw, u, nb)
        for l in range(nb):
            w[_OSUM, l] += w[_OUT, l]
        _inputs(w, bt, i0, nb, m + 1.0, dt, _W)
        _stage(w, _K + 28, dt, nb)
        if memory:
            _stage_memory(w, 2, dt, nb)
        _rhs(w, pt, _XT, _W, _K + 42, _MT, p, q, lpr, lw, u, nb)
        alive = 0.0
        for l in range(nb):
            w[_OOD, l] += w[_ALIVE, l] * (w[_OSUM, l] + w[_OUT, l])
            ok = True
            for j in range(_N):
                v = w[_X + j, l] + h6 * (
                    w[_K + j, l]
                    + 2.0 * w[_K + 14 + j, l]
                    + 2.0 * w[_K + 28 + j, l]
                    + w[_K + 42 + j, l]
                )
                w[_XT + j, l] = v
                ok = ok and abs(v) <= _BIG
                if j < 7:
                    ok = ok and abs(v) <= _DIV
            if memory:
                for j in range(2):
                    v = w[_M + j, l] + h6 * (
                        w[_MK + j, l]
                        + 2.0 * w[_MK + 2 + j, l]
                        + 2.0 * w[_MK + 4 + j, l]
                        + w[_MK + 6 + j, l]
                    )
                    w[_MT + j, l] = v
                    ok = ok and abs(v) <= _BIG
            a = w[_ALIVE, l] if ok else 0.0
            w[_ALIVE, l] = a
            for j in range(_N):
                w[_X + j, l] = w[_XT + j, l] if a > 0.0 else w[_X + j, l]
            if memory:
                for j in range(2):
                    w[_M + j, l] = w[_MT + j, l] if a > 0.0 else w[_M + j, l]
            for b in range(2):
                xb = p.a if b == 0 else -p.a
                d = w[_X + 3 + 2 * b, l] - w[_X, l] - xb * w[_X + 1, l] - p.phi_a * w[_X + 2, l]
                touch = 1.0 if (d > q.free_c) | (d < -q.free_r) else 0.0
                w[_CONTACT, l] += a * touch
            alive += a
        if alive == 0.0:
            break
    _rhs(w, pt, _X, _W, _K, _M, p, q, lpr, lw, u, nb)
    for l in range(nb):
        i = i0 + l
        for j in range(_N):
            bt.state[i, j] = w[_X + j, l]
        if memory:
            bt.state[i, _N], bt.state[i, _N + 1] = w[_M, l], w[_M + 1, l]
        d7, d8, d9 = w[_K + 7, l], w[_K + 8, l], w[_K + 9, l]
        acc = (
            d7 + p.a * d8 + p.phi_a * d9,
            d7 + p.phi_c * d9,
            d7 - p.a * d8 + p.phi_a * d9,
            w[_K + 10, l],
            w[_K + 12, l],
        )
        div = w[_ALIVE, l] == 0.0
        for j in range(5):
            div = div or not abs(acc[j]) <= _BIG
        for j in range(5):
            out.acc[i, j] = 0.0 if div else acc[j]
        out.fs[i, 0] = 0.0 if div else w[_FS, l]
        out.fs[i, 1] = 0.0 if div else w[_FS + 1, l]
        out.count[i, 0] = int(w[_CONTACT, l])
        out.count[i, 1] = int(w[_OOD, l])
        out.div[i] = div
