"""Compiled RK4 kernels that advance ``n`` vertical vehicles by one control step in place.

Each variant has a kernel ``advance_<variant>(state, z, zdot, k0, n_sub, dt, force_a, p, lpr,
out)``: ``p`` is :class:`~railgym.vehicles.vertical.params.SuspensionParams`, ``lpr`` an
:class:`~railgym.vehicles.vertical.elements.LprArrays` (placeholders for the physical
variants) and ``out`` a :class:`StepOutputs` of preallocated arrays.

:func:`advance_semi_active` runs any variant with a controllable damper (:class:`DamperLaw`)
at the actuator's place: its two states are the last two columns of ``state``
(:func:`state_size` with ``damper=True``), integrated in the RK4 stages with the vehicle, the
command held over the step. It takes the scalar path (no lane kernel).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from railgym.vehicles.semi_active import DAMPER_STATES, DamperParams
from railgym.vehicles.semi_active_element import DamperElement, DamperElementArrays
from railgym.vehicles.vertical.elements import (
    DAMPER_LAWS,
    DamperLaw,
    LprArrays,
    damped_rhs,
    in_contact,
    rhs,
)
from railgym.vehicles.vertical.lanes import (
    LANES_MIN,
    PARALLEL_MIN,
    advance_lanes,
    advance_lanes_parallel,
)
from surrogates.memory import FEATURE_FORMS, MEMORY_FORMS, element_form, shortest_time_constant
from surrogates.models.kriging import KrigingArrays
from surrogates.models.lpr import EXTRAPOLATION_MODES, additive_table, lpr_scratch
from surrogates.models.lpr_grid import lpr_grid

__all__ = [
    "DEFAULT_DT",
    "DIVERGENCE_DISPLACEMENT",
    "KERNELS",
    "RAISE_MODE",
    "STATE_SIZE",
    "ScalarWork",
    "StepOutputs",
    "VARIANTS",
    "advance_dynamic",
    "advance_linear",
    "advance_semi_active",
    "advance_static",
    "advance_surrogate",
    "check_variant",
    "damper_law",
    "initial_state",
    "scalar_work",
    "state_size",
    "step_outputs",
    "surrogate_arrays",
]

VARIANTS = ("linear", "static", "dynamic", "surrogate")
#: number of state variables per variant (surrogate: with a memory element; a static element
#: integrates the first 4, see :func:`state_size`)
STATE_SIZE = {"linear": 4, "static": 4, "dynamic": 7, "surrogate": 5}
#: recommended integration step per variant, s
DEFAULT_DT = {"linear": 1e-3, "static": 1e-3, "dynamic": 1e-3, "surrogate": 1e-3}
#: |x1| or |x2| above this (m) counts as divergence
DIVERGENCE_DISPLACEMENT = 10.0
#: LPR extrapolation mode of the ``"raise"`` policy
RAISE_MODE = EXTRAPOLATION_MODES["raise"]

_KIND = {"linear": 0, "static": 1, "dynamic": 2, "surrogate": 3}


class StepOutputs(NamedTuple):
    """Per-env results of one kernel call (preallocated, overwritten in place)."""

    acc: np.ndarray  #: float64 (n, 2): (ẍ1, ẍ2) at the end of the step, m/s² (0 if diverged)
    force: np.ndarray  #: float64 (n,): secondary-suspension force F_s at the end, N
    count: np.ndarray  #: int64 (n, 2): substeps in bump-stop contact, out-of-domain stages
    div: np.ndarray  #: bool (n,): diverged during this step (state frozen)


class ScalarWork(NamedTuple):
    """Work arrays of the scalar path (:func:`advance_kind` with fewer than ``LANES_MIN``
    vehicles, :func:`advance_semi_active`), made once by a caller that steps many times
    (:func:`scalar_work`) instead of on every call."""

    buf: np.ndarray  #: float64 (6, s): state, stage state and the four stage rates
    u: np.ndarray  #: float64 (d,): the element's inputs
    lw: np.ndarray  #: the element's :func:`~surrogates.models.lpr.lpr_scratch`


def scalar_work(s: int, lpr: LprArrays) -> ScalarWork:
    """:class:`ScalarWork` for states of ``s`` columns and the element ``lpr``."""
    return ScalarWork(
        np.empty((6, s)), np.empty(lpr.lo.shape[0]), lpr_scratch(lpr.exps, lpr.lo, lpr.up)
    )


def step_outputs(n: int) -> StepOutputs:
    """Zeroed :class:`StepOutputs` for ``n`` envs."""
    return StepOutputs(
        np.zeros((n, 2)), np.zeros(n), np.zeros((n, 2), np.int64), np.zeros(n, np.bool_)
    )


@njit(cache=True, error_model="numpy", _nrt=True)
def advance_kind(kind, state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out, work=None):
    """RK4 core shared by the four ``advance_<variant>`` kernels (see :func:`advance_linear`):
    the lane kernel (:mod:`~railgym.vehicles.vertical.lanes`) for an additive LPR surrogate
    element and at least ``LANES_MIN`` vehicles (on all threads from ``PARALLEL_MIN``), else
    :func:`_advance_scalar` (the same results; the only path of a Kriging element), in the
    :class:`ScalarWork` ``work`` when given. ``lpr``: ``None`` for the physical variants
    (``kind`` 0 to 2), whose right-hand sides then carry no element."""
    if lpr is None:
        _advance_scalar(kind, state, z, zdot, k0, n_sub, dt, force_a, p, None, out, work=work)
        return
    d = lpr.lo.shape[0]
    n = state.shape[0]
    lanes = kind == 3 and lpr.additive and (d == 2 or d == 3)
    if lanes and n >= PARALLEL_MIN:
        advance_lanes_parallel(state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out)
    elif lanes and n >= LANES_MIN:
        advance_lanes(state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out)
    else:
        _advance_scalar(kind, state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out, work=work)


@njit(cache=True, error_model="numpy", _nrt=False)
def _stage(kind, x, zc, zdc, fa, p, lpr, dmp, u, lw, dx):
    """One right-hand side of :func:`_advance_scalar`: :func:`rhs` with the actuator force
    ``fa`` (N) when ``dmp`` is ``None``, else :func:`damped_rhs` with ``fa`` the damper
    command; returns (F_s, outside, force between bogie and carbody in N)."""
    if dmp is None:
        fs, outside = rhs(kind, x, zc, zdc, fa, p, lpr, u, lw, dx)
        return fs, outside, fa
    return damped_rhs(kind, x, zc, zdc, fa, p, lpr, dmp, u, lw, dx)


@njit(cache=True, error_model="numpy", _nrt=True)
def _advance_scalar(
    kind, state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out, dmp=None, f_d=None, work=None
):
    """RK4 of one vehicle after another (see :func:`advance_linear`); with a damper ``dmp``
    as :func:`advance_semi_active` (``force_a`` the commands, damper forces into ``f_d``);
    ``lpr``: the surrogate element, ``None`` for the physical variants (their right-hand sides
    then carry no element); ``work``: a :class:`ScalarWork` of ``state``'s columns and the
    element (else allocated)."""
    q = p[0]
    n, s = state.shape
    memory = False
    if lpr is not None:
        memory = kind == 3 and lpr.tau > 0.0
    if memory and s < 5:
        raise ValueError("a memory surrogate element needs 5 states [x1, v1, x2, v2, s]")
    if dmp is not None:
        own = 7 if kind == 2 else (5 if memory else 4)
        if s != own + DAMPER_STATES:
            raise ValueError("a controllable damper needs its 2 states (u, w) after the variant's")
    if work is None:
        buf = np.empty((6, s))  # one allocation: state, stage state, the four stage rates
        if lpr is None:
            u = np.empty(0)
            lw = np.empty((0, 0))
        else:
            u = np.empty(lpr.lo.shape[0])
            lw = lpr_scratch(lpr.exps, lpr.lo, lpr.up)
    else:
        buf, u, lw = work
    x, xt, r1, r2, r3, r4 = buf[0], buf[1], buf[2], buf[3], buf[4], buf[5]
    h6 = dt / 6.0
    dt8 = 0.125 * dt  # cubic Hermite midpoint of the track samples (package docstring)
    c3 = 1.5 / dt
    for i in range(n):
        kk = k0[i]
        if kk < 0 or kk + n_sub > z.shape[1] - 1:
            raise ValueError("track index out of range: need 0 <= k0 and k0 + n_sub <= N")
        fa = force_a[i]
        for j in range(s):
            x[j] = state[i, j]
        contact = 0
        ood = 0
        div = False
        for m in range(n_sub):
            ka = kk + m
            za = z[i, ka]
            zda = zdot[i, ka]
            zb = z[i, ka + 1]
            zdb = zdot[i, ka + 1]
            zm = 0.5 * (za + zb) + dt8 * (zda - zdb)
            zdm = c3 * (zb - za) - 0.25 * (zda + zdb)
            _, o1, _ = _stage(kind, x, za, zda, fa, q, lpr, dmp, u, lw, r1)
            for j in range(s):
                xt[j] = x[j] + 0.5 * dt * r1[j]
            _, o2, _ = _stage(kind, xt, zm, zdm, fa, q, lpr, dmp, u, lw, r2)
            for j in range(s):
                xt[j] = x[j] + 0.5 * dt * r2[j]
            _, o3, _ = _stage(kind, xt, zm, zdm, fa, q, lpr, dmp, u, lw, r3)
            for j in range(s):
                xt[j] = x[j] + dt * r3[j]
            _, o4, _ = _stage(kind, xt, zb, zdb, fa, q, lpr, dmp, u, lw, r4)
            ood += o1 + o2 + o3 + o4
            ok = True
            for j in range(s):
                xt[j] = x[j] + h6 * (r1[j] + 2.0 * r2[j] + 2.0 * r3[j] + r4[j])
                if not math.isfinite(xt[j]):
                    ok = False
            if abs(xt[0]) > DIVERGENCE_DISPLACEMENT or abs(xt[2]) > DIVERGENCE_DISPLACEMENT:
                ok = False
            if not ok:
                div = True
                break
            for j in range(s):
                x[j] = xt[j]
            if in_contact(x[0] - x[2], q):
                contact += 1
        for j in range(s):
            state[i, j] = x[j]
        fd = 0.0
        if not div:
            ke = kk + n_sub
            fs, _, fd = _stage(kind, x, z[i, ke], zdot[i, ke], fa, q, lpr, dmp, u, lw, r1)
            if math.isfinite(fs) and math.isfinite(r1[1]) and math.isfinite(r1[3]):
                out.acc[i, 0] = r1[1]
                out.acc[i, 1] = r1[3]
                out.force[i] = fs
            else:
                div = True
        if div:
            out.acc[i, 0] = 0.0
            out.acc[i, 1] = 0.0
            out.force[i] = 0.0
            fd = 0.0
        if f_d is not None:
            f_d[i] = fd
        out.count[i, 0] = contact
        out.count[i, 1] = ood
        out.div[i] = div


@njit(cache=True, error_model="numpy")
def advance_linear(state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out):
    """Advance ``n`` envs by ``n_sub`` RK4 substeps of ``dt`` (s), linear secondary suspension.

    All four ``advance_<variant>`` kernels share this signature and work in place.

    Parameters
    ----------
    state : float64 (n, s)
        States, updated in place (``s = STATE_SIZE[variant]``).
    z, zdot : float64 (n, N+1)
        Track displacement (m) and velocity (m/s) per env on the grid ``t_k = k·dt``.
    k0 : int64 (n,)
        Index of each env's current track sample; needs ``k0 + n_sub <= N``.
    n_sub : int
        Substeps per control step.
    dt : float
        Integration step, s.
    force_a : float64 (n,)
        Actuator force (N, pushes the carbody up and the bogie down), held over the step.
    p : structured float64 (1,)
        ``VerticalVehicle.kernel_params().record()`` (:class:`SuspensionParams` fields).
    lpr : LprArrays
        Surrogate element (:func:`surrogate_arrays`); used by ``advance_surrogate`` only.
    out : StepOutputs
        Accelerations, force, counters and the diverged flags of this step.
    """
    advance_kind(0, state, z, zdot, k0, n_sub, dt, force_a, p, None, out)


@njit(cache=True, error_model="numpy")
def advance_static(state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out):
    """:func:`advance_linear` with the static nonlinear reference suspension."""
    advance_kind(1, state, z, zdot, k0, n_sub, dt, force_a, p, None, out)


@njit(cache=True, error_model="numpy")
def advance_dynamic(state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out):
    """:func:`advance_linear` with the dynamic reference (air spring + Maxwell damper)."""
    advance_kind(2, state, z, zdot, k0, n_sub, dt, force_a, p, None, out)


@njit(cache=True, error_model="numpy")
def advance_surrogate(state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out):
    """:func:`advance_linear` with the LPR surrogate as secondary suspension: ``F̂(δ, δ̇)``
    (static form) or ``F̂(δ, δ̇, δ − s)`` with the Maxwell state ``s = state[:, 4]``
    (``ṡ = (δ − s)/τ``), plus the bump-stop law where ``lpr.bump`` is set."""
    advance_kind(3, state, z, zdot, k0, n_sub, dt, force_a, p, lpr, out)


@njit(cache=True, error_model="numpy")
def advance_semi_active(
    kind, state, z, zdot, k0, n_sub, dt, command, p, lpr, damper, out, f_d, work=None
):
    """:func:`advance_linear` of variant number ``kind`` (:func:`check_variant`) with the
    controllable damper ``damper`` between bogie and carbody in place of the actuator.

    ``command`` (n,) in [0, 1] is held over the step; the damper's states ``(u, w)`` are
    ``state[:, -2:]`` (:func:`state_size` with ``damper=True``) and its force (N, on the carbody,
    bogie −F) at the end of the step goes into ``f_d`` (n,), 0 where the step diverged.
    ``work``: :class:`ScalarWork` (:func:`scalar_work`), else allocated on each call.
    ``lpr``: ``None`` for the physical variants (``kind`` 0 to 2), whose right-hand sides then
    carry no element.
    """
    _advance_scalar(kind, state, z, zdot, k0, n_sub, dt, command, p, lpr, out, damper, f_d, work)


KERNELS = {
    "linear": advance_linear,
    "static": advance_static,
    "dynamic": advance_dynamic,
    "surrogate": advance_surrogate,
}


def surrogate_arrays(
    surrogate: Any = None,
    dt: float | None = None,
    kriging: bool = False,
    relaxation: bool = False,
    grid: bool = False,
) -> LprArrays:
    """:class:`LprArrays` from a fitted LPR model (or its ``kernel_arrays()`` tuple), or with
    ``kriging=True`` also from a fitted :class:`~surrogates.models.kriging.Kriging`.

    The feature form, ``τ`` and the known physics come from the model's ``features_``
    (set by :func:`surrogates.io.load`; absent: the static form, as for a bare
    ``kernel_arrays()`` tuple). ``None`` gives placeholder arrays for the variants that ignore
    them. ``dt`` (s), when given, must not exceed ``2τ`` (RK4 stability of the Maxwell
    state). A model whose input count does not match its form (2 static, 3 maxwell, 4
    maxwell_product, which the whole vehicle's ``element_lpr`` refuses) is rejected, and so
    is a Kriging unless ``kriging`` is set (the vertical kernels of this package evaluate it;
    kernels that read the LPR fields only do not), and a memory element with a nonlinear
    relaxation law unless ``relaxation`` is set (the whole vehicle's kernels integrate it,
    the one-bogie kernels do not). ``grid``: an additive LPR is evaluated
    inside its box by Hermite tables (:func:`~surrogates.models.lpr_grid.lpr_grid`, within
    ``GRID_RTOL`` of its output range) instead of the Legendre recurrence.
    """
    if surrogate is None:
        return _placeholder_arrays()
    arrays = surrogate.kernel_arrays() if hasattr(surrogate, "kernel_arrays") else surrogate
    form = element_form(getattr(surrogate, "features_", None))
    if isinstance(arrays, KrigingArrays):
        if not kriging:
            raise ValueError(
                "surrogate is a Kriging, which runs in the one-bogie vertical model only "
                "(VerticalSuspension-v1, railgym.vehicles.vertical.simulate); use an LPR "
                "element here"
            )
        return _kriging_arrays(arrays, form, dt)
    exps, coef, lo, up, mode = _checked_lpr(arrays, form.form)
    d = len(lo)
    tau, bump = _form_physics(form, dt)
    table = additive_table(exps, coef)
    arrays = LprArrays(exps, coef, lo, up, int(mode), tau, bump, np.zeros((d, 1)), False)
    if form.form == "maxwell_product":
        arrays = arrays._replace(product=True)
    if table is not None:
        arrays = arrays._replace(table=table, additive=True)
        if grid:
            g = lpr_grid(table, lo, up)
            arrays = arrays._replace(gridded=True, grid=g.coef, grid_scale=g.scale, grid_top=g.top)
    if form.relaxation is not None:
        if not relaxation:
            raise ValueError(
                "surrogate has a nonlinear relaxation law (features.relaxation), which the "
                "whole vehicle's kernels integrate (VerticalVehicle-v1, "
                "railgym.vehicles.vehicle); the one-bogie model takes the linear Maxwell form"
            )
        arrays = arrays._replace(relax_z=form.relaxation[0], relax_r=form.relaxation[1])
    return arrays


def _placeholder_arrays() -> LprArrays:
    """One-term placeholder :class:`LprArrays` for the variants that read no element."""
    return LprArrays(
        np.zeros((1, 2), np.int64),
        np.zeros(1),
        np.zeros(2),
        np.ones(2),
        0,
        0.0,
        False,
        np.zeros((2, 1)),
        False,
    )


def _checked_lpr(
    arrays: Any, form: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """The contiguous ``(exps, coef, lo, up)`` and the extrapolation mode of an LPR's
    ``kernel_arrays()`` tuple, checked against the input count of feature form ``form``."""
    if not isinstance(arrays, tuple | list) or len(arrays) != 5:
        raise ValueError(
            "surrogate must be a fitted LPR or Kriging model or an LPR's kernel_arrays() tuple"
        )
    exps, coef, lo, up, mode = arrays
    exps = np.ascontiguousarray(exps, dtype=np.int64)
    coef = np.ascontiguousarray(coef, dtype=np.float64)
    lo = np.ascontiguousarray(lo, dtype=np.float64)
    up = np.ascontiguousarray(up, dtype=np.float64)
    d = len(FEATURE_FORMS[form])
    if exps.ndim != 2 or exps.shape[1] != d or lo.shape != (d,) or up.shape != (d,):
        raise ValueError(
            f"surrogate of feature form {form!r} must have {d} inputs "
            f"{FEATURE_FORMS[form]}; got exponents of shape {exps.shape}"
        )
    if coef.shape != (exps.shape[0],):
        raise ValueError(f"surrogate coef has shape {coef.shape}, expected ({exps.shape[0]},)")
    if int(mode) not in EXTRAPOLATION_MODES.values():
        raise ValueError(f"surrogate extrapolation mode must be one of {EXTRAPOLATION_MODES}")
    return exps, coef, lo, up, int(mode)


def _form_physics(form: Any, dt: float | None) -> tuple[float, bool]:
    """``(τ, bump)`` of an element's feature form: its Maxwell time constant (s; 0 for the
    static form), checked against ``dt`` (s), and whether the bump-stop law is added."""
    tau = form.tau if form.form in MEMORY_FORMS else 0.0
    if dt is not None and tau > 0.0 and dt > 2.0 * tau:
        raise ValueError(
            f"surrogate features.tau = {tau} s is below half the integration step dt = {dt} s"
        )
    if dt is not None and form.relaxation is not None:
        fastest = shortest_time_constant(form.relaxation)
        if dt > 2.0 * fastest:
            raise ValueError(
                f"surrogate features.relaxation has a time constant of {fastest} s, below "
                f"half the integration step dt = {dt} s"
            )
    return tau, "bump_stop" in form.known_physics


def _kriging_arrays(k: KrigingArrays, form: Any, dt: float | None) -> LprArrays:
    """:class:`LprArrays` of a Kriging element (LPR fields are one-term placeholders)."""
    d = len(FEATURE_FORMS[form.form])
    if k.lo.shape != (d,):
        raise ValueError(
            f"surrogate of feature form {form.form!r} must have {d} inputs "
            f"{FEATURE_FORMS[form.form]}; got a Kriging with {k.lo.shape[0]}"
        )
    if form.relaxation is not None:
        raise ValueError("a Kriging element takes the linear Maxwell form (no relaxation law)")
    tau, bump = _form_physics(form, dt)
    return LprArrays(
        np.zeros((1, d), np.int64),
        np.zeros(1),
        k.lo,
        k.up,
        int(k.mode),
        tau,
        bump,
        np.zeros((d, 1)),
        False,
        kriging=True,
        xs=k.xs,
        xs_ell=k.xs_ell,
        ell=k.ell,
        weights=k.weights,
        beta=k.beta,
        y_mean=k.y_mean,
        y_std=k.y_std,
        kernel=k.kernel,
        product=form.form == "maxwell_product",
    )


def damper_law(params: DamperParams, element: DamperElement | None = None) -> DamperLaw:
    """The :class:`DamperLaw` of the exact law with ``params``
    (:func:`~railgym.vehicles.semi_active.load_damper`), or with ``element``
    (:func:`~railgym.vehicles.semi_active_element.load_damper_element`) the element's law,
    its command filter the element's ``eta`` (1/s)."""
    if not isinstance(params, DamperParams):
        raise TypeError(f"damper must be a DamperParams, got {type(params).__name__}")
    exact = DamperParams(*(float(v) for v in params))
    if element is None:
        return DamperLaw(DAMPER_LAWS["exact"], exact)
    if not isinstance(element, DamperElement):
        raise TypeError(f"damper element must be a DamperElement, got {type(element).__name__}")
    a = element.arrays()
    arrays = DamperElementArrays(
        *(np.ascontiguousarray(x, dtype=np.float64) for x in a[:4]), int(a.degree), float(a.length)
    )
    return DamperLaw(DAMPER_LAWS["element"], exact._replace(eta=float(element.eta)), arrays)


def check_variant(variant: str) -> int:
    """Kernel number of ``variant``; ValueError naming ``variant`` otherwise."""
    if not isinstance(variant, str) or variant not in _KIND:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    return _KIND[variant]


def state_size(variant: str, lpr: LprArrays | None = None, damper: bool = False) -> int:
    """State variables of ``variant``; for ``"surrogate"`` 5 with a memory element ``lpr``
    (or none given), 4 with a static one; ``damper``: 2 more, the controllable damper's
    ``(u, w)`` last."""
    check_variant(variant)
    extra = DAMPER_STATES if damper else 0
    if variant == "surrogate" and lpr is not None and lpr.tau == 0.0:
        return 4 + extra
    return STATE_SIZE[variant] + extra


def initial_state(
    variant: str, n: int = 1, lpr: LprArrays | None = None, damper: bool = False
) -> np.ndarray:
    """Static equilibrium state(s), float64 (n, :func:`state_size`) of zeros (a damper at
    rest: ``u = w = 0``)."""
    return np.zeros((n, state_size(variant, lpr, damper)))
