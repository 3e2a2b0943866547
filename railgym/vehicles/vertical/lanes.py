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
from surrogates.models.lpr_grid import grid_eval

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
_U = 37  # element inputs (4 rows: δ, δ̇, ζ and the product input δ·ζ)
_T = 41  # inputs mapped to [-1, 1] (4 rows)
_A, _B, _S = 45, 49, 53  # recurrence P_{k-1}, P_k and partial sums (4 rows each)
_FS = 57  # element force, N
_OUT = 58  # 1.0 where an input is outside the box
_OSUM = 59  # outside stages of this substep
_ALIVE = 60  # 1.0 while not diverged
_CONTACT, _OOD = 61, 62  # counters of the control step
_ROWS = 63


@njit(cache=True, error_model="numpy", _nrt=False)
def _element(block, lpr, lpr_work, u, n_lanes):
    """Element force ``F̂(u)`` into row ``_FS`` from the inputs in rows ``_U``: the additive
    Legendre sums of :func:`~surrogates.models.lpr.lpr_additive_inside` (or the Hermite
    tables of a gridded element) lane-parallel, then the lanes outside the box by
    :func:`~surrogates.models.lpr.lpr_eval_into`."""
    d = lpr.lo.shape[0]
    lo, up = lpr.lo, lpr.up
    for l in range(n_lanes):
        block[_OUT, l] = 0.0
    for j in range(d):
        lj, uj = lo[j], up[j]
        for l in range(n_lanes):
            v = block[_U + j, l]
            block[_OUT, l] = max(block[_OUT, l], 1.0 if (v < lj) | (v > uj) else 0.0)
    if lpr.gridded:
        _grid_sums(block, lpr, n_lanes)
    else:
        _legendre_sums(block, lpr, lpr_work, n_lanes)
    for l in range(n_lanes):
        block[_FS, l] = block[_S, l]
    for j in range(1, d):
        for l in range(n_lanes):
            block[_FS, l] += block[_S + j, l]
    outside = 0.0
    for l in range(n_lanes):
        outside += block[_OUT, l]
    if outside > 0.0:
        for l in range(n_lanes):
            if block[_OUT, l] > 0.0:
                for j in range(d):
                    u[j] = block[_U + j, l]
                block[_FS, l] = lpr_eval_into(u, lpr.exps, lpr.coef, lo, up, lpr.mode, lpr_work)


@njit(cache=True, error_model="numpy", _nrt=False)
def _grid_sums(block, lpr, n_lanes):
    """Row ``_S + j``: the Hermite table ``j`` of a gridded element at the inputs in row
    ``_U + j`` (:func:`~surrogates.models.lpr_grid.grid_eval`, every lane)."""
    coef, lo, scale, top = lpr.grid, lpr.lo, lpr.grid_scale, lpr.grid_top
    for j in range(lo.shape[0]):
        lj, sj, tj = lo[j], scale[j], top[j]
        for l in range(n_lanes):
            block[_S + j, l] = grid_eval(block[_U + j, l], lj, sj, tj, coef, j)


@njit(cache=True, error_model="numpy", _nrt=False)
def _legendre_sums(block, lpr, lpr_work, n_lanes):
    """Row ``_S + j``: the Legendre sum of input ``j`` (the constant in row ``_S``) at the
    inputs in rows ``_U`` (mapped into rows ``_T``), the recurrences lane-parallel."""
    d = lpr.lo.shape[0]
    table = lpr.table
    n = table.shape[1]
    for j in range(d):
        lj, scale = lpr.lo[j], lpr_work[d + 3, j]
        for l in range(n_lanes):
            t = (block[_U + j, l] - lj) * scale - 1.0
            block[_T + j, l] = t
            block[_A + j, l] = 1.0
            block[_B + j, l] = t
    c0 = table[0, 0]
    for j in range(1, d):
        c0 = c0 + table[j, 0]
    for l in range(n_lanes):
        block[_S, l] = c0
    for j in range(1, d):
        for l in range(n_lanes):
            block[_S + j, l] = 0.0
    if n > 1:
        for j in range(d):
            c1 = table[j, 1]
            for l in range(n_lanes):
                block[_S + j, l] += c1 * block[_T + j, l]
    for j in range(d):
        older, newer = _A + j, _B + j  # rows of P_{k-1}, P_k; P_{k+1} overwrites P_{k-1}
        for k in range(1, additive_terms(table, j) - 1):  # up to its last nonzero term
            ck, ek, ct = lpr_work[d + 1, k], lpr_work[d + 2, k], table[j, k + 1]
            for l in range(n_lanes):
                nx = ck * block[_T + j, l] * block[newer, l] - ek * block[older, l]
                block[_S + j, l] += ct * nx
                block[older, l] = nx
            older, newer = newer, older


@njit(cache=True, error_model="numpy", _nrt=False)
def _rhs(block, state_row, rate_row, track_row, suspension, lpr, lpr_work, u, n_lanes):
    """Derivatives of the states in rows ``state_row`` of ``block`` into rows ``rate_row`` with
    the track input in rows ``track_row, track_row + 1``; the force in row ``_FS``, the outside
    flags in row ``_OUT``. ``suspension``: the suspension record; ``lpr_work`` and
    ``u`` (element inputs) are work arrays, ``n_lanes`` the block's vehicles."""
    tau = lpr.tau
    for l in range(n_lanes):
        block[_U, l] = block[state_row, l] - block[state_row + 2, l]
        block[_U + 1, l] = block[state_row + 1, l] - block[state_row + 3, l]
    if tau > 0.0:
        for l in range(n_lanes):
            block[_U + 2, l] = block[_U, l] - block[state_row + 4, l]
            block[rate_row + 4, l] = (block[_U, l] - block[state_row + 4, l]) / tau
        if lpr.product:
            for l in range(n_lanes):
                block[_U + 3, l] = block[_U, l] * block[_U + 2, l]
    else:
        for l in range(n_lanes):
            block[rate_row + 4, l] = 0.0
    _element(block, lpr, lpr_work, u, n_lanes)
    k1, c1, m1, m2 = suspension.k1, suspension.c1, suspension.m1, suspension.m2
    bump = lpr.bump
    for l in range(n_lanes):
        fs = block[_FS, l]
        if bump:
            fs += bump_stop_force(block[_U, l], suspension)
        block[_FS, l] = fs
        fa = block[_FA, l]
        x0, x1 = block[state_row, l], block[state_row + 1, l]
        block[rate_row, l] = x1
        block[rate_row + 1, l] = (
            k1 * (block[track_row, l] - x0) + c1 * (block[track_row + 1, l] - x1) - fs - fa
        ) / m1
        block[rate_row + 2, l] = block[state_row + 3, l]
        block[rate_row + 3, l] = (fs + fa) / m2


@njit(cache=True, error_model="numpy", _nrt=False)
def _stage(block, src, scale, n_lanes):
    """Stage state rows ``_XT = _X + scale · (rows src)``."""
    for j in range(5):
        for l in range(n_lanes):
            block[_XT + j, l] = block[_X + j, l] + scale * block[src + j, l]


@njit(cache=True, error_model="numpy", _nrt=True)
def _block(state, z, zdot, k0, n_sub, dt, force_a, suspension_record, lpr, out, i0):
    """One block of vehicles ``i0 .. i0 + LANES − 1`` (clipped to ``n``), see
    :func:`advance_lanes`."""
    n, s = state.shape
    suspension = suspension_record[0]
    n_lanes = min(LANES, n - i0)
    block = np.zeros((_ROWS, n_lanes))
    lpr_work = lpr_scratch(lpr.exps, lpr.lo, lpr.up)
    u = np.empty(lpr.lo.shape[0])
    for l in range(n_lanes):
        i = i0 + l
        for j in range(s):
            block[_X + j, l] = state[i, j]
        block[_FA, l] = force_a[i]
        block[_ALIVE, l] = 1.0
    h6 = dt / 6.0
    dt8 = 0.125 * dt
    c3 = 1.5 / dt
    half = 0.5 * dt
    for m in range(n_sub):
        for l in range(n_lanes):
            i = i0 + l
            ka = k0[i] + m
            za, zda = z[i, ka], zdot[i, ka]
            zb, zdb = z[i, ka + 1], zdot[i, ka + 1]
            block[_ZA, l], block[_ZDA, l], block[_ZB, l], block[_ZDB, l] = za, zda, zb, zdb
            block[_ZM, l] = 0.5 * (za + zb) + dt8 * (zda - zdb)
            block[_ZDM, l] = c3 * (zb - za) - 0.25 * (zda + zdb)
        _rhs(block, _X, _K, _ZA, suspension, lpr, lpr_work, u, n_lanes)
        for l in range(n_lanes):
            block[_OSUM, l] = block[_OUT, l]
        _stage(block, _K, half, n_lanes)
        _rhs(block, _XT, _K + 5, _ZM, suspension, lpr, lpr_work, u, n_lanes)
        for l in range(n_lanes):
            block[_OSUM, l] += block[_OUT, l]
        _stage(block, _K + 5, half, n_lanes)
        _rhs(block, _XT, _K + 10, _ZM, suspension, lpr, lpr_work, u, n_lanes)
        for l in range(n_lanes):
            block[_OSUM, l] += block[_OUT, l]
        _stage(block, _K + 10, dt, n_lanes)
        _rhs(block, _XT, _K + 15, _ZB, suspension, lpr, lpr_work, u, n_lanes)
        alive = 0.0
        for l in range(n_lanes):
            block[_OSUM, l] += block[_OUT, l]
            block[_OOD, l] += block[_ALIVE, l] * block[_OSUM, l]
            ok = True
            for j in range(5):
                v = block[_X + j, l] + h6 * (
                    block[_K + j, l]
                    + 2.0 * block[_K + 5 + j, l]
                    + 2.0 * block[_K + 10 + j, l]
                    + block[_K + 15 + j, l]
                )
                block[_XT + j, l] = v
                ok = ok and abs(v) <= _BIG
            ok = ok and abs(block[_XT, l]) <= _DIV and abs(block[_XT + 2, l]) <= _DIV
            a = block[_ALIVE, l] if ok else 0.0
            block[_ALIVE, l] = a
            for j in range(5):
                block[_X + j, l] = block[_XT + j, l] if a > 0.0 else block[_X + j, l]
            dc = block[_X, l] - block[_X + 2, l]
            touch = 1.0 if (dc > suspension.free_c) | (dc < -suspension.free_r) else 0.0
            block[_CONTACT, l] += a * touch
            alive += a
        if alive == 0.0:
            break
    for l in range(n_lanes):
        i = i0 + l
        ke = k0[i] + n_sub
        block[_ZA, l], block[_ZDA, l] = z[i, ke], zdot[i, ke]
    _rhs(block, _X, _K, _ZA, suspension, lpr, lpr_work, u, n_lanes)
    for l in range(n_lanes):
        i = i0 + l
        for j in range(s):
            state[i, j] = block[_X + j, l]
        fs, a1, a2 = block[_FS, l], block[_K + 1, l], block[_K + 3, l]
        div = block[_ALIVE, l] == 0.0
        if not div and abs(fs) <= _BIG and abs(a1) <= _BIG and abs(a2) <= _BIG:
            out.acc[i, 0] = a1
            out.acc[i, 1] = a2
            out.force[i] = fs
        else:
            div = True
            out.acc[i, 0] = 0.0
            out.acc[i, 1] = 0.0
            out.force[i] = 0.0
        out.count[i, 0] = int(block[_CONTACT, l])
        out.count[i, 1] = int(block[_OOD, l])
        out.div[i] = div


@njit(cache=True, error_model="numpy", parallel=True, _nrt=True)
def advance_lanes_parallel(state, z, zdot, k0, n_sub, dt, force_a, suspension_record, lpr, out):
    """:func:`advance_lanes` on all numba threads (``prange`` over the blocks), with the same
    results."""
    _check(state, z, k0, n_sub, lpr)
    blocks = (state.shape[0] + LANES - 1) // LANES
    for b in prange(blocks):
        _block(state, z, zdot, k0, n_sub, dt, force_a, suspension_record, lpr, out, b * LANES)


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
def advance_lanes(state, z, zdot, k0, n_sub, dt, force_a, suspension_record, lpr, out):
    """Advance ``n`` vehicles by ``n_sub`` RK4 substeps of ``dt`` (s) with an additive
    surrogate element, in place, one block after another; arguments as for
    :func:`~railgym.vehicles.vertical.kernels.advance_surrogate` (``lpr.additive`` set)."""
    _check(state, z, k0, n_sub, lpr)
    for i0 in range(0, state.shape[0], LANES):
        _block(state, z, zdot, k0, n_sub, dt, force_a, suspension_record, lpr, out, i0)
