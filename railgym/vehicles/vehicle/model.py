"""Whole railway vehicle in the vertical plane: carbody bounce, pitch and first bending on
two bogies (bounce and pitch), four wheelsets following the track.

Coordinates (SI, ``configs/vehicles/manchester_whole.yaml``): ``x`` along the vehicle,
forward positive, origin at the carbody centre; displacements upward from the loaded static
equilibrium; pitch positive nose up (the point at ``x`` moves by ``z + x·θ``). Bogie ``i``
(0 front, 1 rear) sits at ``x_i = ±a``, its wheelsets at ``x_i ± b``. The carbody's first
vertical bending mode is the free–free Euler–Bernoulli beam mode ``φ(x)`` of a uniform body
of length ``L``, normalised to ``φ(0) = 1``, with modal coordinate ``q`` (centre deflection),
modal mass ``m_q``, stiffness ``m_q·ω_b²`` and damping ``2ζ·m_q·ω_b``.

Equations (``F_i = F_s(δ_i, δ̇_i) + F_a,i`` the secondary plus actuator force at bogie ``i``,
pushing the carbody up and the bogie down; ``δ_i = z_b,i − (z_c + x_i·θ_c + φ(x_i)·q)``,
``> 0`` compression, as ``δ = x1 − x2`` of :mod:`railgym.vehicles.vertical`)::

    m_c·z̈_c = F_0 + F_1                 J_c·θ̈_c = a·(F_0 − F_1)
    m_q·(q̈ + 2ζω_b·q̇ + ω_b²·q) = φ(a)·(F_0 + F_1)
    m_b·z̈_b,i = P_i,lead + P_i,trail − F_i      J_b·θ̈_b,i = b·(P_i,lead − P_i,trail)

with the primary force of each wheelset ``P = k1/2·(w − z_b ∓ b·θ_b) + c1/2·(ẇ − ż_b ∓ b·θ̇_b)``
(``k1, c1`` of one bogie split over its two wheelsets) and ``w`` the track height under the
wheelset. The secondary suspension of each bogie is one of the variants of
:mod:`railgym.vehicles.vertical` (``"linear"``, ``"static"``, ``"dynamic"``, ``"surrogate"``),
whose compiled force laws are reused as they are (air spring with reservoir and Maxwell
damper, damper curve, bump stops, LPR element). With ``a = b = 0``, no bending coupling and
two bogies carrying half the carbody each, the model reduces to the one-bogie model.

State per vehicle: positions ``[z_c, θ_c, q, z_b0, θ_b0, z_b1, θ_b1]``, then their rates;
``"dynamic"`` appends ``[Δp_b, Δp_r, y]`` of bogie 0 and then of bogie 1; ``"surrogate"``
with a memory element (:mod:`surrogates.memory`, ``"maxwell"`` form) appends the Maxwell
states ``[s_0, s_1]`` of the two bogies (``ṡ_i = (δ_i − s_i)/τ``, or ``g(δ_i − s_i)`` with
the element's nonlinear relaxation law; element inputs ``(δ_i, δ̇_i, δ_i − s_i)``), the
same element at each bogie (:func:`state_size`). An
element with the ``"bump_stop"`` known physics adds the vehicle's bump-stop law to ``F̂``.
With controllable dampers (:mod:`railgym.vehicles.vehicle.damper`) in place of the actuators,
``F_a,i`` is the damper's force and its states ``[u_0, w_0, u_1, w_1]`` come last
(``state_size(..., damper=True)``); they take the per-vehicle kernel, not the lane kernel.

Track input: one profile per vehicle sampled on the time grid of the rear wheelset,
``Z[k] = z(v·k·dt)`` and ``Ż[k] = v·z'(v·k·dt)``; wheelset ``j`` sees it shifted by the
constant fractional index ``off_j = s_j/(v·dt)``, ``s_j`` its distance ahead of the rear
wheelset, evaluated by cubic Hermite interpolation of ``(Z, Ż)`` (exact at integer
offsets; at half a sample the RK4 midpoint rule of :mod:`railgym.vehicles.vertical`).
Integration: classic RK4 with fixed ``dt``; one compiled kernel steps a batch.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numba
import numpy as np
from numba import njit, prange

from railgym.vehicles.semi_active import DamperParams
from railgym.vehicles.semi_active_element import DamperElementArrays
from railgym.vehicles.vehicle.damper import DAMPER_COLUMNS, VehicleDampers, damper_stage
from railgym.vehicles.vehicle.lanes import LANES, LANES_MIN, hermite, lanes_block
from railgym.vehicles.vehicle.params import WholeVehicle, mode_shape
from railgym.vehicles.vertical.elements import (
    DamperLaw,
    bump_stop_force,
    damper_force,
    dynamic_element,
    in_contact,
)
from railgym.vehicles.vertical.kernels import DIVERGENCE_DISPLACEMENT, surrogate_arrays
from surrogates.memory import relaxation_rate
from surrogates.models.lpr import lpr_additive_inside, lpr_eval_into, lpr_is_outside, lpr_scratch
from surrogates.models.lpr_grid import lpr_grid_inside

VARIANTS = ("linear", "static", "dynamic", "surrogate")
_KIND = {"linear": 0, "static": 1, "dynamic": 2, "surrogate": 3}
N_MECH = 14
#: states per vehicle of each variant (surrogate: with a static element; a memory element adds
#: its two Maxwell states, see :func:`state_size`)
STATE_SIZE = {"linear": N_MECH, "static": N_MECH, "dynamic": N_MECH + 6, "surrogate": N_MECH}
#: default RK4 step, s: every mode lies below 12 Hz (ω·dt < 0.15) and the shortest track
#: wavelength (1 m) spans 9 samples at 200 km/h; measured accuracy in docs/envs/vehicle_vertical.md
DEFAULT_DT = 2e-3
#: batches of at least this many vehicles are advanced on all threads (:func:`advance`)
PARALLEL_MIN = 256
# Start numba's threading layer now: the cached kernels that call the parallel ones link
# against its symbols when they are loaded.
numba.get_num_threads()
#: chunks of vehicles of a parallel :func:`advance`, each with its own scratch; numba's
#: scheduler spreads them over the threads
PARALLEL_CHUNKS = 64


# ======================================================================= kernel data
class Params(NamedTuple):
    """Scalar kernel parameters (SI): inverse masses and inertias (multiplications keep
    divisions out of the right-hand side), modal data, geometry, primary and linear
    secondary suspension. The element array of the nonlinear secondary suspension
    (:meth:`VerticalVehicle.kernel_params`) travels beside it."""

    inv_m_c: float  # 1 / carbody mass, 1/kg
    inv_j_c: float  # 1 / carbody pitch inertia, 1/(kg·m²)
    inv_m_q: float  # 1 / bending modal mass, 1/kg
    k_q: float
    c_q: float
    inv_m_b: float  # 1 / bogie mass, 1/kg
    inv_j_b: float  # 1 / bogie pitch inertia, 1/(kg·m²)
    a: float
    b: float
    phi_a: float  # mode shape at the bogie centres (= front and rear floor points)
    phi_c: float  # mode shape at the centre floor point (1, or 0 when rigid)
    k1w: float  # primary stiffness per wheelset, N/m
    c1w: float  # primary damping per wheelset, N·s/m
    k2: float  # linear secondary stiffness per bogie, N/m
    c2: float  # linear secondary damping per bogie, N·s/m


class Lpr(NamedTuple):
    """Arrays of the LPR surrogate element
    (:func:`railgym.vehicles.vertical.kernels.surrogate_arrays`)."""

    exps: np.ndarray
    coef: np.ndarray
    lo: np.ndarray
    up: np.ndarray
    mode: int
    tau: float  # Maxwell time constant of a memory element, s (0: static element)
    bump: bool  # add the vehicle's bump-stop law to the element's value
    table: np.ndarray  # additive coefficient table (memory element's fast path)
    additive: bool
    relax_z: np.ndarray  # knots of a nonlinear relaxation law ṡ = g(δ − s), m (empty: linear)
    relax_r: np.ndarray  # its rates at the knots, m/s
    gridded: bool  # a memory element evaluated by its Hermite tables inside the box
    grid: np.ndarray  # (d, M, 4) interval coefficients of the tables, N
    grid_scale: np.ndarray  # (d,) intervals per input unit
    grid_top: np.ndarray  # (d,) last interval of each input


class VehicleArrays(NamedTuple):
    """Per-vehicle arrays the kernel works on (``n`` vehicles)."""

    state: np.ndarray  # (n, s), updated in place
    z: np.ndarray  # (n, M) track height on the rear wheelset's time grid, m
    zdot: np.ndarray  # (n, M) its time derivative, m/s
    k: np.ndarray  # (n,) int64 current sample index
    off: np.ndarray  # (n, 4) fractional sample offset of each wheelset
    force: np.ndarray  # (n, 2) actuator forces at the front / rear bogie, N
    start: np.ndarray  # (n,) int64 sample index of column 0 of z and zdot (a window of the track)


class Out(NamedTuple):
    """Kernel outputs at the end of a control step."""

    acc: np.ndarray  # (n, 5) floor points front/centre/rear, bogies front/rear, m/s²
    fs: np.ndarray  # (n, 2) secondary-suspension forces, N
    count: np.ndarray  # (n, 2) int64 substeps in bump-stop contact, out-of-domain evaluations
    div: np.ndarray  # (n,) bool diverged


def kernel_params(vehicle: WholeVehicle, flexible: bool = True) -> Params:
    """:class:`Params` of a vehicle; ``flexible=False`` decouples the bending mode (rigid)."""
    w = 2.0 * math.pi * vehicle.bending_frequency
    mq = float(vehicle.bending_modal_mass)
    phi_a = float(mode_shape(vehicle.bogie_semi_spacing, vehicle.carbody_length))
    s = vehicle.suspension
    return Params(
        inv_m_c=1.0 / vehicle.carbody_mass,
        inv_j_c=1.0 / vehicle.carbody_pitch_inertia,
        inv_m_q=1.0 / mq,
        k_q=mq * w * w,
        c_q=2.0 * vehicle.bending_damping * mq * w,
        inv_m_b=1.0 / vehicle.bogie_mass,
        inv_j_b=1.0 / vehicle.bogie_pitch_inertia,
        a=float(vehicle.bogie_semi_spacing),
        b=float(vehicle.semi_wheelbase),
        phi_a=phi_a if flexible else 0.0,
        phi_c=1.0 if flexible else 0.0,
        k1w=0.5 * s.k1,
        c1w=0.5 * s.c1,
        k2=float(s.k2),
        c2=float(s.c2),
    )


def lpr_arrays(surrogate: Any = None, dt: float | None = None, grid: bool = False) -> Lpr:
    """:class:`Lpr` of a fitted LPR model (or its ``kernel_arrays()``), static or memory
    form; placeholders for None. ``dt`` (s), when given, is checked against ``2τ``. ``grid``:
    an additive memory element is evaluated by its Hermite tables inside the box
    (:mod:`surrogates.models.lpr_grid`)."""
    return element_lpr(surrogate_arrays(surrogate, dt, relaxation=True, grid=grid))


def element_lpr(arrays: Any) -> Lpr:
    """The :class:`Lpr` fields of an element's
    :class:`~railgym.vehicles.vertical.elements.LprArrays`; an element of form
    ``"maxwell_product"`` (one-bogie kernels only) is a ``ValueError``."""
    if getattr(arrays, "product", False):
        raise ValueError(
            "surrogate has the feature form 'maxwell_product' (features.form), which the "
            "one-bogie kernels integrate (VerticalSuspension); the whole vehicle's kernels "
            "take the forms 'static' and 'maxwell'"
        )
    return Lpr(*(getattr(arrays, name) for name in Lpr._fields))


def state_size(variant: str, lpr: Lpr | None = None, damper: bool = False) -> int:
    """States per vehicle of ``variant``: :data:`STATE_SIZE`, plus the two Maxwell states of
    a memory element ``lpr`` for ``"surrogate"``, plus ``damper``: the dampers' four last."""
    check_variant(variant)
    extra = DAMPER_COLUMNS if damper else 0
    if variant == "surrogate" and lpr is not None and lpr.tau > 0.0:
        return N_MECH + 2 + extra
    return STATE_SIZE[variant] + extra


def check_variant(variant: str) -> int:
    """Kernel code of ``variant``; ValueError naming the choices."""
    if variant not in _KIND:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    return _KIND[variant]


def wheelset_offsets(vehicle: WholeVehicle, speed: float, dt: float) -> np.ndarray:
    """Sample offsets of the four wheelsets (front to rear) ahead of the rear one (4,)."""
    s = vehicle.wheelset_positions - vehicle.wheelset_positions[-1]
    return s / (speed * dt)


# =========================================================================== kernels
@njit(cache=True, error_model="numpy")
def _static_force(deflection: float, deflection_rate: float, suspension: Any) -> float:
    """Static reference secondary force (N): progressive spring, bump stops, damper curve."""
    return (
        suspension.k2 * deflection * (1.0 + suspension.progression * deflection * deflection)
        + bump_stop_force(deflection, suspension)
        + damper_force(deflection_rate, suspension)
    )


@njit(cache=True, error_model="numpy")
def _dynamic_force(first, deflection, deflection_rate, state, suspension, element_rates, rates):
    """Dynamic reference secondary force (N) at ``deflection`` (m) and ``deflection_rate``
    (m/s) of the bogie whose element states start at ``state[first]``; their rates go to
    ``rates[first : first + 3]`` (through the work array ``element_rates``)."""
    f_air, f_d = dynamic_element(
        deflection,
        deflection_rate,
        state[first],
        state[first + 1],
        state[first + 2],
        suspension,
        element_rates,
    )
    rates[first], rates[first + 1], rates[first + 2] = (
        element_rates[0],
        element_rates[1],
        element_rates[2],
    )
    return f_air + f_d + bump_stop_force(deflection, suspension)


@njit(cache=True, error_model="numpy", _nrt=False)
def _rhs(
    kind,
    state,
    wheels,
    actuator_force,
    params,
    suspension,
    lpr,
    u,
    element_rates,
    lpr_work,
    rates,
    secondary_force,
):
    """Derivative of ``state`` into ``rates`` for the wheel inputs ``wheels`` (4, 2) (height
    m, rate m/s) and the ``actuator_force`` (2,) N; writes the secondary forces into
    ``secondary_force`` (2,) N; returns the number of out-of-domain surrogate evaluations.
    ``kind``: the variant's code (:func:`check_variant`); ``params``: :class:`Params`;
    ``suspension``: one suspension record; ``u`` (d,) element inputs, ``element_rates`` (3,) and
    ``lpr_work`` are work arrays. A memory element's states are ``state[N_MECH + i]``; it is
    evaluated by its Hermite tables (``lpr.gridded``) or the additive fast path inside its box,
    like the one-bogie kernel."""
    outside = 0
    f0 = 0.0
    f1 = 0.0
    for i in range(2):
        xi = params.a if i == 0 else -params.a
        zb, vb = state[3 + 2 * i], state[10 + 2 * i]
        d = zb - (state[0] + xi * state[1] + params.phi_a * state[2])
        dd = vb - (state[7] + xi * state[8] + params.phi_a * state[9])
        if kind == 0:
            f = params.k2 * d + params.c2 * dd
        elif kind == 1:
            f = _static_force(d, dd, suspension)
        elif kind == 2:
            f = _dynamic_force(N_MECH + 3 * i, d, dd, state, suspension, element_rates, rates)
        else:
            u[0] = d
            u[1] = dd
            memory = lpr.tau > 0.0
            if memory:
                sm = state[N_MECH + i]
                u[2] = d - sm
                if lpr.relax_z.shape[0] > 0:
                    rates[N_MECH + i] = relaxation_rate(d - sm, lpr.relax_z, lpr.relax_r)
                else:
                    rates[N_MECH + i] = (d - sm) / lpr.tau
            out_i = lpr_is_outside(u, lpr.lo, lpr.up)
            if out_i:
                outside += 1
            if memory and lpr.gridded and not out_i:
                f = lpr_grid_inside(u, lpr.grid, lpr.lo, lpr.grid_scale, lpr.grid_top)
            elif memory and lpr.additive and not out_i:
                f = lpr_additive_inside(u, lpr.table, lpr.lo, lpr_work)
            else:
                f = lpr_eval_into(u, lpr.exps, lpr.coef, lpr.lo, lpr.up, lpr.mode, lpr_work)
            if lpr.bump:
                f += bump_stop_force(d, suspension)
        secondary_force[i] = f
        ftot = f + actuator_force[i]
        if i == 0:
            f0 = ftot
        else:
            f1 = ftot
        tb, wb = state[4 + 2 * i], state[11 + 2 * i]
        lead = params.k1w * (wheels[2 * i, 0] - zb - params.b * tb) + params.c1w * (
            wheels[2 * i, 1] - vb - params.b * wb
        )
        trail = params.k1w * (wheels[2 * i + 1, 0] - zb + params.b * tb) + params.c1w * (
            wheels[2 * i + 1, 1] - vb + params.b * wb
        )
        rates[3 + 2 * i] = vb
        rates[4 + 2 * i] = wb
        rates[10 + 2 * i] = (lead + trail - ftot) * params.inv_m_b
        rates[11 + 2 * i] = params.b * (lead - trail) * params.inv_j_b
    for j in range(3):
        rates[j] = state[7 + j]
    rates[7] = (f0 + f1) * params.inv_m_c
    rates[8] = params.a * (f0 - f1) * params.inv_j_c
    rates[9] = (
        params.phi_a * (f0 + f1) - params.k_q * state[2] - params.c_q * state[9]
    ) * params.inv_m_q
    return outside


@njit(cache=True, error_model="numpy")
def _inputs(z, zdot, offsets, pos, dt, wheels, start):
    """Wheel inputs ``wheels`` (4, 2) of one vehicle (track ``z, zdot`` from sample
    ``start`` on, wheelset ``offsets``) at fractional sample index ``pos``."""
    for j in range(4):
        wheels[j, 0], wheels[j, 1] = hermite(z, zdot, pos + offsets[j], dt, start)


@njit(cache=True, error_model="numpy")
def _outputs(rates, params, acc, i):
    """Floor-point (front, centre, rear) and bogie accelerations of vehicle ``i`` from its
    state ``rates``."""
    acc[i, 0] = rates[7] + params.a * rates[8] + params.phi_a * rates[9]
    acc[i, 1] = rates[7] + params.phi_c * rates[9]
    acc[i, 2] = rates[7] - params.a * rates[8] + params.phi_a * rates[9]
    acc[i, 3] = rates[10]
    acc[i, 4] = rates[12]


class Work(NamedTuple):
    """Work arrays of one kernel call (states, stage rates, wheel inputs, element scratch)."""

    x: np.ndarray
    xt: np.ndarray
    r1: np.ndarray
    r2: np.ndarray
    r3: np.ndarray
    r4: np.ndarray
    w: np.ndarray  # (4, 2) wheel inputs at the start/end of a substep
    wm: np.ndarray  # (4, 2) at its midpoint
    fs: np.ndarray  # (2,) secondary forces
    fa: np.ndarray  # (2,) forces of the controllable dampers, N
    u: np.ndarray  # (d,) surrogate input
    rt: np.ndarray  # (3,) dynamic-element rates
    lw: np.ndarray  # LPR scratch


@njit(cache=True, error_model="numpy", _nrt=True)
def advance(kind, arrays, n_sub, dt, params, suspension_record, lpr, out, damper=None):
    """Advance every vehicle of ``arrays`` (:class:`VehicleArrays`) by ``n_sub`` RK4 steps of
    ``dt`` (s) with the actuator forces held; results in ``out`` (:class:`Out`). ``params``:
    :class:`Params`, ``suspension_record``: ``SuspensionParams.record()``, ``lpr``:
    :class:`Lpr`. ``damper``: the controllable dampers
    (:class:`~railgym.vehicles.vehicle.damper.VehicleDampers`, their commands held) in place
    of the actuators; their forces at the end of the step go into ``arrays.force`` (0 where
    the step diverged).

    A vehicle whose state turns non-finite or beyond ``DIVERGENCE_DISPLACEMENT`` is frozen at
    its last finite state, its outputs are zero and ``out.div`` is set. Batches of
    ``PARALLEL_MIN`` vehicles or more run :func:`advance_parallel`, smaller ones
    :func:`advance_serial`; the surrogate variant with ``LANES_MIN`` vehicles or more runs the
    lane kernel (:mod:`railgym.vehicles.vehicle.lanes`, on all threads from
    ``PARALLEL_MIN``). All give bit-identical results. The dampers take the per-vehicle
    kernel (:func:`advance_serial`, or :func:`advance_parallel_dampers` from ``PARALLEL_MIN``).
    """
    n = arrays.state.shape[0]
    d = lpr.lo.shape[0]
    lanes = kind == 3 and (d == 2 or (d == 3 and lpr.additive)) and n >= LANES_MIN
    if damper is not None and n >= PARALLEL_MIN:
        advance_parallel_dampers(
            kind, arrays, n_sub, dt, params, suspension_record, lpr, out, damper
        )
    elif damper is not None:
        advance_serial(kind, arrays, n_sub, dt, params, suspension_record, lpr, out, damper)
    elif lanes:
        _check_track(kind, arrays, n_sub, lpr)
        if n >= PARALLEL_MIN:
            _lanes_parallel(arrays, n_sub, dt, params, suspension_record, lpr, out)
        else:
            for i0 in range(0, n, LANES):
                lanes_block(arrays, i0, n_sub, dt, params, suspension_record, lpr, out)
    elif n >= PARALLEL_MIN:
        advance_parallel(kind, arrays, n_sub, dt, params, suspension_record, lpr, out)
    else:
        advance_serial(kind, arrays, n_sub, dt, params, suspension_record, lpr, out, damper)


@njit(cache=True, error_model="numpy")
def _check_track(kind, arrays, n_sub, lpr, damper=None):
    """Raise unless every vehicle's track window of ``n_sub`` samples lies in its profile, for
    a memory element unless the states hold its two Maxwell states, and with ``damper``
    unless they end with the dampers' four and every vehicle has its commands."""
    if kind == 3 and lpr.tau > 0.0 and arrays.state.shape[1] < N_MECH + 2:
        raise ValueError("a memory surrogate element needs N_MECH + 2 states (Maxwell states)")
    if damper is not None:
        own = N_MECH + (6 if kind == 2 else (2 if kind == 3 and lpr.tau > 0.0 else 0))
        n = arrays.state.shape[0]
        if arrays.state.shape[1] != own + DAMPER_COLUMNS or damper.command.shape != (n, 2):
            raise ValueError("the dampers need their 4 last states and (n, 2) commands")
    last = arrays.z.shape[1] - 1
    for i in range(arrays.state.shape[0]):
        k = arrays.k[i] - arrays.start[i]
        if k < 0 or k + n_sub + arrays.off[i, 0] > last:
            raise ValueError("track index out of range: the profile is too short")


@njit(cache=True, error_model="numpy", _nrt=True)
def _work(n_states, lpr):
    """Scratch :class:`Work` of one vehicle with ``n_states`` states."""
    return Work(
        np.empty(n_states),
        np.empty(n_states),
        np.empty(n_states),
        np.empty(n_states),
        np.empty(n_states),
        np.empty(n_states),
        np.empty((4, 2)),
        np.empty((4, 2)),
        np.empty(2),
        np.empty(2),
        np.empty(lpr.lo.shape[0]),
        np.empty(3),
        lpr_scratch(lpr.exps, lpr.lo, lpr.up),
    )


@njit(cache=True, error_model="numpy", _nrt=True)
def _advance_range(
    kind, arrays, first, last, n_sub, dt, params, suspension_record, lpr, out, damper
):
    """:func:`_advance_one` for the vehicles ``first`` ≤ i < ``last``, with one scratch. The
    record is indexed here: one indexed in a ``prange`` body is passed to numba's gufunc by
    value, which its lowering refuses."""
    work = _work(arrays.state.shape[1], lpr)
    susp = suspension_record[0]
    for i in range(first, last):
        _advance_one(kind, arrays, i, n_sub, dt, params, susp, lpr, out, work, damper)


@njit(cache=True, error_model="numpy", _nrt=True)
def advance_serial(kind, arrays, n_sub, dt, params, suspension_record, lpr, out, damper=None):
    """:func:`advance` on one thread: :func:`_advance_one` for each vehicle in turn."""
    _check_track(kind, arrays, n_sub, lpr, damper)
    n = arrays.state.shape[0]
    _advance_range(kind, arrays, 0, n, n_sub, dt, params, suspension_record, lpr, out, damper)


@njit(cache=True, error_model="numpy", parallel=True, _nrt=True)
def advance_parallel(kind, arrays, n_sub, dt, params, suspension_record, lpr, out):
    """:func:`advance` on all numba threads: ``prange`` over chunks of vehicles, each chunk
    running :func:`_advance_range` as :func:`advance_serial` does."""
    _check_track(kind, arrays, n_sub, lpr)
    n = arrays.state.shape[0]
    chunks = min(n, PARALLEL_CHUNKS)
    for c in prange(chunks):
        first, last = c * n // chunks, (c + 1) * n // chunks
        _advance_range(
            kind, arrays, first, last, n_sub, dt, params, suspension_record, lpr, out, None
        )


@njit(cache=True, error_model="numpy", parallel=True, _nrt=True)
def advance_parallel_dampers(kind, arrays, n_sub, dt, params, suspension_record, lpr, out, damper):
    """:func:`advance_parallel` with the controllable dampers ``damper``
    (:class:`~railgym.vehicles.vehicle.damper.VehicleDampers`). Their law is taken apart here
    and built again inside the loop: numba's parallel lowering cannot capture a NamedTuple
    that nests NamedTuples."""
    _check_track(kind, arrays, n_sub, lpr, damper)
    law_kind, command = damper.law.law, damper.command
    q, e = damper.law.params[:], damper.law.element[:]
    n = arrays.state.shape[0]
    chunks = min(n, PARALLEL_CHUNKS)
    for c in prange(chunks):
        law = DamperLaw(law_kind, DamperParams(*q), DamperElementArrays(*e))
        first, last = c * n // chunks, (c + 1) * n // chunks
        own = VehicleDampers(law, command)
        _advance_range(
            kind, arrays, first, last, n_sub, dt, params, suspension_record, lpr, out, own
        )


@njit(cache=True, error_model="numpy", parallel=True, _nrt=True)
def _lanes_parallel(arrays, n_sub, dt, params, suspension_record, lpr, out):
    """The lane kernel's blocks on all numba threads (``prange``)."""
    blocks = (arrays.state.shape[0] + LANES - 1) // LANES
    for chunk in prange(blocks):
        lanes_block(arrays, chunk * LANES, n_sub, dt, params, suspension_record, lpr, out)


# Without the runtime's reference counting (the arrays are owned by the caller, nothing is
# allocated here): the counting of every array passed on to the element functions would
# cost more than the arithmetic of a substep.
@njit(cache=True, error_model="numpy", _nrt=False)
def _stage(kind, x, wheels, fa, params, suspension, lpr, work, rates, damper, i):
    """:func:`_rhs` of one RK4 stage of vehicle ``i`` into ``rates`` (returns its
    out-of-domain count); with ``damper`` (else ``None``) the dampers' forces into ``fa`` and
    their state rates first (:func:`~railgym.vehicles.vehicle.damper.damper_stage`)."""
    if damper is not None:
        damper_stage(x, params, damper.law, damper.command[i], fa, rates)
    return _rhs(
        kind, x, wheels, fa, params, suspension, lpr, work.u, work.rt, work.lw, rates, work.fs
    )


@njit(cache=True, error_model="numpy", _nrt=False)
def _advance_one(kind, arrays, i, n_sub, dt, params, suspension, lpr, out, work, damper=None):
    """RK4 steps of vehicle ``i`` (see :func:`advance`); ``suspension``: one suspension
    record; ``work``: :class:`Work`; ``damper``: :func:`advance`'s."""
    s = arrays.state.shape[1]
    x, xt, r1, r2, r3, r4 = work.x, work.xt, work.r1, work.r2, work.r3, work.r4
    w, wm, fs = work.w, work.wm, work.fs
    h6 = dt / 6.0
    kk = arrays.k[i]
    if damper is None:
        fa = arrays.force[i]
    else:
        fa = work.fa
    z, zd, off, start = arrays.z[i], arrays.zdot[i], arrays.off[i], arrays.start[i]
    for j in range(s):
        x[j] = arrays.state[i, j]
    contact = 0
    ood = 0
    div = False
    _inputs(z, zd, off, float(kk), dt, w, start)  # then carried from the end of each substep
    for m in range(n_sub):
        t0 = float(kk + m)
        ood += _stage(kind, x, w, fa, params, suspension, lpr, work, r1, damper, i)
        _inputs(z, zd, off, t0 + 0.5, dt, wm, start)
        for j in range(s):
            xt[j] = x[j] + 0.5 * dt * r1[j]
        ood += _stage(kind, xt, wm, fa, params, suspension, lpr, work, r2, damper, i)
        for j in range(s):
            xt[j] = x[j] + 0.5 * dt * r2[j]
        ood += _stage(kind, xt, wm, fa, params, suspension, lpr, work, r3, damper, i)
        _inputs(z, zd, off, t0 + 1.0, dt, w, start)
        for j in range(s):
            xt[j] = x[j] + dt * r3[j]
        ood += _stage(kind, xt, w, fa, params, suspension, lpr, work, r4, damper, i)
        ok = True
        for j in range(s):
            xt[j] = x[j] + h6 * (r1[j] + 2.0 * r2[j] + 2.0 * r3[j] + r4[j])
            if not math.isfinite(xt[j]):
                ok = False
        for j in range(7):
            if abs(xt[j]) > DIVERGENCE_DISPLACEMENT:
                ok = False
        if not ok:
            div = True
            break
        for j in range(s):
            x[j] = xt[j]
        for b in range(2):
            xb = params.a if b == 0 else -params.a
            if in_contact(x[3 + 2 * b] - x[0] - xb * x[1] - params.phi_a * x[2], suspension):
                contact += 1
    for j in range(s):
        arrays.state[i, j] = x[j]
    if not div:  # w holds the inputs at the end of the step
        _stage(kind, x, w, fa, params, suspension, lpr, work, r1, damper, i)
        _outputs(r1, params, out.acc, i)
        for j in range(5):
            if not math.isfinite(out.acc[i, j]):
                div = True
        out.fs[i, 0] = fs[0]
        out.fs[i, 1] = fs[1]
    if div:
        for j in range(5):
            out.acc[i, j] = 0.0
        out.fs[i, 0] = 0.0
        out.fs[i, 1] = 0.0
    if damper is not None:
        for b in range(2):
            arrays.force[i, b] = 0.0 if div else fa[b]
    out.count[i, 0] = contact
    out.count[i, 1] = ood
    out.div[i] = div


# ======================================================================== utilities
def new_arrays(
    n: int, variant: str, n_samples: int, lpr: Lpr | None = None, damper: bool = False
) -> tuple[VehicleArrays, Out]:
    """Zeroed :class:`VehicleArrays` and :class:`Out` for ``n`` vehicles and ``n_samples`` samples
    (states sized by :func:`state_size` for the element ``lpr`` and ``damper``)."""
    s = state_size(variant, lpr, damper)
    arrays = VehicleArrays(
        np.zeros((n, s)),
        np.zeros((n, n_samples)),
        np.zeros((n, n_samples)),
        np.zeros(n, np.int64),
        np.zeros((n, 4)),
        np.zeros((n, 2)),
        np.zeros(n, np.int64),
    )
    out = Out(np.zeros((n, 5)), np.zeros((n, 2)), np.zeros((n, 2), np.int64), np.zeros(n, np.bool_))
    return arrays, out


def linear_state_space(
    vehicle: WholeVehicle, flexible: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Linear model ``ẋ = A·x + B·F_a + E·w`` of the 14 mechanical states, linear secondary.

    ``w = [w_0..w_3, ẇ_0..ẇ_3]`` (m, m/s) are the wheelset inputs front to rear; the outputs
    ``y = C·x + D·F_a`` are the floor-point accelerations front/centre/rear (m/s²). Built by
    probing the compiled right-hand side with unit vectors (exact: it is linear).

    Returns
    -------
    A (14, 14), B (14, 2), E (14, 8), C (3, 14), D (3, 2)
    """
    p = kernel_params(vehicle, flexible)
    e = vehicle.suspension.kernel_params().record()
    lpr = lpr_arrays(None)

    def probe(x: np.ndarray, w: np.ndarray, fa: np.ndarray) -> np.ndarray:
        dx = np.zeros(N_MECH)
        _rhs(0, x, w, fa, p, e[0], lpr, np.empty(2), np.empty(3), np.empty((1, 1)), dx, np.empty(2))
        acc = np.zeros((1, 5))
        _outputs(dx, p, acc, 0)
        return np.concatenate([dx, acc[0, :3]])

    zx, zw, zf = np.zeros(N_MECH), np.zeros((4, 2)), np.zeros(2)
    cols_x = [probe(np.eye(N_MECH)[j], zw, zf) for j in range(N_MECH)]
    cols_f = [probe(zx, zw, np.eye(2)[j]) for j in range(2)]
    cols_w = []
    for j in range(8):
        w = np.zeros((4, 2))
        w[j % 4, j // 4] = 1.0
        cols_w.append(probe(zx, w, zf))
    mx, mf, mw = (np.array(c).T for c in (cols_x, cols_f, cols_w))
    return mx[:N_MECH], mf[:N_MECH], mw[:N_MECH], mx[N_MECH:], mf[N_MECH:]
