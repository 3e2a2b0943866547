"""Compiled bookkeeping of ``railgym/TrainCrash-v1`` (:mod:`railgym.envs.crash`): absorber
scales, the model's batch step, episode statistics, observation, reward and the flat ``info``
row, one compiled call per control step for all trains."""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from railgym.envs.crash.layout import (
    CLEARED,
    COLUMNS,
    ENV_FIELDS,
    Episode,
    InfoColumns,
    buffer_views,
    named_rebuild,
    row_clearer,
)
from railgym.vehicles.crash.criteria import zero_crossing
from railgym.vehicles.crash.outputs import CrashOutputs
from railgym.vehicles.crash.reference import ReferenceParams, ReferenceState, reference_batch_step
from railgym.vehicles.crash.surrogate_model import (
    SurrogateParams,
    SurrogateState,
    surrogate_batch_step,
    surrogate_batch_step_parallel,
)

__all__ = [
    "DECEL_REF_G",
    "DIVERGENCE_PENALTY",
    "ENV_START",
    "F_STOP",
    "INTRUSION_REF",
    "PEAK_REF_G",
    "STATE_LIMIT",
    "STATE_START",
    "TIME_REF",
    "V_STOP",
    "Criteria",
    "EnvConsts",
    "advance_reference",
    "advance_surrogate",
    "advance_surrogate_parallel",
    "crush_limits",
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
    absorber_stroke : (zones,) absorber stroke, m. crush_limit : (zones,) largest crush the model
        holds, m (:func:`crush_limits`); beyond it the train counts as diverged.
    inv_scale : (obs,) 1 / observation scale.
    w_decel, w_intrusion, w_peak : reward weights. gravity : m/s². control_dt : s.
    absorber_range : action ±1 sets the scale 1 ± range. max_scale_change : largest scale
        change per step. unloading_k, tension_k : (model zones,) unloading and coupler tension
        stiffness of each surrogate element, N/m, for its energy check (empty for the
        reference: ``energy_error`` is then the energy-balance residual).
    criteria : :class:`Criteria`. info : :class:`InfoColumns`.
    """

    zones: np.ndarray
    absorber_stroke: np.ndarray
    crush_limit: np.ndarray
    inv_scale: np.ndarray
    w_decel: float
    w_intrusion: float
    w_peak: float
    gravity: float
    control_dt: float
    absorber_range: float
    max_scale_change: float
    unloading_k: np.ndarray
    tension_k: np.ndarray
    criteria: Criteria
    info: InfoColumns


def plain(value: Any) -> Any:
    """``value`` with every NamedTuple turned into a plain tuple, recursively: compiled code
    types a plain tuple argument much faster than a NamedTuple (rebuilt inside by
    :func:`~railgym.envs.crash.layout.named_rebuild`)."""
    if isinstance(value, tuple):
        return tuple(plain(v) for v in value)
    return value


_named_consts = named_rebuild(EnvConsts)
_named_reference = named_rebuild(ReferenceParams)
_named_surrogate = named_rebuild(SurrogateParams)
_OUTPUT_DIMS = tuple(1 if name == "stored" else 2 for name in CrashOutputs._fields)
#: buffer layout: the :class:`CrashOutputs` arrays, :data:`ENV_FIELDS`, the model state
ENV_START = len(CrashOutputs._fields)
STATE_START = ENV_START + len(ENV_FIELDS)
_output_views = buffer_views(_OUTPUT_DIMS)
_episode_views = buffer_views(tuple(1 if name in COLUMNS else 2 for name in ENV_FIELDS))
_reference_views = buffer_views((2,) * len(ReferenceState._fields))
_surrogate_views = buffer_views((2,) * len(SurrogateState._fields))
_clear_episode = row_clearer(CLEARED)


@njit(cache=True)
def _set_scale(actions, scale, active, consts):
    """Move each active absorber's force scale towards ``1 + range · action`` by at most
    ``consts.max_scale_change``, the action clipped to [−1, 1]. Returns ``False``, changing
    nothing, if any action (of any train) is not finite."""
    for i in range(actions.shape[0]):
        for z in range(actions.shape[1]):
            if not math.isfinite(actions[i, z]):
                return False
    for i in range(actions.shape[0]):
        if not active[i]:
            continue
        for z in range(consts.zones.shape[0]):
            k = consts.zones[z]
            a = min(max(actions[i, z], -1.0), 1.0)
            step = 1.0 + consts.absorber_range * a - scale[i, k]
            scale[i, k] += min(max(step, -consts.max_scale_change), consts.max_scale_change)
    return True


@njit(cache=True, inline="always")
def _pulse_sample(episode, i, k, t, v, a, consts):
    """Car ``k`` of train ``i`` at time ``t`` (s), velocity ``v``, acceleration ``a``: update
    its crash pulse as :func:`railgym.vehicles.crash.criteria.crash_pulse` defines it, one
    sample at a time; returns the pulse mean deceleration so far, g."""
    gravity = consts.gravity
    if episode.stopped[i, k] == 0.0:
        braking = -a >= consts.criteria.onset_g * gravity
        if episode.pulse_t0[i, k] < 0.0:
            if braking:
                episode.pulse_t0[i, k], episode.pulse_v0[i, k] = t, v
                episode.pulse_t1[i, k], episode.pulse_v1[i, k] = t, v
                if v <= 0.0:
                    episode.stopped[i, k] = 1.0
        elif v <= 0.0:
            t_prev = t - consts.control_dt
            episode.pulse_t1[i, k] = zero_crossing(
                t_prev, t, episode.prev_v[i, k], v, episode.prev_a[i, k]
            )
            episode.pulse_v1[i, k] = 0.0
            episode.stopped[i, k] = 1.0
        elif braking:
            episode.pulse_t1[i, k], episode.pulse_v1[i, k] = t, v
    episode.prev_v[i, k], episode.prev_a[i, k] = v, a
    span = episode.pulse_t1[i, k] - episode.pulse_t0[i, k]
    if episode.pulse_t0[i, k] < 0.0 or span <= 0.0:
        return 0.0
    return (episode.pulse_v0[i, k] - episode.pulse_v1[i, k]) / (gravity * span)


@njit(cache=True, inline="always")
def _moving_average_sample(episode, i, k, n_cars, steps, v, consts):
    """Store car ``k``'s velocity ``v`` of control step ``steps`` in the ring and update its
    moving-average peak deceleration (g) over ``window_steps`` control steps."""
    w = consts.criteria.window_steps
    slots = w + 1
    episode.ring[i, (steps % slots) * n_cars + k] = v
    if steps >= w:
        old = episode.ring[i, ((steps - w) % slots) * n_cars + k]
        mean = (old - v) / (consts.gravity * consts.criteria.window)
        episode.ma_peak[i, k] = mean if steps == w else max(episode.ma_peak[i, k], mean)


@njit(cache=True, inline="always")
def _returned_excess(outputs, episode, i, consts, init):
    """Largest work (J) any zone of train ``i`` has returned since its work peak beyond the
    elastic energy ``f² / (2 k)`` it could store at that peak (``k`` the unloading stiffness,
    the coupler's in tension); 0 if none (see ``docs/envs/crash.md``, ``energy_error``)."""
    worst = 0.0
    for z in range(outputs.work.shape[1]):
        w, f = outputs.work[i, z], outputs.force[i, z]
        if init or w >= episode.w_peak[i, z]:
            episode.w_peak[i, z], episode.f_peak[i, z] = w, f
        fp = episode.f_peak[i, z]
        k = consts.unloading_k[z] if fp >= 0.0 else consts.tension_k[z]
        bound = 0.5 * fp * fp / k if k > 0.0 else 0.0
        worst = max(worst, episode.w_peak[i, z] - w - bound)
    return worst


@njit(cache=True, inline="always")
def _score_decelerations(outputs, episode, consts, i):
    """Update train ``i``'s peak and summed car decelerations (g); returns the reward's
    ``decel`` term and the worst car's peak before the step (g)."""
    n_cars = episode.peak.shape[1]
    worst = 0.0
    for k in range(n_cars):
        worst = max(worst, episode.peak[i, k])
    cost = 0.0
    for k in range(n_cars):
        d = -outputs.a[i, k] / consts.gravity
        episode.peak[i, k] = max(episode.peak[i, k], d)
        episode.decel_sum[i, k] += d
        cost += (d / DECEL_REF_G) ** 2
    return -consts.w_decel * (consts.control_dt / TIME_REF) * cost / n_cars, worst


@njit(cache=True, inline="always")
def _score_intrusions(outputs, episode, consts, i, reward):
    """Update train ``i``'s largest crush and intrusion per zone (m), flag a zone crushed
    through a car as diverged; returns ``reward`` less the intrusion growth and the reward's
    ``intrusion`` term."""
    term = 0.0
    for z in range(consts.zones.shape[0]):
        crush = outputs.crush[i, consts.zones[z]]
        if crush > consts.crush_limit[z]:  # crushed through a car
            episode.div[i] = True
        episode.max_crush[i, z] = max(episode.max_crush[i, z], crush)
        new = max(episode.max_crush[i, z] - consts.absorber_stroke[z], 0.0)
        cost = consts.w_intrusion * (new - episode.intrusion[i, z]) / INTRUSION_REF
        reward -= cost
        term -= cost
        episode.intrusion[i, z] = new
    return reward, term


@njit(cache=True, inline="always")
def _score_peak(episode, consts, i, worst):
    """The reward's ``peak`` term: the growth of train ``i``'s worst car peak (g) over the
    step, from ``worst`` before it."""
    growth = 0.0
    for k in range(episode.peak.shape[1]):
        growth = max(growth, episode.peak[i, k] - worst)
    return -consts.w_peak * growth / PEAK_REF_G


@njit(cache=True, inline="always")
def _set_reward(episode, i, reward, decel, intrusion, peak):
    """Store train ``i``'s reward and its terms; a diverged train (or a reward that is not
    finite) gets the divergence penalty alone."""
    if not math.isfinite(reward):  # a state too violent to score counts as diverged
        episode.div[i] = True
    if episode.div[i]:
        episode.reward[i] = -DIVERGENCE_PENALTY
        episode.terms[i] = 0.0
        episode.terms[i, 3] = -DIVERGENCE_PENALTY
    else:
        episode.reward[i] = reward
        episode.terms[i, 0], episode.terms[i, 1], episode.terms[i, 2] = decel, intrusion, peak
        episode.terms[i, 3] = 0.0


@njit(cache=True, inline="always")
def _crash_over(outputs, i):
    """True when no zone of train ``i`` carries more than :data:`F_STOP` nor closes faster
    than :data:`V_STOP`."""
    for k in range(outputs.force.shape[1]):
        if outputs.force[i, k] > F_STOP or outputs.rate[i, k] > V_STOP:
            return False
    return True


@njit(cache=True, inline="always")
def _score_step(outputs, episode, consts, i):
    """One control step of train ``i``: statistics, reward and its terms, crash end."""
    episode.steps[i] += 1
    reward, worst = _score_decelerations(outputs, episode, consts, i)
    decel = reward
    reward, intrusion = _score_intrusions(outputs, episode, consts, i, reward)
    peak = _score_peak(episode, consts, i, worst)
    _set_reward(episode, i, reward + peak, decel, intrusion, peak)
    episode.over[i] = _crash_over(outputs, i)


@njit(cache=True, inline="always")
def _observe(outputs, episode, consts, i):
    """Train ``i``'s observation: car x, v, a, then zone crush, force and scale − 1, each
    over its scale."""
    n_cars, n_zones, inv = episode.peak.shape[1], consts.zones.shape[0], consts.inv_scale
    obs = episode.obs[i]
    for k in range(n_cars):
        obs[k] = outputs.x[i, k] * inv[k]
        obs[n_cars + k] = outputs.v[i, k] * inv[n_cars + k]
        obs[2 * n_cars + k] = outputs.a[i, k] * inv[2 * n_cars + k]
    j = 3 * n_cars
    for z in range(n_zones):
        k = consts.zones[z]
        obs[j + z] = outputs.crush[i, k] * inv[j + z]
        obs[j + n_zones + z] = outputs.force[i, k] * inv[j + n_zones + z]
        obs[j + 2 * n_zones + z] = (episode.scale[i, k] - 1.0) * inv[j + 2 * n_zones + z]


@njit(cache=True, inline="always")
def _car_info(outputs, episode, consts, i, t):
    """The per-car ``info`` columns of train ``i`` at time ``t`` (s), the crash pulse and the
    moving average updated; returns whether every car meets every deceleration limit."""
    row, col, limits = episode.info[i], consts.info, consts.criteria
    steps, g, passed = episode.steps[i], consts.gravity, True
    n_cars = episode.peak.shape[1]
    for k in range(n_cars):
        pulse = _pulse_sample(episode, i, k, t, outputs.v[i, k], outputs.a[i, k], consts)
        _moving_average_sample(episode, i, k, n_cars, steps, outputs.v[i, k], consts)
        row[col.payload_kg + k] = episode.payload[i, k]
        row[col.decel_g + k] = -outputs.a[i, k] / g
        row[col.peak_decel_g + k] = episode.peak[i, k]
        row[col.mean_decel_g + k] = episode.decel_sum[i, k] / max(steps, 1)
        row[col.moving_average_peak_g + k] = episode.ma_peak[i, k]
        row[col.pulse_mean_decel_g + k] = pulse
        ok = (
            pulse <= limits.mean_decel_g,
            episode.peak[i, k] <= limits.peak_decel_g,
            episode.ma_peak[i, k] <= limits.moving_average_g,
        )
        row[col.mean_decel_passed + k] = 1.0 if ok[0] else 0.0
        row[col.peak_decel_passed + k] = 1.0 if ok[1] else 0.0
        row[col.moving_average_passed + k] = 1.0 if ok[2] else 0.0
        passed = passed and ok[0] and ok[1] and ok[2]
    return passed


@njit(cache=True, inline="always")
def _zone_info(outputs, episode, consts, i, passed):
    """The per-zone ``info`` columns of train ``i``, ``stroke_exceeded`` and
    ``criteria_passed`` (``passed``: the cars' verdict)."""
    row, col, stroke = episode.info[i], consts.info, consts.absorber_stroke
    exceeded = False
    for z in range(consts.zones.shape[0]):
        k = consts.zones[z]
        row[col.crush_m + z] = outputs.crush[i, k]
        row[col.force_N + z] = outputs.force[i, k]
        row[col.absorber_scale + z] = episode.scale[i, k]
        row[col.absorbed_energy_J + z] = outputs.work[i, k]
        row[col.max_crush_m + z] = episode.max_crush[i, z]
        row[col.intrusion_m + z] = episode.intrusion[i, z]
        row[col.stroke_used + z] = episode.max_crush[i, z] / stroke[z]
        ok = episode.intrusion[i, z] <= consts.criteria.intrusion_m
        row[col.intrusion_passed + z] = 1.0 if ok else 0.0
        passed = passed and ok
        exceeded = exceeded or episode.max_crush[i, z] > stroke[z]
    row[col.criteria_passed] = 1.0 if passed else 0.0
    row[col.stroke_exceeded] = 1.0 if exceeded else 0.0


@njit(cache=True, inline="always")
def _energy_error(outputs, episode, consts, i, init):
    """``info["energy_error"]`` of train ``i``: surrogate, the work returned beyond the
    elastic bound (:func:`_returned_excess`); reference, the integrator's energy-balance
    residual; over the energy at first contact."""
    if consts.unloading_k.shape[0] > 0:
        error = _returned_excess(outputs, episode, i, consts, init)
    else:
        error = (
            episode.energy0[i]
            - outputs.stored[i]
            - outputs.dissipated[i, 0]
            - outputs.dissipated[i, 1]
        )
        for k in range(outputs.work.shape[1]):
            error -= outputs.work[i, k]
    return error / episode.energy0[i] if episode.energy0[i] > 0.0 else 0.0


@njit(cache=True, error_model="numpy", _nrt=False)
def _post_step(outputs, episode, consts, active, init):
    """Bookkeeping after a kernel call: episode statistics, crash criteria, observation,
    reward and its terms, and the flat ``info`` row (``crash_layout.INFO_FIELDS``) of every active
    train.

    ``outputs`` :class:`CrashOutputs`, ``episode`` :class:`Episode`, ``consts``
    :class:`EnvConsts`. With ``init`` the trains are at first contact (the arrays of
    :data:`~railgym.envs.crash.layout.CLEARED` already cleared, :func:`_begin`): the step is
    not scored.
    """
    col = consts.info
    for i in range(outputs.x.shape[0]):
        if not active[i]:
            continue
        if init:
            episode.energy0[i] = outputs.stored[i]
        else:
            _score_step(outputs, episode, consts, i)
        _observe(outputs, episode, consts, i)
        row = episode.info[i]
        t = episode.steps[i] * consts.control_dt
        row[col.time] = t
        row[col.initial_speed] = episode.speed[i]
        passed = _car_info(outputs, episode, consts, i, t)
        _zone_info(outputs, episode, consts, i, passed)
        row[col.friction_work_J] = outputs.dissipated[i, 0]
        row[col.energy_error] = _energy_error(outputs, episode, consts, i, init)
        row[col.diverged] = 1.0 if episode.div[i] else 0.0


@njit(cache=True, inline="always")
def _views(buf, fields, flags):
    """The :class:`CrashOutputs` and the :class:`Episode` (``flags`` = div, over, steps) of a
    :class:`CrashBatch` buffer, as views."""
    outputs = CrashOutputs(*_output_views(buf, fields, 0))
    return outputs, Episode(*_episode_views(buf, fields, ENV_START), *flags)


# One compiled call per control step (absorber scales, physics, bookkeeping) per backend, and
# every per-train float array in one buffer (:meth:`CrashBatch._pack`): each array passed from
# Python into a compiled function has a fixed cost, a sizeable part of a single-env step.
@njit(cache=True, inline="always")
def _begin(buf, fields, flags, consts, actions, active, init):
    """Named constants, the buffer's views, then with ``init`` the active trains' arrays of
    :data:`~railgym.envs.crash.layout.CLEARED` cleared, else the absorber scales
    (:func:`_set_scale`); ``ok`` is False for a non-finite action."""
    named = _named_consts(consts)
    outputs, episode = _views(buf, fields, flags)
    if init:
        for i in range(active.shape[0]):
            if active[i]:
                _clear_episode(episode, i)
    ok = init or _set_scale(actions, episode.scale, active, named)
    return named, outputs, episode, ok


@njit(cache=True, inline="always")
def _reference_state(buf, fields):
    """The :class:`ReferenceState` of a :class:`CrashBatch` buffer, as views."""
    return ReferenceState(*_reference_views(buf, fields, STATE_START))


@njit(cache=True, inline="always")
def _surrogate_state(buf, fields):
    """The :class:`SurrogateState` of a :class:`CrashBatch` buffer, as views."""
    return SurrogateState(*_surrogate_views(buf, fields, STATE_START))


@njit(inline="always")
def _advance(step, state, params, args):
    """:func:`_set_scale` (unless ``init``), the model's batch step ``step`` on its ``state``
    and named ``params``, and :func:`_post_step` on a :class:`CrashBatch` buffer; ``False``
    (nothing done) for a non-finite action. Inlined into each backend's entry point, so the
    compiled ``step`` is a constant there (the entry points stay cached). ``args``: the
    entry point's ``(buf, fields, flags, consts, actions, active, init, stepping)``."""
    buf, fields, flags, consts, actions, active, init, stepping = args
    named, outputs, episode, ok = _begin(buf, fields, flags, consts, actions, active, init)
    if not ok:
        return False
    dt, n_sub = stepping
    step(state, outputs, params, episode.scale, active, init, dt, n_sub, STATE_LIMIT, episode.div)
    _post_step(outputs, episode, named, active, init)
    return True


@njit(cache=True)
def advance_reference(buf, fields, flags, params, stepping, consts, actions, active, init):
    """:func:`_advance` with :func:`reference_batch_step`. ``params``, ``consts``:
    :func:`plain` tuples of :class:`ReferenceParams` and :class:`EnvConsts`; ``stepping`` =
    (dt, n_sub)."""
    state, named = _reference_state(buf, fields), _named_reference(params)
    args = (buf, fields, flags, consts, actions, active, init, stepping)
    return _advance(reference_batch_step, state, named, args)


@njit(cache=True)
def advance_surrogate(buf, fields, flags, params, stepping, consts, actions, active, init):
    """:func:`advance_reference` with :func:`surrogate_batch_step`."""
    state, named = _surrogate_state(buf, fields), _named_surrogate(params)
    args = (buf, fields, flags, consts, actions, active, init, stepping)
    return _advance(surrogate_batch_step, state, named, args)


# Not cached: it calls the uncached parallel kernel.
@njit
def advance_surrogate_parallel(buf, fields, flags, params, stepping, consts, actions, active, init):
    """:func:`advance_surrogate` with :func:`surrogate_batch_step_parallel` (all threads)."""
    state, named = _surrogate_state(buf, fields), _named_surrogate(params)
    args = (buf, fields, flags, consts, actions, active, init, stepping)
    return _advance(surrogate_batch_step_parallel, state, named, args)
