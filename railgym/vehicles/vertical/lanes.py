"""SIMD lane kernel of the surrogate variant with an additive LPR element.

The vehicles are taken ``LANES`` at a time (one block); every statement of the RK4 step is a
loop over the lanes of a block on structure-of-arrays rows of one work array, without
branches, so that LLVM vectorises it across vehicles. The arithmetic per vehicle is the one of
the scalar kernel (``kernels._advance_scalar``) operation for
operation, so both give bit-identical results (tested). Lanes past the last vehicle of a
partial block repeat its first vehicle and are discarded. Inputs outside the element's box
(a rare event) are evaluated lane by lane with the scalar linear extension.

Blocks are independent: batches of ``PARALLEL_MIN`` vehicles or more run on all numba threads
(``prange`` over blocks), with the same block function and so the same results.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import njit, prange

from railgym.vehicles.vertical.elements import bump_stop_force
from surrogates.models.lpr import additive_terms, lpr_eval_into, lpr_scratch

__all__ = ["LANES", "LANES_MIN", "PARALLEL_MIN", "advance_lanes", "advance_lanes_parallel"]

#: vehicles per block (the length of the vectorised loops)
LANES = 64
#: batches of fewer vehicles run the scalar kernel (same results, less loop overhead)
LANES_MIN = 8
# Start numba's threading layer now: a cached parallel kernel links against its symbols when
# it is loaded.
numba.get_num_threads()
#: batches of at least this many vehicles run on all numba threads
PARALLEL_MIN = 256
#: |x1| or |x2| above this (m) counts as divergence (``kernels.DIVERGENCE_DISPLACEMENT``)
_DIV = 10.0
_BIG = 1.7976931348623157e308  # largest float64: |v| <= _BIG is False for NaN and ±inf

# rows of the block's work array (each row holds one quantity for the LANES lanes)
_X = 0  # state x (5 rows)
_XT = 5  # stage state (5 rows)
_K = 10  # stage derivatives k1..k4 (4 × 5 rows)
_ZA, _ZDA, _ZB, _ZDB, _ZM, _ZDM = 30, 31, 32, 33, 34, 35  # track input (m, m/s)
_FA = 36  # actuator force, N
_U = 37  # element inputs (3 rows)
_T = 40  # inputs mapped to [-1, 1] (3 rows)
_A, _B, _S = 43, 46, 49  # recurrence P_{k-1}, P_k and partial sums (3 rows each)
_FS = 52  # element force, N
_OUT = 53  # 1.0 where an input is outside the box
_OSUM = 54  # outside stages of this substep
_ALIVE = 55  # 1.0 while not diverged
_CONTACT, _OOD = 56, 57  # counters of the control step
_ROWS = 58


@njit(cache=True, error_model="numpy", _nrt=False)
def _element(w, lpr, lw, u, nb):
    """Element force ``F̂(u)`` into row ``_FS`` from the inputs in rows ``_U``: the additive
    Legendre sums of :func:`~surrogates.models.lpr.lpr_additive_inside` lane-parallel, then
    the lanes outside the box by :func:`~surrogates.models.lpr.lpr_eval_into`."""
    d = lpr.lo.shape[0]
    table = lpr.table
    n = table.shape[1]
    lo, up = lpr.lo, lpr.up
    for l in range(nb):
        w[_OUT, l] = 0.0
    for j in range(d):
        lj, uj, sc = lo[j], up[j], lw[d + 3, j]
        for l in range(nb):
            v = w[_U + j, l]
            w[_OUT, l] = max(w[_OUT, l], 1.0 if (v < lj) | (v > uj) else 0.0)
            t = (v - lj) * sc - 1.0
            w[_T + j, l] = t
            w[_A + j, l] = 1.0
            w[_B + j, l] = t
    c0 = table[0, 0]
    for j in range(1, d):
        c0 = c0 + table[j, 0]
    for l in range(nb):
        w[_S, l] = c0
    for j in range(1, d):
        for l in range(nb):
            w[_S + j, l] = 0.0
    if n > 1:
        for j in range(d):
            c1 = table[j, 1]
            for l in range(nb):
                w[_S + j, l] += c1 * w[_T + j, l]
    for j in range(d):
        older, newer = _A + j, _B + j  # rows of P_{k-1}, P_k; P_{k+1} overwrites P_{k-1}
        for k in range(1, additive_terms(table, j) - 1):  # up to its last nonzero term
            ck, ek, ct = lw[d + 1, k], lw[d + 2, k], table[j, k + 1]
            for l in range(nb):
                nx = ck * w[_T + j, l] * w[newer, l] - ek * w[older, l]
                w[_S + j, l] += ct * nx
                w[older, l] = nx
            older, newer = newer, older
    for l in range(nb):
        w[_FS, l] = w[_S, l]
    for j in range(1, d):
        for l in range(nb):
            w[_FS, l] += w[_S + j, l]
    outside = 0.0
    for l in range(nb):
        outside += w[_OUT, l]
    if outside > 0.0:
        for l in range(nb):
            if w[_OUT, l] > 0.0:
                for j in range(d):
                    u[j] = w[_U + j, l]
                w[_FS, l] = lpr_eval_into(u, lpr.exps, lpr.coef, lo, up, lpr.mode, lw)


@njit(cache=True, error_model="numpy", _nrt=False)
def _rhs(w, xr, dr, zr, q, lpr, lw, u, nb):
    """Derivatives of the states in rows ``xr`` into rows ``dr`` with the track input in rows
    ``zr, zr + 1``; the force in row ``_FS``, the outside flags in row ``_OUT``."""
    tau = lpr.tau
    for l in range(nb):
        w[_U, l] = w[xr, l] - w[xr + 2, l]
        w[_U + 1, l] = w[xr + 1, l] - w[xr + 3, l]
    if tau > 0.0:
        for l in range(nb):
            w[_U + 2, l] = w[_U, l] - w[xr + 4, l]
            w[dr + 4, l] = (w[_U, l] - w[xr + 4, l]) / tau
    else:
        for l in range(nb):
            w[dr + 4, l] = 0.0
    _element(w, lpr, lw, u, nb)
    k1, c1, m1, m2 = q.k1, q.c1, q.m1, q.m2
    bump = lpr.bump
    for l in range(nb):
        fs = w[_FS, l]
        if bump:
            fs += bump_stop_force(w[_U, l], q)
        w[_FS, l] = fs
        fa = w[_FA, l]
        x0, x1 = w[xr, l], w[xr + 1, l]
        w[dr, l] = x1
        w[dr + 1, l] = (k1 * (w[zr, l] - x0) + c1 * (w[zr + 1, l] - x1) - fs - fa) / m1
        w[dr + 2, l] = w[xr + 3, l]
        w[dr + 3, l] = (fs + fa) / m2


@njit(cache=True, error_model="numpy", _nrt=False)
def _stage(w, src, scale, nb):
    """Stage state rows ``_XT = _X + scale · (rows src)``."""
    for j in range(5):
        for l in range(nb):
            w[_XT + j, l] = w[_X + j, l] + scale * w[src + j, l]


@njit(cache=True, error_model="numpy", _nrt=True)
def _block(state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out, i0):
    """One block of vehicles ``i0 .. i0 + LANES − 1`` (clipped to ``n``), see
    :func:`advance_lanes`."""
    n, s = state.shape
    q = p[0]
    nb = min(LANES, n - i0)
    w = np.zeros((_ROWS, nb))
    lw = lpr_scratch(lpr.exps, lpr.lo, lpr.up)
    u = np.empty(lpr.lo.shape[0])
    for l in range(nb):
        i = i0 + l
        for j in range(s):
            w[_X + j, l] = state[i, j]
        w[_FA, l] = force_a[i]
        w[_ALIVE, l] = 1.0
    h6 = dt / 6.0
    dt8 = 0.125 * dt
    c3 = 1.5 / dt
    half = 0.5 * dt
    for m in range(n_sub):
        for l in range(nb):
            i = i0 + l
            ka = k0[i] + m
            za, zda = z[i, ka], zdot[i, ka]
            zb, zdb = z[i, ka + 1], zdot[i, ka + 1]
            w[_ZA, l], w[_ZDA, l], w[_ZB, l], w[_ZDB, l] = za, zda, zb, zdb
            w[_ZM, l] = 0.5 * (za + zb) + dt8 * (zda - zdb)
            w[_ZDM, l] = c3 * (zb - za) - 0.25 * (zda + zdb)
        _rhs(w, _X, _K, _ZA, q, lpr, lw, u, nb)
        for l in range(nb):
            w[_OSUM, l] = w[_OUT, l]
        _stage(w, _K, half, nb)
        _rhs(w, _XT, _K + 5, _ZM, q, lpr, lw, u, nb)
        for l in range(nb):
            w[_OSUM, l] += w[_OUT, l]
        _stage(w, _K + 5, half, nb)
        _rhs(w, _XT, _K + 10, _ZM, q, lpr, lw, u, nb)
        for l in range(nb):
            w[_OSUM, l] += w[_OUT, l]
        _stage(w, _K + 10, dt, nb)
        _rhs(w, _XT, _K + 15, _ZB, q, lpr, lw, u, nb)
        alive = 0.0
        for l in range(nb):
            w[_OSUM, l] += w[_OUT, l]
            w[_OOD, l] += w[_ALIVE, l] * w[_OSUM, l]
            ok = True
            for j in range(5):
                v = w[_X + j, l] + h6 * (
                    w[_K + j, l]
                    + 2.0 * w[_K + 5 + j, l]
                    + 2.0 * w[_K + 10 + j, l]
                    + w[_K + 15 + j, l]
                )
                w[_XT + j, l] = v
                ok = ok and abs(v) <= _BIG
            ok = ok and abs(w[_XT, l]) <= _DIV and abs(w[_XT + 2, l]) <= _DIV
            a = w[_ALIVE, l] if ok else 0.0
            w[_ALIVE, l] = a
            for j in range(5):
                w[_X + j, l] = w[_XT + j, l] if a > 0.0 else w[_X + j, l]
            dc = w[_X, l] - w[_X + 2, l]
            touch = 1.0 if (dc > q.free_c) | (dc < -q.free_r) else 0.0
            w[_CONTACT, l] += a * touch
            alive += a
        if alive == 0.0:
            break
    for l in range(nb):
        i = i0 + l
        ke = k0[i] + n_sub
        w[_ZA, l], w[_ZDA, l] = z[i, ke], zdot[i, ke]
    _rhs(w, _X, _K, _ZA, q, lpr, lw, u, nb)
    for l in range(nb):
        i = i0 + l
        for j in range(s):
            state[i, j] = w[_X + j, l]
        fs, a1, a2 = w[_FS, l], w[_K + 1, l], w[_K + 3, l]
        div = w[_ALIVE, l] == 0.0
        if not div and abs(fs) <= _BIG and abs(a1) <= _BIG and abs(a2) <= _BIG:
            out.acc[i, 0] = a1
            out.acc[i, 1] = a2
            out.force[i] = fs
        else:
            div = True
            out.acc[i, 0] = 0.0
            out.acc[i, 1] = 0.0
            out.force[i] = 0.0
        out.count[i, 0] = int(w[_CONTACT, l])
        out.count[i, 1] = int(w[_OOD, l])
        out.div[i] = div


@njit(cache=True, error_model="numpy", parallel=True, _nrt=True)
def advance_lanes_parallel(state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out):
    """:func:`advance_lanes` on all numba threads (``prange`` over the blocks), with the same
    results."""
    _check(state, z, k0, n_sub, lpr)
    blocks = (state.shape[0] + LANES - 1) // LANES
    for b in prange(blocks):
        _block(state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out, b * LANES)


@njit(cache=True, error_model="numpy")
def _check(state, z, k0, n_sub, lpr):
    """Raise for a memory element without its state or a track window out of range."""
    n, s = state.shape
    if lpr.tau > 0.0 and s < 5:
        raise ValueError("a memory surrogate element needs 5 states [x1, v1, x2, v2, s]")
    for i in range(n):
        kk = k0[i]
        if kk < 0 or kk + n_sub > z.shape[1] - 1:
            raise ValueError("track index out of range: need 0 <= k0 and k0 + n_sub <= N")


@njit(cache=True, error_model="numpy", _nrt=True)
def advance_lanes(state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out):
    """Advance ``n`` vehicles by ``n_sub`` RK4 substeps of ``dt`` (s) with an additive
    surrogate element, in place, one block after another; arguments as for
    :func:`~railgym.vehicles.vertical.kernels.advance_surrogate` (``lpr.additive`` set)."""
    _check(state, z, k0, n_sub, lpr)
    for i0 in range(0, state.shape[0], LANES):
        _block(state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out, i0)
