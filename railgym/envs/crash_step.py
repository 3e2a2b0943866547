"""Compiled bookkeeping of ``railgym/TrainCrash-v1`` (:mod:`railgym.envs.crash`): absorber
scales, the model's batch step, episode statistics, observation, reward and the flat ``info``
row, one compiled call per control step for all trains."""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from railgym.vehicles.crash import (
    CrashOutputs,
    ElementTypes,
    LprModels,
    ReferenceParams,
    ReferenceState,
    SurrogateParams,
    SurrogateState,
    ZoneTypes,
    reference_batch_step,
    surrogate_batch_step,
    surrogate_batch_step_parallel,
)
from railgym.vehicles.crash.criteria import zero_crossing

__all__ = [
    "COLUMNS",
    "DECEL_REF_G",
    "DIVERGENCE_PENALTY",
    "ENV_FIELDS",
    "F_STOP",
    "INFO_FIELDS",
    "INTRUSION_REF",
    "PEAK_REF_G",
    "STATE_LIMIT",
    "TIME_REF",
    "V_STOP",
    "REWARD_TERMS",
    "Criteria",
    "EnvConsts",
    "Episode",
    "InfoColumns",
    "crush_limits",
    "info_layout",
    "plain",
]

#: deceleration of the reward's reference, in g: one control step of 1 ms at 5 g costs 1
DECEL_REF_G = 5.0
#: time of the reward's reference, s (the deceleration term is time-integrated)
TIME_REF = 1e-3
#: crush beyond the absorber stroke that costs 1 (reward term ``intrusion``), m
INTRUSION_REF = 1e-3
#: growth of the worst car's peak deceleration that costs 1 (reward term ``peak``), g
PEAK_REF_G = 1.0
DIVERGENCE_PENALTY = 100.0
#: the crash is over when no zone carries more than F_STOP (N) and none closes faster than
#: V_STOP (m/s): every car at rest or rebounding away (as ``simulate_reference``'s stop)
F_STOP = 1e3
V_STOP = 0.01
#: a train whose |x| (m) or |v| (m/s) exceeds this, or turns non-finite, has diverged
STATE_LIMIT = 1e3

#: the ``info`` row, in column order: key and size (``"1"``, ``"bool"``, ``"cars"``,
#: ``"zones"``; ``"cars?"``, ``"zones?"`` for bool arrays)
INFO_FIELDS = (
    ("time", "1"),
    ("initial_speed", "1"),
    ("payload_kg", "cars"),
    ("decel_g", "cars"),
    ("crush_m", "zones"),
    ("force_N", "zones"),
    ("absorber_scale", "zones"),
    ("peak_decel_g", "cars"),
    ("mean_decel_g", "cars"),
    ("moving_average_peak_g", "cars"),
    ("pulse_mean_decel_g", "cars"),
    ("absorbed_energy_J", "zones"),
    ("max_crush_m", "zones"),
    ("intrusion_m", "zones"),
    ("stroke_used", "zones"),
    ("stroke_exceeded", "bool"),
    ("mean_decel_passed", "cars?"),
    ("peak_decel_passed", "cars?"),
    ("moving_average_passed", "cars?"),
    ("intrusion_passed", "zones?"),
    ("criteria_passed", "bool"),
    ("friction_work_J", "1"),
    ("energy_error", "1"),
    ("diverged", "bool"),
)
#: first column of each ``info`` key in the flat info row (:func:`info_layout`)
InfoColumns = NamedTuple("InfoColumns", [(key, int) for key, _ in INFO_FIELDS])
#: the reward terms (``info["reward_terms"]``), summing to the reward
REWARD_TERMS = ("decel", "intrusion", "peak", "divergence")


class Criteria(NamedTuple):
    """Crash criteria of the env's bookkeeping (:mod:`railgym.vehicles.crash.criteria`).

    Attributes
    ----------
    onset_g : deceleration that starts a car's pulse, g. window_steps : control steps of the
        moving-average window. window : its length, s.
    mean_decel_g, peak_decel_g, moving_average_g : limits per car, g (inf = not checked).
    intrusion_m : limit per zone, m.
    """

    onset_g: float
    window_steps: int
    window: float
    mean_decel_g: float
    peak_decel_g: float
    moving_average_g: float
    intrusion_m: float


def crush_limits(lengths: np.ndarray) -> np.ndarray:
    """Largest crush (m) of each controlled zone the crash model holds, from the car lengths
    (m), front to back: the lead car's length for the wall zone, half of each neighbour's
    length for an interface. A zone crushed further has passed through a carbody, which no
    force law of the model describes."""
    lengths = np.asarray(lengths, dtype=float)
    return np.concatenate((lengths[:1], 0.5 * (lengths[:-1] + lengths[1:])))


class EnvConsts(NamedTuple):
    """Constants of the env's compiled bookkeeping.

    Attributes
    ----------
    zones : (zones,) model zone of each controlled zone, front to back.
    stroke : (zones,) absorber stroke, m. crush_limit : (zones,) largest crush the model
        holds, m (:func:`crush_limits`); beyond it the train counts as diverged.
    inv_scale : (obs,) 1 / observation scale.
    w_decel, w_intrusion, w_peak : reward weights. gravity : m/s². control_dt : s.
    absorber_range : action ±1 sets the scale 1 ± range. max_change : largest scale change
        per step. unloading_k, tension_k : (model zones,) unloading and coupler tension
        stiffness of each surrogate element, N/m, for its energy check (empty for the
        reference: ``energy_error`` is then the energy-balance residual).
    criteria : :class:`Criteria`. info : :class:`InfoColumns`.
    """

    zones: np.ndarray
    stroke: np.ndarray
    crush_limit: np.ndarray
    inv_scale: np.ndarray
    w_decel: float
    w_intrusion: float
    w_peak: float
    gravity: float
    control_dt: float
    absorber_range: float
    max_change: float
    unloading_k: np.ndarray
    tension_k: np.ndarray
    criteria: Criteria
    info: InfoColumns


class Episode(NamedTuple):
    """Per-train arrays of :class:`CrashBatch`: absorber scales and episode statistics (the
    float ones in this order in the buffer, :data:`ENV_FIELDS`), then the flags."""

    scale: np.ndarray  # (n, model zones) absorber force scale
    speed: np.ndarray  # (n,) initial speed, m/s
    energy0: np.ndarray  # (n,) stored energy at first contact, J
    payload: np.ndarray  # (n, cars) payload of each car, kg
    peak: np.ndarray  # (n, cars) peak deceleration, g
    decel_sum: np.ndarray  # (n, cars) sum of the step decelerations, g
    max_crush: np.ndarray  # (n, zones) largest crush, m
    intrusion: np.ndarray  # (n, zones) crush beyond the absorber stroke, m
    w_peak: np.ndarray  # (n, model zones) largest work done on each zone so far, J
    f_peak: np.ndarray  # (n, model zones) zone force when that work was reached, N
    pulse_t0: np.ndarray  # (n, cars) pulse start (s), −1 before the onset
    pulse_v0: np.ndarray  # (n, cars) velocity at the pulse start, m/s
    pulse_t1: np.ndarray  # (n, cars) pulse end so far, s
    pulse_v1: np.ndarray  # (n, cars) velocity at the pulse end so far, m/s
    stopped: np.ndarray  # (n, cars) 1 once the car's velocity reached zero in its pulse
    prev_v: np.ndarray  # (n, cars) velocity at the previous step end, m/s
    prev_a: np.ndarray  # (n, cars) acceleration at the previous step end, m/s²
    ring: np.ndarray  # (n, (window_steps + 1) · cars) last velocities, slot-major, m/s
    ma_peak: np.ndarray  # (n, cars) moving-average peak deceleration, g
    terms: np.ndarray  # (n, reward terms) last reward terms
    obs: np.ndarray  # (n, obs) observation
    reward: np.ndarray  # (n,) last reward
    info: np.ndarray  # (n, info columns) flat info row
    div: np.ndarray  # (n,) bool: diverged
    over: np.ndarray  # (n,) bool: crash over
    steps: np.ndarray  # (n,) int64: control steps since the reset


#: the float arrays of :class:`Episode` kept in the :class:`CrashBatch` buffer
ENV_FIELDS = Episode._fields[:-3]
#: the 1-D ones among them (the others are 2-D)
COLUMNS = ("speed", "energy0", "reward")
#: buffer layout: the 9 :class:`CrashOutputs` arrays, :data:`ENV_FIELDS`, the model state
_ENV = len(CrashOutputs._fields)
_STATE = _ENV + len(ENV_FIELDS)


def info_layout(n_cars: int, n_zones: int) -> dict[str, tuple[slice, bool]]:
    """Columns of each ``info`` key in the flat info row (key → (columns, is_scalar)), from
    :data:`INFO_FIELDS`."""
    sizes = {"1": 1, "bool": 1, "cars": n_cars, "zones": n_zones, "cars?": n_cars}
    sizes["zones?"] = n_zones
    out, j = {}, 0
    for key, size in INFO_FIELDS:
        out[key] = (slice(j, j + sizes[size]), size in ("1", "bool"))
        j += sizes[size]
    return out


def plain(value: Any) -> Any:
    """``value`` with every NamedTuple turned into a plain tuple, recursively: compiled code
    types a plain tuple argument much faster than a NamedTuple (rebuilt inside, e.g.
    :func:`_named_consts`)."""
    if isinstance(value, tuple):
        return tuple(plain(v) for v in value)
    return value


@njit(cache=True, inline="always")
def _named_consts(c):
    return EnvConsts(*c[:-2], Criteria(*c[-2]), InfoColumns(*c[-1]))


@njit(cache=True, inline="always")
def _named_reference(p):
    return ReferenceParams(*p[:-1], ZoneTypes(*p[-1]))


@njit(cache=True, inline="always")
def _named_surrogate(p):
    return SurrogateParams(*p[:-2], ElementTypes(*p[-2]), LprModels(*p[-1]))


@njit(cache=True)
def _set_scale(actions, scale, active, c):
    """Move each active absorber's force scale towards ``1 + range · action`` by at most
    ``c.max_change``, the action clipped to [−1, 1]. Returns ``False``, changing nothing, if
    any action (of any train) is not finite."""
    for i in range(actions.shape[0]):
        for z in range(actions.shape[1]):
            if not math.isfinite(actions[i, z]):
                return False
    for i in range(actions.shape[0]):
        if not active[i]:
            continue
        for z in range(c.zones.shape[0]):
            k = c.zones[z]
            a = min(max(actions[i, z], -1.0), 1.0)
            step = 1.0 + c.absorber_range * a - scale[i, k]
            scale[i, k] += min(max(step, -c.max_change), c.max_change)
    return True


@njit(cache=True, inline="always")
def _pulse_sample(ep, i, k, t, v, a, c):
    """Car ``k`` of train ``i`` at time ``t`` (s), velocity ``v``, acceleration ``a``: update
    its crash pulse as :func:`railgym.vehicles.crash.criteria.crash_pulse` defines it, one
    sample at a time; returns the pulse mean deceleration so far, g."""
    g = c.gravity
    if ep.stopped[i, k] == 0.0:
        braking = -a >= c.criteria.onset_g * g
        if ep.pulse_t0[i, k] < 0.0:
            if braking:
                ep.pulse_t0[i, k], ep.pulse_v0[i, k] = t, v
                ep.pulse_t1[i, k], ep.pulse_v1[i, k] = t, v
                if v <= 0.0:
                    ep.stopped[i, k] = 1.0
        elif v <= 0.0:
            t_prev = t - c.control_dt
            ep.pulse_t1[i, k] = zero_crossing(t_prev, t, ep.prev_v[i, k], v, ep.prev_a[i, k])
            ep.pulse_v1[i, k] = 0.0
            ep.stopped[i, k] = 1.0
        elif braking:
            ep.pulse_t1[i, k], ep.pulse_v1[i, k] = t, v
    ep.prev_v[i, k], ep.prev_a[i, k] = v, a
    span = ep.pulse_t1[i, k] - ep.pulse_t0[i, k]
    if ep.pulse_t0[i, k] < 0.0 or span <= 0.0:
        return 0.0
    return (ep.pulse_v0[i, k] - ep.pulse_v1[i, k]) / (g * span)


@njit(cache=True, inline="always")
def _moving_average_sample(ep, i, k, n_cars, steps, v, c):
    """Store car ``k``'s velocity ``v`` of control step ``steps`` in the ring and update its
    moving-average peak deceleration (g) over ``window_steps`` control steps."""
    w = c.criteria.window_steps
    slots = w + 1
    ep.ring[i, (steps % slots) * n_cars + k] = v
    if steps >= w:
        old = ep.ring[i, ((steps - w) % slots) * n_cars + k]
        mean = (old - v) / (c.gravity * c.criteria.window)
        ep.ma_peak[i, k] = mean if steps == w else max(ep.ma_peak[i, k], mean)


@njit(cache=True, inline="always")
def _returned_excess(out, ep, i, c, init):
    """Largest work (J) any zone of train ``i`` has returned since its work peak beyond the
    elastic energy ``f² / (2 k)`` it could store at that peak (``k`` the unloading stiffness,
    the coupler's in tension); 0 if none (see ``docs/envs/crash.md``, ``energy_error``)."""
    worst = 0.0
    for z in range(out.work.shape[1]):
        w, f = out.work[i, z], out.force[i, z]
        if init or w >= ep.w_peak[i, z]:
            ep.w_peak[i, z], ep.f_peak[i, z] = w, f
        fp = ep.f_peak[i, z]
        k = c.unloading_k[z] if fp >= 0.0 else c.tension_k[z]
        bound = 0.5 * fp * fp / k if k > 0.0 else 0.0
        worst = max(worst, ep.w_peak[i, z] - w - bound)
    return worst


@njit(cache=True, error_model="numpy", _nrt=False)
def _post_step(out, ep, c, active, init):
    """Bookkeeping after a kernel call: episode statistics, crash criteria, observation,
    reward and its terms, and the flat ``info`` row (:data:`INFO_FIELDS`) of every active
    train.

    ``out`` :class:`CrashOutputs`, ``ep`` :class:`Episode`, ``c`` :class:`EnvConsts`. With
    ``init`` the statistics of the active rows are cleared (train at first contact).
    """
    n_cars, nz = ep.peak.shape[1], c.zones.shape[0]
    g, ic, zones, stroke, inv = c.gravity, c.info, c.zones, c.stroke, c.inv_scale
    lim = c.criteria
    for i in range(out.x.shape[0]):
        if not active[i]:
            continue
        if init:
            ep.steps[i] = 0
            ep.peak[i] = 0.0
            ep.decel_sum[i] = 0.0
            ep.max_crush[i] = 0.0
            ep.intrusion[i] = 0.0
            ep.reward[i] = 0.0
            ep.terms[i] = 0.0
            ep.pulse_t0[i] = -1.0
            ep.pulse_v0[i] = ep.pulse_t1[i] = ep.pulse_v1[i] = ep.stopped[i] = 0.0
            ep.ma_peak[i] = 0.0
            ep.over[i] = False
            ep.energy0[i] = out.stored[i]
        else:
            ep.steps[i] += 1
            cost = 0.0
            worst = 0.0
            for k in range(n_cars):
                worst = max(worst, ep.peak[i, k])
            for k in range(n_cars):
                d = -out.a[i, k] / g
                ep.peak[i, k] = max(ep.peak[i, k], d)
                ep.decel_sum[i, k] += d
                cost += (d / DECEL_REF_G) ** 2
            r = -c.w_decel * (c.control_dt / TIME_REF) * cost / n_cars
            t_decel = r
            t_intrusion = 0.0
            for z in range(nz):
                if out.crush[i, zones[z]] > c.crush_limit[z]:  # crushed through a car
                    ep.div[i] = True
                ep.max_crush[i, z] = max(ep.max_crush[i, z], out.crush[i, zones[z]])
                new = max(ep.max_crush[i, z] - stroke[z], 0.0)
                r -= c.w_intrusion * (new - ep.intrusion[i, z]) / INTRUSION_REF
                t_intrusion -= c.w_intrusion * (new - ep.intrusion[i, z]) / INTRUSION_REF
                ep.intrusion[i, z] = new
            growth = 0.0  # of the worst car's peak deceleration over the step, g
            for k in range(n_cars):
                growth = max(growth, ep.peak[i, k] - worst)
            t_peak = -c.w_peak * growth / PEAK_REF_G
            r += t_peak
            if not math.isfinite(r):  # a state too violent to score counts as diverged
                ep.div[i] = True
            if ep.div[i]:
                ep.reward[i] = -DIVERGENCE_PENALTY
                ep.terms[i] = 0.0
                ep.terms[i, 3] = -DIVERGENCE_PENALTY
            else:
                ep.reward[i] = r
                ep.terms[i, 0], ep.terms[i, 1], ep.terms[i, 2] = t_decel, t_intrusion, t_peak
                ep.terms[i, 3] = 0.0
            done = True
            for k in range(out.force.shape[1]):
                if out.force[i, k] > F_STOP or out.rate[i, k] > V_STOP:
                    done = False
            ep.over[i] = done
        obs = ep.obs[i]
        for k in range(n_cars):
            obs[k] = out.x[i, k] * inv[k]
            obs[n_cars + k] = out.v[i, k] * inv[n_cars + k]
            obs[2 * n_cars + k] = out.a[i, k] * inv[2 * n_cars + k]
        j = 3 * n_cars
        for z in range(nz):
            k = zones[z]
            obs[j + z] = out.crush[i, k] * inv[j + z]
            obs[j + nz + z] = out.force[i, k] * inv[j + nz + z]
            obs[j + 2 * nz + z] = (ep.scale[i, k] - 1.0) * inv[j + 2 * nz + z]
        row = ep.info[i]
        steps = ep.steps[i]
        t = steps * c.control_dt
        row[ic.time] = t
        row[ic.initial_speed] = ep.speed[i]
        passed = True
        for k in range(n_cars):
            pulse = _pulse_sample(ep, i, k, t, out.v[i, k], out.a[i, k], c)
            _moving_average_sample(ep, i, k, n_cars, steps, out.v[i, k], c)
            row[ic.payload_kg + k] = ep.payload[i, k]
            row[ic.decel_g + k] = -out.a[i, k] / g
            row[ic.peak_decel_g + k] = ep.peak[i, k]
            row[ic.mean_decel_g + k] = ep.decel_sum[i, k] / max(steps, 1)
            row[ic.moving_average_peak_g + k] = ep.ma_peak[i, k]
            row[ic.pulse_mean_decel_g + k] = pulse
            ok = (
                pulse <= lim.mean_decel_g,
                ep.peak[i, k] <= lim.peak_decel_g,
                ep.ma_peak[i, k] <= lim.moving_average_g,
            )
            row[ic.mean_decel_passed + k] = 1.0 if ok[0] else 0.0
            row[ic.peak_decel_passed + k] = 1.0 if ok[1] else 0.0
            row[ic.moving_average_passed + k] = 1.0 if ok[2] else 0.0
            passed = passed and ok[0] and ok[1] and ok[2]
        exceeded = False
        for z in range(nz):
            k = zones[z]
            row[ic.crush_m + z] = out.crush[i, k]
            row[ic.force_N + z] = out.force[i, k]
            row[ic.absorber_scale + z] = ep.scale[i, k]
            row[ic.absorbed_energy_J + z] = out.work[i, k]
            row[ic.max_crush_m + z] = ep.max_crush[i, z]
            row[ic.intrusion_m + z] = ep.intrusion[i, z]
            row[ic.stroke_used + z] = ep.max_crush[i, z] / stroke[z]
            ok_z = ep.intrusion[i, z] <= lim.intrusion_m
            row[ic.intrusion_passed + z] = 1.0 if ok_z else 0.0
            passed = passed and ok_z
            exceeded = exceeded or ep.max_crush[i, z] > stroke[z]
        row[ic.criteria_passed] = 1.0 if passed else 0.0
        if c.unloading_k.shape[0] > 0:  # surrogate: work returned beyond the elastic bound
            error = _returned_excess(out, ep, i, c, init)
        else:  # reference: the energy-balance residual of the integrator
            error = ep.energy0[i] - out.stored[i] - out.dissipated[i, 0] - out.dissipated[i, 1]
            for k in range(out.work.shape[1]):
                error -= out.work[i, k]
        row[ic.stroke_exceeded] = 1.0 if exceeded else 0.0
        row[ic.friction_work_J] = out.dissipated[i, 0]
        row[ic.energy_error] = error / ep.energy0[i] if ep.energy0[i] > 0.0 else 0.0
        row[ic.diverged] = 1.0 if ep.div[i] else 0.0


@njit(cache=True, inline="always")
def _field(buf, fields, f):
    """2-D array ``f`` (rows, columns) of a :class:`CrashBatch` buffer, as a view."""
    o, r, c = fields[f, 0], fields[f, 1], fields[f, 2]
    return buf[o : o + r * c].reshape((r, c))


@njit(cache=True, inline="always")
def _column(buf, fields, f):
    """1-D array ``f`` (rows,) of a :class:`CrashBatch` buffer, as a view."""
    return buf[fields[f, 0] : fields[f, 0] + fields[f, 1]]


@njit(cache=True, inline="always")
def _views(buf, fields, flags):
    """The :class:`CrashOutputs` and the :class:`Episode` (``flags`` = div, over, steps) of a
    :class:`CrashBatch` buffer, as views; 1-D fields are ``stored`` and :data:`COLUMNS`."""
    out = CrashOutputs(
        _field(buf, fields, 0),
        _field(buf, fields, 1),
        _field(buf, fields, 2),
        _field(buf, fields, 3),
        _field(buf, fields, 4),
        _field(buf, fields, 5),
        _field(buf, fields, 6),
        _field(buf, fields, 7),
        _column(buf, fields, 8),
    )
    k = _ENV
    ep = Episode(
        _field(buf, fields, k),  # scale
        _column(buf, fields, k + 1),  # speed
        _column(buf, fields, k + 2),  # energy0
        _field(buf, fields, k + 3),  # payload
        _field(buf, fields, k + 4),  # peak
        _field(buf, fields, k + 5),  # decel_sum
        _field(buf, fields, k + 6),  # max_crush
        _field(buf, fields, k + 7),  # intrusion
        _field(buf, fields, k + 8),  # w_peak
        _field(buf, fields, k + 9),  # f_peak
        _field(buf, fields, k + 10),  # pulse_t0
        _field(buf, fields, k + 11),  # pulse_v0
        _field(buf, fields, k + 12),  # pulse_t1
        _field(buf, fields, k + 13),  # pulse_v1
        _field(buf, fields, k + 14),  # stopped
        _field(buf, fields, k + 15),  # prev_v
        _field(buf, fields, k + 16),  # prev_a
        _field(buf, fields, k + 17),  # ring
        _field(buf, fields, k + 18),  # ma_peak
        _field(buf, fields, k + 19),  # terms
        _field(buf, fields, k + 20),  # obs
        _column(buf, fields, k + 21),  # reward
        _field(buf, fields, k + 22),  # info
        *flags,
    )
    return out, ep


# One compiled call per control step (absorber scales, physics, bookkeeping) per backend, and
# every per-train float array in one buffer (:meth:`CrashBatch._pack`): each array passed from
# Python into a compiled function has a fixed cost, a sizeable part of a single-env step.
@njit(cache=True, inline="always")
def _begin(buf, fields, flags, consts, actions, active, init):
    """Named constants, the buffer's views and, unless ``init``, the absorber scales
    (:func:`_set_scale`); ``ok`` is False for a non-finite action."""
    c = _named_consts(consts)
    out, ep = _views(buf, fields, flags)
    ok = init or _set_scale(actions, ep.scale, active, c)
    return c, out, ep, ok


@njit(cache=True, inline="always")
def _reference_state(buf, fields):
    """The :class:`ReferenceState` of a :class:`CrashBatch` buffer, as views."""
    k = _STATE
    return ReferenceState(
        _field(buf, fields, k),
        _field(buf, fields, k + 1),
        _field(buf, fields, k + 2),
        _field(buf, fields, k + 3),
        _field(buf, fields, k + 4),
        _field(buf, fields, k + 5),
        _field(buf, fields, k + 6),
        _field(buf, fields, k + 7),
        _field(buf, fields, k + 8),
    )


@njit(cache=True, inline="always")
def _surrogate_state(buf, fields):
    """The :class:`SurrogateState` of a :class:`CrashBatch` buffer, as views."""
    k = _STATE
    return SurrogateState(
        _field(buf, fields, k),
        _field(buf, fields, k + 1),
        _field(buf, fields, k + 2),
        _field(buf, fields, k + 3),
        _field(buf, fields, k + 4),
        _field(buf, fields, k + 5),
        _field(buf, fields, k + 6),
    )


@njit(cache=True)
def _advance_reference(buf, fields, flags, params, stepping, consts, actions, active, init):
    """:func:`_set_scale` (unless ``init``), :func:`reference_batch_step` and
    :func:`_post_step` on a :class:`CrashBatch` buffer; ``False`` (nothing done) for a
    non-finite action. ``params``, ``consts``: :func:`plain` tuples of
    :class:`ReferenceParams` and :class:`EnvConsts`; ``stepping`` = (dt, n_sub)."""
    c, out, ep, ok = _begin(buf, fields, flags, consts, actions, active, init)
    if not ok:
        return False
    state, p = _reference_state(buf, fields), _named_reference(params)
    dt, n_sub = stepping
    reference_batch_step(state, out, p, ep.scale, active, init, dt, n_sub, STATE_LIMIT, ep.div)
    _post_step(out, ep, c, active, init)
    return True


@njit(cache=True)
def _advance_surrogate(buf, fields, flags, params, stepping, consts, actions, active, init):
    """:func:`_advance_reference` with :func:`surrogate_batch_step`."""
    c, out, ep, ok = _begin(buf, fields, flags, consts, actions, active, init)
    if not ok:
        return False
    state, p = _surrogate_state(buf, fields), _named_surrogate(params)
    dt, n_sub = stepping
    surrogate_batch_step(state, out, p, ep.scale, active, init, dt, n_sub, STATE_LIMIT, ep.div)
    _post_step(out, ep, c, active, init)
    return True


# Not cached: it calls the uncached parallel kernel.
@njit
def _advance_surrogate_parallel(
    buf, fields, flags, params, stepping, consts, actions, active, init
):
    """:func:`_advance_surrogate` with :func:`surrogate_batch_step_parallel` (all threads)."""
    c, out, ep, ok = _begin(buf, fields, flags, consts, actions, active, init)
    if not ok:
        return False
    state, p = _surrogate_state(buf, fields), _named_surrogate(params)
    dt, n_sub = stepping
    surrogate_batch_step_parallel(
        state, out, p, ep.scale, active, init, dt, n_sub, STATE_LIMIT, ep.div
    )
    _post_step(out, ep, c, active, init)
    return True
