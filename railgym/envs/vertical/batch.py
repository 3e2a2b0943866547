"""The batch of :mod:`railgym.envs.vertical`: ``n`` vertical vehicles stepped by one compiled call.

:class:`VerticalBatch` implements the batch contract of :mod:`railgym.envs.base`: it holds the
arrays the kernels of :mod:`railgym.vehicles.vertical` work on, and a compiled control step
(:func:`control_step`) runs the kernel of the variant and turns its outputs into observation,
reward, reward terms, the ``info`` values (layout declared in :data:`INFO_KEYS`) and the
episode flags. With a controllable damper (``actuator="semi-active"``) the action is its
command, the kernel :func:`~railgym.vehicles.vertical.kernels.advance_semi_active` and the
force of the step (``force``: reward, ``info["actuator_force"]``) the damper's at its end;
``info`` adds :data:`SEMI_ACTIVE_INFO_KEYS`.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from railgym.envs.batch_base import TrackBatch, draw_tracks
from railgym.envs.compiled import (
    DIVERGENCE_PENALTY,
    OBS_LIMIT,
    compiled_entry,
    settle_reward,
    weigh,
)
from railgym.envs.params import TrackEnvParams, consts
from railgym.envs.track_shell import reward_sections, track_window
from railgym.profile import profile_time_input
from railgym.track import track_time_input, track_time_window
from railgym.vehicles.element_envelope import EnvelopeCheck, OperatingEnvelope
from railgym.vehicles.vertical.elements import DamperLaw, LprArrays
from railgym.vehicles.vertical.kernels import (
    RAISE_MODE,
    advance_kind,
    advance_semi_active,
    check_variant,
    initial_state,
    scalar_work,
    step_outputs,
)
from railgym.vehicles.vertical.params import SuspensionParams, VerticalVehicle

__all__ = [
    "ACC_REF",
    "DIVERGENCE_PENALTY",
    "INFO_KEYS",
    "OBS_LIMIT",
    "OUTCOME",
    "REWARD_TERMS",
    "SEMI_ACTIVE_INFO_KEYS",
    "VerticalBatch",
    "control_step",
]

#: tests only: force chunked mode with windows of this many samples (None: by memory)
_FORCED_WINDOW: int | None = None

#: reference carbody acceleration of the reward, m/s²: passive RMS on the training case
#: (class 5, 144 km/h, dynamic reference), so that a passive step's reward is about −1
ACC_REF = 0.75


class Counters(NamedTuple):
    """Per-vehicle episode counters updated by :func:`post_step`."""

    k: np.ndarray  #: int64 (n,) current track sample
    steps: np.ndarray  #: int64 (n,) control steps this episode
    contacts: np.ndarray  #: int64 (n,) substeps in bump-stop contact
    ood: np.ndarray  #: int64 (n,) out-of-domain surrogate evaluations
    acc_sq: np.ndarray  #: float64 (n,) sum of ẍ2², m²/s⁴
    zi: np.ndarray  #: float64 (n, n_sec, 2) state of the reward's weighting filter, m/s²


class StepCfg(NamedTuple):
    """Constants of :func:`control_step` (SI units)."""

    kind: int  #: kernel variant number (:func:`~railgym.vehicles.vertical.kernels.check_variant`)
    n_sub: int  #: RK4 substeps per control step
    dt: float  #: integration step, s
    n_steps: int  #: control steps per episode (truncation)
    control_dt: float  #: s
    f_max: float  #: actuator force at action ±1, N (semi-active: the reward's force scale)
    free_travel: float  #: m
    w_acc: float
    w_defl: float
    w_force: float
    sos: np.ndarray  #: float64 (n_sec, 6) the reward's weighting of ẍ2 (`reward_sections`)
    inv_scale: np.ndarray  #: float64 (n_obs,) 1/scale of each observation channel
    flag_ood: bool  #: "raise" policy: flag steps with out-of-domain surrogate evaluations
    full_obs: bool  #: the ``"full"`` observation (else ``"sensors"``)
    semi_active: bool  #: a controllable damper: its command ``u`` observed and in ``info``


class StepResult(NamedTuple):
    """Outputs of :func:`post_step` per vehicle: observation (n, n_obs), reward (n,), its
    terms (n, len(REWARD_TERMS)), the outcome and info values (n, N_OUTCOME + len(INFO_KEYS),
    :data:`OUTCOME` then :data:`INFO_COLUMN`), and the truncated and extrapolated flags (n,)."""

    obs: np.ndarray
    reward: np.ndarray
    terms: np.ndarray
    info: np.ndarray
    truncated: np.ndarray
    extrapolated: np.ndarray


#: columns of :attr:`StepResult.terms`, the keys of ``info["reward_terms"]``
REWARD_TERMS = ("acceleration", "deflection", "force", "divergence")
#: the first columns of :attr:`StepResult.info`: the step's outcome (reward, its terms, the
#: diverged, extrapolated and truncated flags as 1.0 / 0.0), copies for the single env's one
#: read (:meth:`VerticalBatch.outcome`); the info keys follow
OUTCOME = ("reward", *REWARD_TERMS, "diverged", "extrapolated", "truncated")
N_OUTCOME = len(OUTCOME)
_O_REWARD, _O_TERMS, _O_DIV, _O_EXT, _O_TRUNC = (
    OUTCOME.index(k) for k in ("reward", REWARD_TERMS[0], "diverged", "extrapolated", "truncated")
)

#: the ``info`` layout of the single and the vector env, declared once: key, Python type of
#: the single env's value (the vector env's arrays are float64, int64 and bool)
INFO_KEYS = (
    ("time", float),  # s
    ("carbody_acc", float),  # m/s²
    ("out_of_domain", int),
    ("bump_stop_contacts", int),
    ("outside_element", bool),  # an element evaluation of this step was outside its box
    ("outside_envelope", bool),  # the episode's class / speed is outside the element's envelope
    ("rms_carbody_acc", float),  # m/s²
    ("actuator_force", float),  # N
)
#: the keys ``actuator="semi-active"`` adds after :data:`INFO_KEYS`
SEMI_ACTIVE_INFO_KEYS = (
    ("damper_force", float),  # N, the damper's at the end of the step
    ("damper_command", float),  # its filtered command u at the end of the step
)
_INFO = [key for key, _ in INFO_KEYS]
#: column of each info key in :attr:`StepResult.info` (after :data:`OUTCOME`); the compiled
#: step writes them by name
INFO_COLUMN = {
    key: N_OUTCOME + j for j, key in enumerate(_INFO + [k for k, _ in SEMI_ACTIVE_INFO_KEYS])
}
I_TIME, I_ACC, I_RMS, I_FORCE = (
    INFO_COLUMN[k] for k in ("time", "carbody_acc", "rms_carbody_acc", "actuator_force")
)
I_OOD, I_CONTACTS, I_OUTSIDE, I_ENVELOPE = (
    INFO_COLUMN[k]
    for k in ("out_of_domain", "bump_stop_contacts", "outside_element", "outside_envelope")
)
I_DAMPER_FORCE, I_DAMPER_COMMAND = (INFO_COLUMN[k] for k in ("damper_force", "damper_command"))
#: width of a row of :attr:`StepResult.info` without the damper's columns
_N_ROW = N_OUTCOME + len(INFO_KEYS)
#: (column, type) of the single env's int and bool values; the vector env's array dtypes
_CAST_INFO = tuple((j, kind) for j, (_, kind) in enumerate(INFO_KEYS) if kind is not float)
_DTYPES = {int: np.int64, bool: np.bool_}

_LINEAR, _STATIC, _DYNAMIC, _SURROGATE = (
    check_variant(v) for v in ("linear", "static", "dynamic", "surrogate")
)


@njit(cache=True)
def _observe(state, acc, z, zdot, k, s, i, obs, full, damper):
    """Normalised observation of vehicle ``i`` into ``obs[i]``; ``s`` is 1/scale per channel,
    ``full``: the ``"full"`` observation, ``damper``: the damper's command ``u`` (state
    column −2) as the last channel."""
    if damper:
        n = obs.shape[1] - 1
        obs[i, n] = state[i, state.shape[1] - 2] * s[n]
    if full:
        kk = min(k[i], z.shape[1] - 1)
        raw = (
            state[i, 0],
            state[i, 1],
            state[i, 2],
            state[i, 3],
            acc[i, 0],
            acc[i, 1],
            z[i, kk],
            zdot[i, kk],
        )
        for j in range(8):
            obs[i, j] = raw[j] * s[j]
    else:
        obs[i, 0] = acc[i, 1] * s[0]
        obs[i, 1] = acc[i, 0] * s[1]
        obs[i, 2] = (state[i, 0] - state[i, 2]) * s[2]
        obs[i, 3] = (state[i, 1] - state[i, 3]) * s[3]
        obs[i, 4] = state[i, 3] * s[4]


@njit(cache=True)
def post_step(state, z, zdot, out, force, counters, result, consts):
    """Bookkeeping after a kernel call: counters, observation, reward and its terms
    (:func:`~railgym.envs.compiled.settle_reward`: a divergence also when the reward is not
    finite or the observation too large; ẍ2 weighted in the reward by ``consts.sos``,
    :func:`~railgym.envs.compiled.weigh`), info values and the truncated and extrapolated
    flags. ``outside_element`` is set for the step exactly when its count of element
    evaluations outside the training box (any RK4 stage) is positive; ``outside_envelope``
    is the episode's, written at reset."""
    for i in range(state.shape[0]):
        counters.k[i] += consts.n_sub
        counters.steps[i] += 1
        counters.contacts[i] += out.count[i, 0]
        counters.ood[i] += out.count[i, 1]
        counters.acc_sq[i] += out.acc[i, 1] * out.acc[i, 1]
        _observe(
            state,
            out.acc,
            z,
            zdot,
            counters.k,
            consts.inv_scale,
            i,
            result.obs,
            consts.full_obs,
            consts.semi_active,
        )
        defl = (state[i, 0] - state[i, 2]) / consts.free_travel
        fa = force[i] / consts.f_max
        a2 = weigh(consts.sos, counters.zi[i], out.acc[i, 1]) / ACC_REF
        t_a = -(consts.w_acc * a2 * a2)
        t_d = -(consts.w_defl * defl * defl)
        t_f = -(consts.w_force * fa * fa)
        settle_reward(result.obs, result.terms, result.reward, out.div, i, t_a, t_d, t_f)
        result.info[i, I_TIME] = counters.steps[i] * consts.control_dt
        result.info[i, I_ACC] = out.acc[i, 1]
        result.info[i, I_OOD] = counters.ood[i]
        result.info[i, I_CONTACTS] = counters.contacts[i]
        result.info[i, I_RMS] = math.sqrt(counters.acc_sq[i] / max(counters.steps[i], 1))
        result.info[i, I_FORCE] = force[i]
        result.info[i, I_OUTSIDE] = 1.0 if out.count[i, 1] > 0 else 0.0
        if consts.semi_active:
            result.info[i, I_DAMPER_FORCE] = force[i]
            result.info[i, I_DAMPER_COMMAND] = state[i, state.shape[1] - 2]
        result.truncated[i] = counters.steps[i] >= consts.n_steps
        if consts.flag_ood:
            result.extrapolated[i] = out.count[i, 1] > 0
        result.info[i, _O_REWARD] = result.reward[i]
        for j in range(len(REWARD_TERMS)):
            result.info[i, _O_TERMS + j] = result.terms[i, j]
        result.info[i, _O_DIV] = 1.0 if out.div[i] else 0.0
        result.info[i, _O_EXT] = 1.0 if result.extrapolated[i] else 0.0
        result.info[i, _O_TRUNC] = 1.0 if result.truncated[i] else 0.0


# Without the runtime's reference counting: the arrays come from the batch, which owns them
# for the call, so the entry point unboxes them without runtime records and the kernel's
# counting of every array it passes on (per RK4 stage) is skipped. The kernel's own scratch
# arrays are still allocated and freed by the runtime
# (tests/envs/vehicle/test_vehicle_shell.py checks the balance).
@njit(cache=True, _nrt=False)
def control_step(
    state, z, zdot, action, force, params, lpr, damper, out, counters, result, consts, work
):
    """One control step of every vehicle: actuator forces ``action[:, 0] · f_max`` (N), the
    kernel of variant ``consts.kind`` (arguments as
    :func:`~railgym.vehicles.vertical.kernels.advance_linear` with ``k0 = counters.k``; ``work``
    the batch's :class:`~railgym.vehicles.vertical.kernels.ScalarWork`), then
    :func:`post_step`. With a ``damper`` (:class:`~railgym.vehicles.vertical.elements.DamperLaw`,
    else ``None``) ``action[:, 0]`` is its command and ``force`` receives its force (N)."""
    k, n_sub, dt, kind = counters.k, consts.n_sub, consts.dt, consts.kind
    if damper is not None:
        command = action[:, 0]
        if kind == _SURROGATE:
            advance_semi_active(
                kind, state, z, zdot, k, n_sub, dt, command, params, lpr, damper, out, force, work
            )
        else:
            advance_semi_active(
                kind, state, z, zdot, k, n_sub, dt, command, params, None, damper, out, force, work
            )
        post_step(state, z, zdot, out, force, counters, result, consts)
        return
    for i in range(state.shape[0]):
        force[i] = action[i, 0] * consts.f_max
    # each variant's number as a constant, so that its kernel is compiled for it alone
    if kind == _LINEAR:
        advance_kind(_LINEAR, state, z, zdot, k, n_sub, dt, force, params, None, out, work)
    elif kind == _STATIC:
        advance_kind(_STATIC, state, z, zdot, k, n_sub, dt, force, params, None, out, work)
    elif kind == _DYNAMIC:
        advance_kind(_DYNAMIC, state, z, zdot, k, n_sub, dt, force, params, None, out, work)
    else:
        advance_kind(_SURROGATE, state, z, zdot, k, n_sub, dt, force, params, lpr, out, work)
    post_step(state, z, zdot, out, force, counters, result, consts)


class VerticalBatch(TrackBatch):
    """``n`` vertical vehicles, each on its own track, stepped by one compiled kernel call.

    Not a Gymnasium object: the batch of :mod:`railgym.envs.base` (its contract is there).
    It holds the arrays the kernels work on and computes observation, reward, its terms and
    the ``info`` quantities of :class:`VerticalSuspensionEnv`. ``envelope``: the operating
    envelope of the surrogate element (``None``: none, or not the surrogate backend), behind
    ``info["outside_envelope"]`` and the warning of the first episode outside it. ``damper``:
    the controllable damper of ``actuator="semi-active"`` (``None``: the actuator force).
    """

    REWARD_TERMS = REWARD_TERMS

    def __init__(
        self,
        n: int,
        cfg: TrackEnvParams,
        vehicle: VerticalVehicle,
        lpr: LprArrays,
        envelope: OperatingEnvelope | None = None,
        damper: DamperLaw | None = None,
    ) -> None:
        self.n, self.cfg = n, cfg
        self.vehicle = vehicle
        self.params: SuspensionParams = vehicle.kernel_params()
        self.params_record = self.params.record()
        self.lpr = lpr
        self.damper = damper
        semi_active = damper is not None
        self._info_keys = INFO_KEYS + (SEMI_ACTIVE_INFO_KEYS if semi_active else ())
        self._info_names = [key for key, _ in self._info_keys]
        #: samples of an episode's track, t_k = k·dt
        self.n_samples = cfg.n_steps * cfg.n_sub + 1
        self._track_storage(n)
        self._episodes(n)
        self.state = initial_state(cfg.variant, n, lpr, semi_active)
        self.work = scalar_work(self.state.shape[1], lpr)
        #: float64 (n, 1) the actions of the next step (the batch contract)
        self.actions = np.zeros((n, 1))
        self.force = np.zeros(n)
        self.out = step_outputs(n)
        ints = {k: np.zeros(n, np.int64) for k in ("k", "steps", "contacts", "ood")}
        sos = reward_sections(cfg.acc_weighting, cfg.control_dt)
        self.cnt = Counters(**ints, acc_sq=np.zeros(n), zi=np.zeros((n, sos.shape[0], 2)))
        self.envelope = envelope
        self._envelope_check = EnvelopeCheck(envelope, "VerticalSuspension")
        self.inv_scale = 1.0 / cfg.obs_scale
        w = cfg.reward_weights
        self.step_consts = consts(
            StepCfg,
            cfg,
            kind=check_variant(cfg.variant),
            w_acc=w["acceleration"],
            w_defl=w["deflection"],
            w_force=w["force"],
            sos=sos,
            inv_scale=self.inv_scale,
            flag_ood=lpr.mode == RAISE_MODE,
            full_obs=cfg.observation == "full",
            semi_active=semi_active,
        )
        self.res = StepResult(
            obs=np.zeros((n, len(cfg.obs_names))),
            reward=np.zeros(n),
            terms=np.zeros((n, len(REWARD_TERMS))),
            info=np.zeros((n, N_OUTCOME + len(self._info_keys))),
            truncated=np.zeros(n, np.bool_),
            extrapolated=np.zeros(n, np.bool_),
        )
        self._link()

    def _track_storage(self, n: int) -> None:
        """The track arrays of ``n`` vehicles: the whole episodes, or windows (chunked mode)."""
        cfg = self.cfg
        #: samples held per vehicle in chunked mode (None: the whole episode)
        self.window = track_window(
            n, self.n_samples, 0, cfg.n_sub + 1, "track arrays", _FORCED_WINDOW
        )
        held = self.n_samples if self.window is None else self.window
        #: the track samples held, ``base + 0 .. base + held - 1`` of each episode (m, m/s)
        self.z = np.zeros((n, held))
        self.zdot = np.zeros((n, held))
        #: int64 (n,) episode sample of the windows' first column (0 outside chunked mode)
        self.base = np.zeros(n, np.int64)

    def copy_track(self, src: VerticalBatch) -> None:
        """Vehicle 0's episode set to ``src``'s vehicle 0's (same grid needed), at rest at
        its start."""
        if src.z.shape != self.z.shape:
            raise ValueError(
                f"other env's track has {src.z.shape[1]} samples, this env needs {self.z.shape[1]}"
            )
        np.copyto(self.z, src.z)
        np.copyto(self.zdot, src.zdot)
        np.copyto(self.track_class, src.track_class)
        np.copyto(self.speed, src.speed)
        np.copyto(self.measured, src.measured)
        self.reset_state(0)

    def _link(self) -> None:
        """Short names of the arrays, the flags and the compiled entry point of
        :func:`control_step` (made again after a copy: it is not picklable)."""
        out, cnt, res = self.out, self.cnt, self.res
        self.acc, self.fs, self.count, self.div = out.acc, out.force, out.count, out.div
        self.k, self.steps, self.contacts, self.ood = cnt.k, cnt.steps, cnt.contacts, cnt.ood
        self.acc_sq, self.obs, self.rew, self.terms = cnt.acc_sq, res.obs, res.reward, res.terms
        self.info_rows, self.trunc, self.extrapolated = res.info, res.truncated, res.extrapolated
        self.reward, self._terms, self._truncated = self.rew, self.terms, self.trunc
        self._flags = {"diverged": self.div, "extrapolated": self.extrapolated}
        self._args = (
            self.state,
            self.z,
            self.zdot,
            self.actions,
            self.force,
            self.params_record,
            self.lpr,
            self.damper,
            self.out,
            self.cnt,
            self.res,
            self.step_consts,
            self.work,
        )
        self._step = compiled_entry(control_step, self._args)

    def _start(self, i: int, rng: np.random.Generator, episode: tuple[int, float, Any]) -> None:
        """Vehicle ``i``'s episode ``(track_class, speed, profile)``: a seeded FRA track (seed
        drawn from ``rng``) for ``profile=None``, else the given ``(x, z)`` (m) from its first
        point on."""
        self._set_episode(i, rng, *episode)

    def _track(self) -> tuple[np.ndarray, np.ndarray]:
        return self.z, self.zdot

    def _fill(self, i: int, start: int) -> None:
        """Chunked mode: vehicle ``i``'s window from episode sample ``start`` on (the
        episode's track drawn again, bit for bit the full arrays' values)."""
        cfg, held = self.cfg, self.z.shape[1]
        speed, profile = float(self.speed[i]), self._profiles[i]
        if profile is None:
            z, zdot = track_time_window(
                int(self.track_class[i]),
                speed,
                cfg.duration,
                cfg.dt,
                int(self._seeds[i]),
                start,
                held,
                band=cfg.band,
                wheelbase=cfg.wheelbase,
            )
        else:
            z, zdot = profile_time_input(profile, speed, cfg.dt, self.n_samples)
            z, zdot = z[start : start + held], zdot[start : start + held]
        self.z[i], self.zdot[i] = z, zdot
        self.base[i] = start

    def _cover_step(self) -> None:
        """Chunked mode: move the window of every vehicle that the next control step would
        run past (``k + n_sub`` beyond its last sample) to start at its current sample, or to
        end at the episode's last sample; ``k`` stays the index into the window."""
        held, n_sub = self.z.shape[1], self.cfg.n_sub
        late = np.flatnonzero((self.k + n_sub > held - 1) & (self.base < self.n_samples - held))

        def move(i: int) -> None:
            at = int(self.base[i] + self.k[i])
            start = min(at, self.n_samples - held)
            self._fill(i, start)
            self.k[i] = at - start

        draw_tracks(late, move)

    def _episode_track(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Vehicle ``i``'s whole episode track ``(z, zdot)`` (m, m/s) drawn from its seed or
        profile."""
        cfg = self.cfg
        if self._profiles[i] is not None:
            return profile_time_input(self._profiles[i], self.speed[i], cfg.dt, self.n_samples)
        _, z, zdot = track_time_input(
            int(self.track_class[i]),
            float(self.speed[i]),
            cfg.duration,
            cfg.dt,
            int(self._seeds[i]),
            band=cfg.band,
            wheelbase=cfg.wheelbase,
        )
        return z, zdot

    def reset_state(self, i: int) -> None:
        """Vehicle ``i`` at rest at the start of its track, counters cleared; its
        ``outside_envelope`` set for the episode (a ``UserWarning`` the first time)."""
        if self.window is not None and self.base[i] != 0:
            self._fill(i, 0)
        self.state[i] = 0.0
        self.k[i] = self.steps[i] = self.contacts[i] = self.ood[i] = 0
        self.acc[i] = self.force[i] = self.fs[i] = self.acc_sq[i] = self.rew[i] = 0.0
        self.terms[i] = self.info_rows[i] = self.cnt.zi[i] = 0.0
        self.div[i] = self.extrapolated[i] = self.trunc[i] = False
        self.info_rows[i, I_ENVELOPE] = self._outside_envelope(i)
        c = self.step_consts
        _observe(
            self.state,
            self.acc,
            self.z,
            self.zdot,
            self.k,
            self.inv_scale,
            i,
            self.obs,
            c.full_obs,
            c.semi_active,
        )

    def info(self, i: int | None = None) -> dict[str, Any]:
        """The :data:`INFO_KEYS` (with a damper also :data:`SEMI_ACTIVE_INFO_KEYS`) of vehicle
        ``i`` (Python numbers), or of all ((n,) arrays)."""
        if i is not None:  # the outcome's, less the step's reward terms and flags
            info = self.outcome(i)[3]
            for key in ("reward_terms", "diverged", "extrapolated"):
                info.pop(key, None)
            return info
        names = self._info_names
        cols = self.info_rows[:, N_OUTCOME:].T.copy()  # one copy; each key a contiguous row
        out = dict(zip(names, cols, strict=True))
        for j, kind in _CAST_INFO:
            out[names[j]] = cols[j].astype(_DTYPES[kind])
        return out

    def outcome(self, i: int) -> tuple[float, bool, bool, dict[str, Any]]:
        """``(reward, terminated, truncated, info)`` of vehicle ``i`` as the single env's step
        returns them (the batch contract), from one read of its row: ``info`` with the
        :data:`INFO_KEYS` (Python numbers; with a damper also :data:`SEMI_ACTIVE_INFO_KEYS`),
        ``reward_terms`` and each flag set this step (``diverged``, ``extrapolated``).

        The row is unpacked and ``info`` built as one literal: the single env's step does this
        once per step."""
        row = self.info_rows[i].tolist()
        damper = None
        if len(row) > _N_ROW:  # the damper's columns last
            damper = row[_N_ROW:]
            del row[_N_ROW:]
        (
            reward,
            acc,
            defl,
            force,
            div,
            diverged,
            extrapolated,
            truncated,
            t,
            carbody_acc,
            ood,
            contacts,
            outside,
            envelope,
            rms,
            actuator_force,
        ) = row
        info = {
            "time": t,
            "carbody_acc": carbody_acc,
            "out_of_domain": int(ood),
            "bump_stop_contacts": int(contacts),
            "outside_element": outside != 0.0,
            "outside_envelope": envelope != 0.0,
            "rms_carbody_acc": rms,
            "actuator_force": actuator_force,
        }
        if damper:
            info["damper_force"], info["damper_command"] = damper
        info["reward_terms"] = {
            "acceleration": acc,
            "deflection": defl,
            "force": force,
            "divergence": div,
        }
        terminated = False
        if diverged:
            info["diverged"] = terminated = True
        if extrapolated:
            info["extrapolated"] = terminated = True
        return reward, terminated, not terminated and truncated != 0.0, info

    def time(self) -> np.ndarray:
        """Simulated time of each vehicle, s."""
        return self.steps * self.cfg.control_dt

    def rms_acc(self) -> np.ndarray:
        """Running RMS carbody acceleration over the episode, m/s²."""
        return np.sqrt(self.acc_sq / np.maximum(self.steps, 1))

    def render_state(self, i: int) -> dict[str, Any]:
        """What :func:`railgym.envs.vertical.render.render_vertical` draws for vehicle ``i``
        (in chunked mode the track is drawn again for it)."""
        z = self.z[i] if self.window is None else self.track_arrays(i)[0]
        return self._render(i, z, min(int(self.base[i] + self.k[i]), z.shape[0] - 1))

    def _render(self, i: int, z: np.ndarray, kk: int) -> dict[str, Any]:
        """:meth:`render_state` of vehicle ``i`` on the track samples ``z`` (m), ``kk`` its
        current one."""
        dx = self.speed[i] * self.cfg.dt
        lo, hi = max(kk - int(10.0 / dx), 0), min(kk + int(10.0 / dx), z.shape[0] - 1)
        return {
            "x1": float(self.state[i, 0]),
            "x2": float(self.state[i, 2]),
            "z": float(z[kk]),
            "track_x": (np.arange(lo, hi + 1) - kk) * dx,
            "track_z": z[lo : hi + 1],
            "time": float(self.steps[i] * self.cfg.control_dt),
            "duration": self.cfg.duration,
            "force_a": float(self.force[i]),
            "f_max": self.cfg.f_max,
            "speed": float(self.speed[i]),
            "carbody_acc": float(self.acc[i, 1]),
        }
