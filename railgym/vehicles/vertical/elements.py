"""Compiled secondary-suspension element laws and the vehicle's right-hand side (eq. 1–2).

Every function reads the vehicle from a :class:`~railgym.vehicles.vertical.params.SuspensionParams`
``p`` by field name; the surrogate element (an LPR or a Kriging) from an :class:`LprArrays` tuple;
a controllable damper in parallel with the secondary suspension from a :class:`DamperLaw`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from railgym.vehicles.semi_active import DamperParams
from railgym.vehicles.semi_active import damper_force as law_force
from railgym.vehicles.semi_active import damper_rates as law_rates
from railgym.vehicles.semi_active_element import (
    DamperElementArrays,
    element_force,
    element_rates,
)
from surrogates.models.kriging import kriging_eval_into
from surrogates.models.lpr import lpr_additive_inside, lpr_eval_into, lpr_is_outside
from surrogates.models.lpr_grid import lpr_grid_inside

__all__ = [
    "DAMPER_LAWS",
    "DamperLaw",
    "LprArrays",
    "bump_stop_force",
    "controlled_damper",
    "damped_rhs",
    "damper_force",
    "damper_velocity",
]


_NONE2 = np.zeros((0, 2))
_NONE1 = np.zeros(0)
_ONE = np.ones(2)
_NO_GRID = np.zeros((1, 1, 4))


class LprArrays(NamedTuple):
    """A fitted surrogate element as plain arrays with its feature form: ``d = 2`` inputs
    (δ, δ̇) for ``"static"``, ``d = 3`` (δ, δ̇, δ − s) for ``"maxwell"``, ``d = 4``
    (δ, δ̇, δ − s, δ·(δ − s)) for ``"maxwell_product"`` (``surrogates.memory``).

    An LPR fills the LPR fields (:meth:`LegendreRegression.kernel_arrays`). A Kriging sets
    ``kriging`` and the fields of :class:`~surrogates.models.kriging.KrigingArrays`
    (:meth:`Kriging.kernel_arrays`; same names, so that
    :func:`~surrogates.models.kriging.kriging_eval_into` reads this tuple), with one-term
    placeholders in ``exps``, ``coef``, ``table``. The Kriging fields are flat (no nested
    tuple) so that the tuple passes into the ``prange`` lane kernel; so are the Hermite
    tables of a gridded additive LPR (``gridded``, :mod:`surrogates.models.lpr_grid`), which
    replace the Legendre recurrence inside the box (outside: the polynomial as without them).
    """

    exps: np.ndarray  #: int64 (L, d) exponents
    coef: np.ndarray  #: float64 (L,) coefficients
    lo: np.ndarray  #: float64 (d,) lower corner of the training box
    up: np.ndarray  #: float64 (d,) upper corner
    mode: int  #: extrapolation mode (``surrogates.models.lpr.EXTRAPOLATION_MODES``)
    tau: float  #: Maxwell time constant τ of the state ``ṡ = (δ − s)/τ``, s (0: static form)
    bump: bool  #: known physics: add :func:`bump_stop_force` of the vehicle to ``F̂``
    table: np.ndarray  #: float64 (d, nmax + 1) additive coefficient table (``additive_table``)
    additive: bool  #: ``table`` holds the model (no coupled terms): fast path inside the box
    #: knots ``ζ`` (m) of the Maxwell state's nonlinear relaxation law ``ṡ = g(δ − s)``
    #: (:mod:`surrogates.memory`; empty: the linear law ``(δ − s)/τ``); whole vehicle only
    relax_z: np.ndarray = _NONE1
    relax_r: np.ndarray = _NONE1  #: its rates ``g`` at the knots, m/s
    #: form ``"maxwell_product"``: the fourth input is ``δ·(δ − s)``; one-bogie kernels only
    product: bool = False
    kriging: bool = False  #: the element is a Kriging (the fields below), not an LPR
    xs: np.ndarray = _NONE2  #: Kriging: float64 (n, d) training inputs in the unit box
    xs_ell: np.ndarray = _NONE2  #: Kriging: float64 (n, d) ``xs / ℓ``
    ell: np.ndarray = _ONE  #: Kriging: float64 (d,) length scales in box widths
    weights: np.ndarray = _NONE1  #: Kriging: float64 (n,) correlation weights
    beta: np.ndarray = _NONE1  #: Kriging: float64 (p,) trend coefficients
    y_mean: float = 0.0  #: Kriging: output mean, N
    y_std: float = 1.0  #: Kriging: output standard deviation, N
    kernel: int = 0  #: Kriging: 0 Gaussian, 1 Matérn-5/2
    #: an additive LPR evaluated inside the box by its Hermite tables (the fields below,
    #: :class:`~surrogates.models.lpr_grid.LprGrid`) instead of the Legendre recurrence
    gridded: bool = False
    grid: np.ndarray = _NO_GRID  #: float64 (d, M, 4) interval coefficients, N
    grid_scale: np.ndarray = _ONE  #: float64 (d,) intervals per input unit
    grid_top: np.ndarray = _NONE1  #: float64 (d,) last interval of each input


#: law kinds of a controllable damper (:attr:`DamperLaw.law`): ``"exact"`` is the Bouc–Wen law
#: of :mod:`railgym.vehicles.semi_active`, ``"element"`` its data-driven element
#: (:mod:`railgym.vehicles.semi_active_element`)
DAMPER_LAWS = {"exact": 0, "element": 1}

#: placeholder element arrays of an exact law (the kernels see one :class:`DamperLaw` type)
_NO_ELEMENT = DamperElementArrays(np.zeros((1, 1, 1)), np.zeros(3), np.ones(3), np.ones(3), 0, 1.0)


class DamperLaw(NamedTuple):
    """A controllable damper between bogie and carbody as the kernels read it: the law kind
    (:data:`DAMPER_LAWS`) and its parameters. Its two states (filtered command ``u``, then the
    exact law's hysteresis state ``w`` or the element's memory ``m``) are the last two columns
    of the vehicle's state."""

    law: int  #: :data:`DAMPER_LAWS` value
    params: DamperParams  #: the exact law's parameters (``eta``: the command filter of every law)
    element: DamperElementArrays = _NO_ELEMENT  #: the element law's arrays


@njit(cache=True, error_model="numpy")
def _ramp(x: float, eps: float) -> float:
    """Hyperbolic smooth ramp ``(x + √(x² + ε²))/2``."""
    return 0.5 * (x + math.sqrt(x * x + eps * eps))


@njit(cache=True, error_model="numpy")
def _damper_branch(v: float, c: float, vk: float, r: float, eps: float) -> float:
    """Force of one damper branch for ``v ≥ 0``: slope ``c`` then ``r·c`` past the knee."""
    return c * (v - (1.0 - r) * (_ramp(v - vk, eps) - _ramp(-vk, eps)))


@njit(cache=True, error_model="numpy")
def _damper_branch_inv(f: float, c: float, vk: float, r: float, eps: float) -> float:
    """Closed-form inverse of :func:`_damper_branch` for ``f ≥ 0`` (exactly 0 at ``f = 0``).

    With ``v = vk + w`` the branch reads ``α·w − β·√(w² + ε²) = Φ``, ``α, β = (1 ± r)/2``,
    whose root is ``w = (α·Φ + β·√(Φ² + r·ε²))/r``.
    """
    alpha = 0.5 * (1.0 + r)
    beta = 0.5 * (1.0 - r)
    re2 = r * eps * eps
    phi0 = -vk - (1.0 - r) * _ramp(-vk, eps)
    phi = f / c + phi0
    w = alpha * phi + beta * math.sqrt(phi * phi + re2)
    w0 = alpha * phi0 + beta * math.sqrt(phi0 * phi0 + re2)
    return (w - w0) / r


@njit(cache=True, error_model="numpy")
def damper_force(v, p):
    """Damper force (N) at relative velocity ``v`` (m/s, > 0 compression)."""
    if v >= 0.0:
        return _damper_branch(v, p.c_c, p.vk_c, p.blowoff, p.knee)
    return -_damper_branch(-v, p.c_r, p.vk_r, p.blowoff, p.knee)


@njit(cache=True, error_model="numpy")
def damper_velocity(f, p):
    """Inverse of :func:`damper_force`: velocity (m/s) that produces force ``f`` (N)."""
    if f >= 0.0:
        return _damper_branch_inv(f, p.c_c, p.vk_c, p.blowoff, p.knee)
    return -_damper_branch_inv(-f, p.c_r, p.vk_r, p.blowoff, p.knee)


@njit(cache=True, error_model="numpy")
def _contact_ramp(e: float, s: float) -> float:
    """C1 ramp: 0 for e ≤ 0, e²/(2s) up to s, then e − s/2 (branch-free: a select)."""
    ep = max(e, 0.0)
    quad = 0.5 * ep * ep / s
    lin = ep - 0.5 * s
    return quad if ep < s else lin


@njit(cache=True, error_model="numpy")
def bump_stop_force(d, p):
    """Bump-stop (δ > free travel) and rebound-stop (δ < −free travel) force, N.

    Branch-free (the ramps of the free side are exactly 0), so that the lane kernels
    vectorise it.
    """
    ec = max(d - p.free_c, 0.0)
    er = max(-d - p.free_r, 0.0)
    fc = p.k_bs * _contact_ramp(ec, p.bs_smooth) + p.k_bs3 * ec * ec * ec
    fr = p.k_bs * _contact_ramp(er, p.bs_smooth) + p.k_bs3 * er * er * er
    return 0.0 + fc - fr


@njit(cache=True, error_model="numpy")
def in_contact(d, p):
    """True where the deflection ``d`` (m) is beyond either free travel."""
    return d > p.free_c or d < -p.free_r


@njit(cache=True, error_model="numpy")
def dynamic_element(d, dd, dpb, dpr, y, p, rates):
    """Air spring and Maxwell damper of the dynamic reference.

    Writes ``rates = (d Δp_b/dt, d Δp_r/dt, dy/dt)``; returns (air-spring force, damper force).
    """
    n = p.n_poly
    p0 = p.p0
    a0 = p.area
    da = p.d_area
    ae = a0 + da * d
    vb = p.v_bag - a0 * d - 0.5 * da * d * d
    vr = p.v_res
    pb = p0 + dpb
    pr = p0 + dpr
    rho_b = p.rho0 * (pb / p0) ** (1.0 / n)
    rho_r = p.rho0 * (pr / p0) ** (1.0 / n)
    dp = dpb - dpr
    dl = p.dp_lam
    q = p.cd_area * math.sqrt(rho_b + rho_r) * dp / math.sqrt(math.sqrt(dp * dp + dl * dl))
    rates[0] = n * pb * (ae * dd - q / rho_b) / vb
    rates[1] = n * pr * q / (rho_r * vr)
    f_d = p.k_series * (d - y)
    rates[2] = damper_velocity(f_d, p)
    f_air = p.n_springs * ((p0 - p.p_atm) * da * d + dpb * ae)
    return f_air, f_d


@njit(cache=True, error_model="numpy", _nrt=False)
def rhs(kind, x, zc, zdc, fa, p, lpr, u, lw, dx):
    """State derivative ``dx`` of variant ``kind``; returns (F_s, 1 if any surrogate input is
    outside its box). ``zc, zdc``: track input (m, m/s); ``fa``: actuator force, N.

    The surrogate's state ``x[4]`` is the Maxwell state ``s`` (``ṡ = (δ − s)/τ``) of a memory
    element (with ``lpr.product`` the fourth input ``δ·(δ − s)``); a static element
    integrates 4 states (a fifth one is held still). The element is
    an LPR or a Kriging (``lpr.kriging``); ``None`` for the physical variants, whose
    calls then carry no element (the surrogate variant refuses it). ``u`` (d,) and ``lw``
    (:func:`~surrogates.models.lpr.lpr_scratch`) are work arrays.
    """
    d = x[0] - x[2]
    dd = x[1] - x[3]
    outside = 0
    if kind == 0:
        fs = p.k2 * d + p.c2 * dd
    elif kind == 1:
        fs = p.k2 * d * (1.0 + p.progression * d * d) + bump_stop_force(d, p) + damper_force(dd, p)
    elif kind == 2:
        f_air, f_d = dynamic_element(d, dd, x[4], x[5], x[6], p, dx[4:])
        fs = f_air + f_d + bump_stop_force(d, p)
    elif lpr is None:
        raise ValueError("the surrogate variant needs its element lpr")
    else:
        u[0] = d
        u[1] = dd
        if lpr.tau > 0.0:
            u[2] = d - x[4]
            dx[4] = (d - x[4]) / lpr.tau
            if lpr.product:
                u[3] = d * u[2]
        elif dx.shape[0] > 4:
            dx[4] = 0.0
        if lpr_is_outside(u, lpr.lo, lpr.up):
            outside = 1
        if lpr.kriging:
            fs = kriging_eval_into(u, lpr, lw)
        elif lpr.gridded and outside == 0:
            fs = lpr_grid_inside(u, lpr.grid, lpr.lo, lpr.grid_scale, lpr.grid_top)
        elif lpr.additive and outside == 0:
            fs = lpr_additive_inside(u, lpr.table, lpr.lo, lw)
        else:
            fs = lpr_eval_into(u, lpr.exps, lpr.coef, lpr.lo, lpr.up, lpr.mode, lw)
        if lpr.bump:
            fs += bump_stop_force(d, p)
    dx[0] = x[1]
    dx[1] = (p.k1 * (zc - x[0]) + p.c1 * (zdc - x[1]) - fs - fa) / p.m1
    dx[2] = x[3]
    dx[3] = (fs + fa) / p.m2
    return fs, outside


@njit(cache=True, error_model="numpy", _nrt=False)
def controlled_damper(v, u, w, command, dmp):
    """Force (N, on the carbody in the direction of ``v``) and state rates ``(u̇, ẇ)`` (1/s) of
    the controllable damper ``dmp`` at extension rate ``v = ẋ1 − ẋ2`` (m/s), states ``u, w``
    and ``command`` in [0, 1]: the exact law (``dmp.law = DAMPER_LAWS["exact"]``, ``w`` its
    hysteresis state) or the element (``DAMPER_LAWS["element"]``, ``w`` its memory ``m`` in m,
    ``ṁ`` in m/s)."""
    if dmp.law == 1:
        f = element_force(v, u, w, dmp.element)
        return f, dmp.params.eta * (command - u), element_rates(v, w, dmp.element)
    f = law_force(v, u, w, dmp.params)
    du, dw = law_rates(v, u, w, command, dmp.params)
    return f, du, dw


@njit(cache=True, error_model="numpy", _nrt=False)
def damped_rhs(kind, x, zc, zdc, command, p, lpr, dmp, u, lw, dx):
    """:func:`rhs` with the controllable damper ``dmp`` in place of the actuator: its force
    enters as ``fa`` (carbody +F, bogie −F), its states are ``x[-2:]`` (``(u, w)``, rates into
    ``dx[-2:]``), ``command`` in [0, 1] is held by the caller; returns (F_s, outside, F_d)."""
    s = x.shape[0]
    f_d, du, dw = controlled_damper(x[1] - x[3], x[s - 2], x[s - 1], command, dmp)
    fs, outside = rhs(kind, x, zc, zdc, f_d, p, lpr, u, lw, dx)
    dx[s - 2] = du
    dx[s - 1] = dw
    return fs, outside, f_d
