"""The batch of :mod:`railgym.envs.vertical`: ``n`` vertical vehicles stepped by one kernel call.

:class:`VerticalBatch` implements the batch contract of :mod:`railgym.envs.base`: it holds the
arrays the kernels of :mod:`railgym.vehicles.vertical` work on, and a compiled post-step turns
each kernel call into observation, reward, reward terms and the ``info`` values, whose layout
is declared once (:data:`INFO_KEYS`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from railgym import _validation as val
from railgym.profile import profile_time_input
from railgym.track import track_time_input
from railgym.vehicles.vertical import (
    KERNELS,
    RAISE_MODE,
    LprArrays,
    SuspensionParams,
    VerticalVehicle,
    initial_state,
    step_outputs,
)

__all__ = [
    "ACC_REF",
    "INFO_KEYS",
    "LIMITS",
    "REWARD_TERMS",
    "VerticalBatch",
    "VerticalConfig",
]

#: reference carbody acceleration of the reward, m/s²: passive RMS on the training case
#: (class 5, 144 km/h, dynamic reference), so that a passive step's reward is about −1
ACC_REF = 0.75
DIVERGENCE_PENALTY = 100.0
#: |normalised observation| above this counts as divergence (keeps float32 observations finite)
OBS_LIMIT = 1e30
#: documented argument limits (docs/envs/vertical.md)
LIMITS = {
    "speed_factor": 2.0,  # speed <= this × the class's maximum speed unless speed_limit= is given
    "duration": 600.0,  # s
    "f_max": 1e6,  # N
    "sensor_noise": 10.0,  # std on the normalised observation
    "reward_weight": 1e6,
    "wheelbase": 50.0,  # m
    "band": (0.1, 1000.0),  # shortest and longest wavelength, m
    "num_envs": 65536,
    "track_bytes": 2**30,  # track arrays of all sub-envs, bytes
}


@dataclass(frozen=True)
class VerticalConfig:
    """Validated settings shared by the single and the vector env (SI units)."""

    variant: str
    dt: float
    n_sub: int
    n_steps: int
    control_dt: float
    duration: float
    f_max: float
    free_travel: float
    obs_names: tuple[str, ...]
    obs_scale: np.ndarray
    weights: tuple[float, float, float]
    sensor_noise: float
    wheelbase: float | None
    band: tuple[float, float]


class Counters(NamedTuple):
    """Per-vehicle episode counters updated by :func:`_post_step`."""

    k: np.ndarray  #: int64 (n,) current track sample
    steps: np.ndarray  #: int64 (n,) control steps this episode
    contacts: np.ndarray  #: int64 (n,) substeps in bump-stop contact
    ood: np.ndarray  #: int64 (n,) out-of-domain surrogate evaluations
    acc_sq: np.ndarray  #: float64 (n,) sum of ẍ2², m²/s⁴


class StepSpec(NamedTuple):
    """Reward weights and normalisers and the control step (SI); the post-step takes it as
    a structured record array (:meth:`record`), read by field name."""

    w_acc: float
    w_defl: float
    w_force: float
    acc_ref: float  #: m/s²
    free_travel: float  #: m
    f_max: float  #: N
    penalty: float  #: reward of a diverged step (negated)
    control_dt: float  #: s

    def record(self) -> np.ndarray:
        """The values as a structured float64 array (1,) with these field names."""
        return np.array([tuple(self)], [(name, np.float64) for name in self._fields])


class StepResult(NamedTuple):
    """Outputs of :func:`_post_step` per vehicle: observation (n, n_obs), reward (n,), its
    terms (n, len(REWARD_TERMS)) and the info values (n, len(INFO_KEYS))."""

    obs: np.ndarray
    reward: np.ndarray
    terms: np.ndarray
    info: np.ndarray


#: the ``info`` layout of the single and the vector env, declared once: key, integer-valued
INFO_KEYS = (
    ("time", False),  # s
    ("carbody_acc", False),  # m/s²
    ("out_of_domain", True),
    ("bump_stop_contacts", True),
    ("rms_carbody_acc", False),  # m/s²
    ("actuator_force", False),  # N
)
_INFO = [key for key, _ in INFO_KEYS]
I_TIME, I_ACC, I_OOD, I_CONTACTS, I_RMS, I_FORCE = (
    _INFO.index(k)
    for k in (
        "time",
        "carbody_acc",
        "out_of_domain",
        "bump_stop_contacts",
        "rms_carbody_acc",
        "actuator_force",
    )
)
_INT_INFO = tuple(j for j, (_, is_int) in enumerate(INFO_KEYS) if is_int)

#: columns of :attr:`StepResult.terms`, the keys of ``info["reward_terms"]``
REWARD_TERMS = ("acceleration", "deflection", "force", "divergence")


@njit(cache=True)
def _observe(state, acc, z, zdot, k, s, i, obs):
    """Normalised observation of vehicle ``i`` into ``obs[i]``; ``s`` is 1/scale per channel,
    8 channels mean the ``"full"`` observation."""
    if obs.shape[1] == 8:
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
def _post_step(state, z, zdot, out, force, n_sub, cnt, inv_scale, spec, res):
    """Bookkeeping after a kernel call: counters, observation, reward and its terms.

    A step whose reward is not finite or whose observation exceeds ``OBS_LIMIT`` counts as
    diverged (``out.div``), like a non-finite state in the kernel.
    """
    rw = spec[0]
    for i in range(state.shape[0]):
        cnt.k[i] += n_sub
        cnt.steps[i] += 1
        cnt.contacts[i] += out.count[i, 0]
        cnt.ood[i] += out.count[i, 1]
        cnt.acc_sq[i] += out.acc[i, 1] * out.acc[i, 1]
        _observe(state, out.acc, z, zdot, cnt.k, inv_scale, i, res.obs)
        defl = (state[i, 0] - state[i, 2]) / rw.free_travel
        fa = force[i] / rw.f_max
        a2 = out.acc[i, 1] / rw.acc_ref
        t_a = -(rw.w_acc * a2 * a2)
        t_d = -(rw.w_defl * defl * defl)
        t_f = -(rw.w_force * fa * fa)
        r = t_a + t_d + t_f
        big = False
        for j in range(res.obs.shape[1]):
            if not abs(res.obs[i, j]) <= OBS_LIMIT:
                big = True
        if out.div[i] or big or not math.isfinite(r):
            out.div[i] = True
            for j in range(res.obs.shape[1]):
                res.obs[i, j] = min(max(res.obs[i, j], -OBS_LIMIT), OBS_LIMIT)
            t_a = t_d = t_f = 0.0
            r = -rw.penalty
        res.terms[i, 0] = t_a
        res.terms[i, 1] = t_d
        res.terms[i, 2] = t_f
        res.terms[i, 3] = -rw.penalty if out.div[i] else 0.0
        res.reward[i] = r
        res.info[i, I_TIME] = cnt.steps[i] * rw.control_dt
        res.info[i, I_ACC] = out.acc[i, 1]
        res.info[i, I_OOD] = cnt.ood[i]
        res.info[i, I_CONTACTS] = cnt.contacts[i]
        res.info[i, I_RMS] = math.sqrt(cnt.acc_sq[i] / max(cnt.steps[i], 1))
        res.info[i, I_FORCE] = force[i]


class VerticalBatch:
    """``n`` vertical vehicles, each on its own track, stepped by one compiled kernel call.

    Not a Gymnasium object: the batch of :mod:`railgym.envs.base` (its contract is there).
    It holds the arrays the kernels work on and computes observation, reward, its terms and
    the ``info`` quantities of :class:`VerticalSuspensionEnv`.
    """

    def __init__(
        self, n: int, cfg: VerticalConfig, vehicle: VerticalVehicle, lpr: LprArrays
    ) -> None:
        self.n, self.cfg = n, cfg
        self.vehicle = vehicle
        self.params: SuspensionParams = vehicle.kernel_params()
        self.params_record = self.params.record()
        self.kernel = KERNELS[cfg.variant]
        self.lpr = lpr
        n_samples = cfg.n_steps * cfg.n_sub + 1
        if n * n_samples * 16 > LIMITS["track_bytes"]:
            raise val.FieldError(
                "num_envs",
                f"× duration/dt needs {n * n_samples * 16 / 2**30:.1f} GiB of track arrays "
                f"(num_envs={n}, {n_samples} samples each); the limit is "
                f"{LIMITS['track_bytes'] / 2**30:g} GiB",
            )
        self.z = np.zeros((n, n_samples))
        self.zdot = np.zeros((n, n_samples))
        self.state = initial_state(cfg.variant, n, lpr)
        self.force = np.zeros(n)
        self.out = step_outputs(n)
        self.acc, self.fs, self.count, self.div = self.out
        self.cnt = Counters(
            np.zeros(n, np.int64),
            np.zeros(n, np.int64),
            np.zeros(n, np.int64),
            np.zeros(n, np.int64),
            np.zeros(n),
        )
        self.k, self.steps, self.contacts, self.ood, self.acc_sq = self.cnt
        self.track_class = np.zeros(n, np.int64)
        self.speed = np.zeros(n)
        self.inv_scale = 1.0 / cfg.obs_scale
        w = cfg.weights
        self.step_spec = StepSpec(
            w[0],
            w[1],
            w[2],
            ACC_REF,
            cfg.free_travel,
            cfg.f_max,
            DIVERGENCE_PENALTY,
            cfg.control_dt,
        )
        self.step_record = self.step_spec.record()
        self.res = StepResult(
            np.zeros((n, len(cfg.obs_names))),
            np.zeros(n),
            np.zeros((n, len(REWARD_TERMS))),
            np.zeros((n, len(INFO_KEYS))),
        )
        self.obs, self.rew, self.terms, self.info_rows = self.res
        self.reward = self.rew
        self.extrapolated = np.zeros(n, np.bool_)
        self._flags = {"diverged": self.div, "extrapolated": self.extrapolated}

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Re-link the views (named tuples, column views) after a copy."""
        self.__dict__.update(state)
        self.acc, self.fs, self.count, self.div = self.out
        self.k, self.steps, self.contacts, self.ood, self.acc_sq = self.cnt
        self.obs, self.rew, self.terms, self.info_rows = self.res
        self.reward = self.rew
        self._flags = {"diverged": self.div, "extrapolated": self.extrapolated}

    def reset(self, i: int, rng: np.random.Generator, episode: tuple[int, float, Any]) -> None:
        """New track for vehicle ``i``, state at rest; ``episode`` is ``(track_class, speed,
        profile)``: a seeded FRA track (seed drawn from ``rng``) for ``profile=None``, else
        the given ``(x, z)`` (m) from its first point on."""
        cfg = self.cfg
        track_class, speed, profile = episode
        if profile is None:
            seed = int(rng.integers(2**63 - 1))
            _, z, zdot = track_time_input(
                track_class,
                speed,
                cfg.duration,
                cfg.dt,
                seed,
                band=cfg.band,
                wheelbase=cfg.wheelbase,
            )
        else:
            z, zdot = profile_time_input(profile, speed, cfg.dt, self.z.shape[1])
        self.z[i], self.zdot[i] = z, zdot
        self.track_class[i], self.speed[i] = track_class, speed
        self.reset_state(i)

    def reset_state(self, i: int) -> None:
        """Vehicle ``i`` at rest at the start of its track, counters cleared."""
        self.state[i] = 0.0
        self.k[i] = self.steps[i] = self.contacts[i] = self.ood[i] = 0
        self.acc[i] = self.force[i] = self.fs[i] = self.acc_sq[i] = self.rew[i] = 0.0
        self.terms[i] = self.info_rows[i] = 0.0
        self.div[i] = self.extrapolated[i] = False
        _observe(self.state, self.acc, self.z, self.zdot, self.k, self.inv_scale, i, self.obs)

    def set_action(self, actions: np.ndarray) -> None:
        """Actuator forces from the clipped actions (n, 1): ``action · f_max``, N."""
        np.multiply(actions[:, 0], self.cfg.f_max, out=self.force)

    def advance(self) -> None:
        """One control step of every vehicle with the actuator forces in ``self.force``, N."""
        cfg = self.cfg
        self.kernel(
            self.state,
            self.z,
            self.zdot,
            self.k,
            cfg.n_sub,
            cfg.dt,
            self.force,
            self.params_record,
            self.lpr,
            self.out,
        )
        _post_step(
            self.state,
            self.z,
            self.zdot,
            self.out,
            self.force,
            cfg.n_sub,
            self.cnt,
            self.inv_scale,
            self.step_record,
            self.res,
        )
        if self.lpr.mode == RAISE_MODE:
            np.greater(self.count[:, 1], 0, out=self.extrapolated)

    def flags(self) -> dict[str, np.ndarray]:
        """Events that end the episode: ``diverged``; ``extrapolated`` (surrogate input out of
        its box under the ``"raise"`` extrapolation policy)."""
        return self._flags

    def truncated(self) -> np.ndarray:
        """True where the episode reached ``duration``."""
        return self.steps >= self.cfg.n_steps

    def info(self, i: int | None = None) -> dict[str, Any]:
        """The :data:`INFO_KEYS` of vehicle ``i`` (Python numbers), or of all ((n,) arrays)."""
        if i is not None:
            row = self.info_rows[i].tolist()
            for j in _INT_INFO:
                row[j] = int(row[j])
            return dict(zip(_INFO, row, strict=True))
        out = {key: self.info_rows[:, j].copy() for j, key in enumerate(_INFO)}
        for j in _INT_INFO:
            out[_INFO[j]] = out[_INFO[j]].astype(np.int64)
        return out

    def reward_terms(self, i: int | None = None) -> dict[str, Any]:
        """Weighted reward terms of vehicle ``i`` (floats) or of all ((n,) arrays); they sum to
        the reward."""
        if i is not None:
            return dict(zip(REWARD_TERMS, self.terms[i].tolist(), strict=True))
        return {key: self.terms[:, j].copy() for j, key in enumerate(REWARD_TERMS)}

    def observe(self, rngs: list[np.random.Generator]) -> np.ndarray:
        """Observations (n, n_obs) float32, plus sensor noise drawn from the per-env ``rngs``."""
        if self.cfg.sensor_noise > 0:
            noise = np.stack([g.standard_normal(self.obs.shape[1]) for g in rngs])
            return (self.obs + self.cfg.sensor_noise * noise).astype(np.float32)
        return self.obs.astype(np.float32)

    def time(self) -> np.ndarray:
        """Simulated time of each vehicle, s."""
        return self.steps * self.cfg.control_dt

    def rms_acc(self) -> np.ndarray:
        """Running RMS carbody acceleration over the episode, m/s²."""
        return np.sqrt(self.acc_sq / np.maximum(self.steps, 1))

    def render_state(self, i: int) -> dict[str, Any]:
        """What :func:`railgym.envs.rendering.render_vertical` draws for vehicle ``i``."""
        kk = min(int(self.k[i]), self.z.shape[1] - 1)
        dx = self.speed[i] * self.cfg.dt
        lo, hi = max(kk - int(10.0 / dx), 0), min(kk + int(10.0 / dx), self.z.shape[1] - 1)
        return {
            "x1": float(self.state[i, 0]),
            "x2": float(self.state[i, 2]),
            "z": float(self.z[i, kk]),
            "track_x": (np.arange(lo, hi + 1) - kk) * dx,
            "track_z": self.z[i, lo : hi + 1],
            "time": float(self.steps[i] * self.cfg.control_dt),
            "duration": self.cfg.duration,
            "force_a": float(self.force[i]),
            "f_max": self.cfg.f_max,
        }
