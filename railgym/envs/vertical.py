"""``railgym/VerticalSuspension-v0``: active secondary suspension on random FRA track.

A bogie (m1) and its share of the carbody (m2) ride on the primary suspension over a
seeded FRA track profile (paper eq. 1/2); the secondary suspension is either a surrogate
element F̂(δ, δ̇) (``backend="surrogate"``, paper eq. 2), the high-fidelity reference
(``"reference"``: air spring with reservoir + Maxwell damper + bump stops) or the linear
suspension (``"linear"``). The agent commands an actuator force between bogie and carbody.
See ``docs/envs/vertical.md`` for the tables of observation, action, reward and ``info``.

The physics is in :mod:`railgym.vehicles.vertical` (numba RK4 kernels); the single env
and the native vector env are thin shells around :class:`VerticalBatch`, which steps any
number of vehicles, each on its own track, in one compiled call.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numba import njit

from railgym.envs.vector import reset_plan
from railgym.track import class_parameters, class_speed, track_time_input
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.vertical import (
    DEFAULT_DT,
    KERNELS,
    VerticalVehicle,
    initial_state,
    load_vehicle,
    surrogate_arrays,
)
from surrogates import io

BACKENDS = {"surrogate": "surrogate", "reference": "dynamic", "linear": "linear"}
OBSERVATIONS = {
    # name: (channels, scale of each channel in SI units)
    "sensors": (("carbody_acc", "bogie_acc", "deflection", "deflection_rate", "carbody_vel"),
                (1.0, 10.0, None, 0.1, 0.1)),
    "full": (("x1", "v1", "x2", "v2", "bogie_acc", "carbody_acc", "z", "zdot"),
             (0.01, 0.1, 0.01, 0.1, 10.0, 1.0, 0.01, 0.1)),
}  # fmt: skip
#: reference carbody acceleration of the reward, m/s²: passive RMS on the training case
#: (class 5, 144 km/h, dynamic reference), so that a passive step's reward is about −1
ACC_REF = 0.75
DEFAULT_WEIGHTS = {"acceleration": 1.0, "deflection": 1.0, "force": 0.1}
DIVERGENCE_PENALTY = 100.0


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


def make_config(
    backend: str,
    duration: float,
    control_dt: float,
    dt: float | None,
    f_max: float,
    observation: str,
    sensor_noise: float,
    reward_weights: dict[str, float] | None,
    wheelbase: float | None,
    band: tuple[float, float],
    free_travel: float,
) -> VerticalConfig:
    """Check the env arguments; every error names the argument."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {sorted(BACKENDS)}, got {backend!r}")
    variant = BACKENDS[backend]
    for name, value in (("duration", duration), ("control_dt", control_dt), ("f_max", f_max)):
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number, got {value!r}")
    dt = DEFAULT_DT[variant] if dt is None else float(dt)
    if not (np.isfinite(dt) and 0 < dt <= control_dt):
        raise ValueError(f"dt must be positive and at most control_dt, got {dt!r}")
    n_sub = round(control_dt / dt)
    if abs(n_sub * dt - control_dt) > 1e-9 * control_dt:
        raise ValueError(f"control_dt ({control_dt} s) must be a whole multiple of dt ({dt} s)")
    n_steps = round(duration / control_dt)
    if n_steps < 1 or abs(n_steps * control_dt - duration) > 1e-9 * duration:
        raise ValueError(f"duration ({duration} s) must be a whole multiple of control_dt")
    if observation not in OBSERVATIONS:
        raise ValueError(f"observation must be one of {sorted(OBSERVATIONS)}, got {observation!r}")
    if not (np.isfinite(sensor_noise) and sensor_noise >= 0):
        raise ValueError(f"sensor_noise must be a non-negative number, got {sensor_noise!r}")
    weights = dict(DEFAULT_WEIGHTS)
    for key, value in (reward_weights or {}).items():
        if key not in DEFAULT_WEIGHTS:
            raise ValueError(f"reward_weights has unknown key {key!r}; keys: {list(weights)}")
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"reward_weights[{key!r}] must be a non-negative number")
        weights[key] = float(value)
    names, scales = OBSERVATIONS[observation]
    scale = np.array([free_travel if s is None else s for s in scales])
    return VerticalConfig(
        variant=variant, dt=dt, n_sub=n_sub, n_steps=n_steps, control_dt=float(control_dt),
        duration=float(duration), f_max=float(f_max), free_travel=free_travel,
        obs_names=names, obs_scale=scale,
        weights=(weights["acceleration"], weights["deflection"], weights["force"]),
        sensor_noise=float(sensor_noise), wheelbase=wheelbase, band=tuple(band),
    )  # fmt: skip


def _surrogate_arrays(backend: str, surrogate: Any) -> tuple:
    """Kernel arrays of the surrogate element: packaged default, a JSON path or a model."""
    if backend != "surrogate":
        return surrogate_arrays(None)
    if surrogate is None:
        surrogate = default_vertical_surrogate()
    elif isinstance(surrogate, (str, Path)):
        surrogate = io.load(surrogate)
    if not hasattr(surrogate, "kernel_arrays"):
        raise ValueError(
            "surrogate must be a Legendre regression (it runs inside the compiled kernel); "
            f"got {type(surrogate).__name__}"
        )
    return surrogate_arrays(surrogate)


@njit(cache=True)
def _post_step(state, acc, force, div, count, z, zdot, k, steps, contacts, ood, acc_sq,
               n_sub, full, inv_scale, weights, free_travel, f_max, obs, reward):  # fmt: skip
    """Bookkeeping after a kernel call: counters, observation (n, n_obs) and reward (n,)."""
    w_a, w_d, w_f = weights[0], weights[1], weights[2]
    last = z.shape[1] - 1
    for i in range(state.shape[0]):
        k[i] += n_sub
        steps[i] += 1
        contacts[i] += count[i, 0]
        ood[i] += count[i, 1]
        acc_sq[i] += acc[i, 1] * acc[i, 1]
        _observe(state, acc, z, zdot, k, full, inv_scale, last, i, obs)
        defl = (state[i, 0] - state[i, 2]) / free_travel
        fa = force[i] / f_max
        a2 = acc[i, 1] / ACC_REF
        reward[i] = -(w_a * a2 * a2 + w_d * defl * defl + w_f * fa * fa)
        if div[i]:
            reward[i] = -DIVERGENCE_PENALTY


@njit(cache=True)
def _observe(state, acc, z, zdot, k, full, inv_scale, last, i, obs):
    """Normalised observation of vehicle ``i`` into ``obs[i]``."""
    if full:
        kk = min(k[i], last)
        raw = (state[i, 0], state[i, 1], state[i, 2], state[i, 3], acc[i, 0], acc[i, 1],
               z[i, kk], zdot[i, kk])  # fmt: skip
        for j in range(8):
            obs[i, j] = raw[j] * inv_scale[j]
    else:
        obs[i, 0] = acc[i, 1] * inv_scale[0]
        obs[i, 1] = acc[i, 0] * inv_scale[1]
        obs[i, 2] = (state[i, 0] - state[i, 2]) * inv_scale[2]
        obs[i, 3] = (state[i, 1] - state[i, 3]) * inv_scale[3]
        obs[i, 4] = state[i, 3] * inv_scale[4]


def _check_track(track_class: Any, speed: Any) -> tuple[int, float]:
    class_parameters(track_class)  # raises ValueError naming track_class
    v = class_speed(track_class) if speed is None else speed
    if not (isinstance(v, (int, float, np.floating)) and np.isfinite(v) and v > 0):
        raise ValueError(f"speed must be a positive number in m/s, got {speed!r}")
    return int(track_class), float(v)


class VerticalBatch:
    """``n`` vertical vehicles, each on its own track, stepped by one compiled kernel call.

    Not a Gymnasium object: it holds the arrays the kernels work on and computes the
    observation, reward and ``info`` quantities of :class:`VerticalSuspensionEnv`.
    """

    def __init__(self, n: int, cfg: VerticalConfig, vehicle: VerticalVehicle, lpr: tuple) -> None:
        self.n, self.cfg = n, cfg
        self.vehicle = vehicle
        self.params = vehicle.kernel_params()
        self.kernel = KERNELS[cfg.variant]
        self.lpr = lpr
        n_samples = cfg.n_steps * cfg.n_sub + 1
        self.z = np.zeros((n, n_samples))
        self.zdot = np.zeros((n, n_samples))
        self.state = initial_state(cfg.variant, n)
        self.k = np.zeros(n, np.int64)
        self.steps = np.zeros(n, np.int64)
        self.force = np.zeros(n)
        self.acc = np.zeros((n, 2))
        self.fs = np.zeros(n)
        self.count = np.zeros((n, 2), np.int64)
        self.div = np.zeros(n, np.bool_)
        self.contacts = np.zeros(n, np.int64)
        self.ood = np.zeros(n, np.int64)
        self.acc_sq = np.zeros(n)
        self.track_class = np.zeros(n, np.int64)
        self.speed = np.zeros(n)
        self.inv_scale = 1.0 / cfg.obs_scale
        self.full = cfg.obs_names[0] == "x1"
        self.weights = np.array(cfg.weights)
        self.obs = np.zeros((n, len(cfg.obs_names)))
        self.rew = np.zeros(n)

    def reset(self, i: int, rng: np.random.Generator, track_class: int, speed: float) -> None:
        """New seeded track for vehicle ``i`` (seed drawn from ``rng``), state at rest."""
        cfg = self.cfg
        seed = int(rng.integers(2**63 - 1))
        _, z, zdot = track_time_input(
            track_class, speed, cfg.duration, cfg.dt, seed, band=cfg.band, wheelbase=cfg.wheelbase
        )
        self.z[i], self.zdot[i] = z, zdot
        self.track_class[i], self.speed[i] = track_class, speed
        self.reset_state(i)

    def reset_state(self, i: int) -> None:
        """Vehicle ``i`` at rest at the start of its track, counters cleared."""
        self.state[i] = 0.0
        self.k[i] = self.steps[i] = self.contacts[i] = self.ood[i] = 0
        self.acc[i] = self.force[i] = self.fs[i] = self.acc_sq[i] = self.rew[i] = 0.0
        self.div[i] = False
        _observe(self.state, self.acc, self.z, self.zdot, self.k, self.full, self.inv_scale,
                 self.z.shape[1] - 1, i, self.obs)  # fmt: skip

    def advance(self) -> None:
        """One control step of every vehicle with the actuator forces in ``self.force``, N;
        updates ``obs`` and ``rew``."""
        cfg = self.cfg
        self.kernel(self.state, self.z, self.zdot, self.k, cfg.n_sub, cfg.dt, self.force,
                    self.params, *self.lpr, self.acc, self.fs, self.count, self.div)  # fmt: skip
        _post_step(self.state, self.acc, self.force, self.div, self.count, self.z, self.zdot,
                   self.k, self.steps, self.contacts, self.ood, self.acc_sq, cfg.n_sub,
                   self.full, self.inv_scale, self.weights, cfg.free_travel, cfg.f_max,
                   self.obs, self.rew)  # fmt: skip

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
            "x1": float(self.state[i, 0]), "x2": float(self.state[i, 2]),
            "z": float(self.z[i, kk]), "track_x": (np.arange(lo, hi + 1) - kk) * dx,
            "track_z": self.z[i, lo : hi + 1], "time": float(self.steps[i] * self.cfg.control_dt),
            "duration": self.cfg.duration, "force_a": float(self.force[i]), "f_max": self.cfg.f_max,
        }  # fmt: skip


class VerticalSuspensionEnv(gym.Env[np.ndarray, np.ndarray]):
    """Active secondary suspension of a railway vehicle on random FRA track.

    Parameters
    ----------
    backend : ``"surrogate"`` (default, paper eq. 2), ``"reference"`` or ``"linear"``.
    surrogate : LPR model, path of a model JSON, or ``None`` for the packaged element.
    track_class : FRA class 1–6 (default 5, the paper's training case).
    speed : m/s; ``None`` = the class's maximum passenger speed (class 5: 144 km/h).
    duration : episode length, s (truncation). control_dt : agent step, s.
    dt : integration step, s (default the kernel's ``DEFAULT_DT``).
    f_max : actuator force at action ±1, N.
    observation : ``"sensors"`` or ``"full"``. sensor_noise : std of the additive noise on
        the normalised observation. reward_weights : ``acceleration``, ``deflection``,
        ``force`` weights. wheelbase : m, average two delayed wheel inputs (default off).
    band : wavelength band of the track irregularity, m. vehicle : vehicle YAML name/path.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(
        self,
        backend: str = "surrogate",
        surrogate: Any = None,
        track_class: int = 5,
        speed: float | None = None,
        duration: float = 20.0,
        control_dt: float = 0.01,
        dt: float | None = None,
        f_max: float = 8000.0,
        observation: str = "sensors",
        sensor_noise: float = 0.0,
        reward_weights: dict[str, float] | None = None,
        wheelbase: float | None = None,
        band: tuple[float, float] = (1.0, 100.0),
        vehicle: str = "manchester",
        render_mode: str | None = None,
    ) -> None:
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        veh = load_vehicle(vehicle)
        self.cfg = make_config(backend, duration, control_dt, dt, f_max, observation,
                               sensor_noise, reward_weights, wheelbase, band,
                               veh.bump_stop.free_travel_compression)  # fmt: skip
        self.backend = backend
        self.track_class, self.speed = _check_track(track_class, speed)
        self._speed_arg = speed
        self.sim = VerticalBatch(1, self.cfg, veh, _surrogate_arrays(backend, surrogate))
        self.render_mode = render_mode
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        n_obs = len(self.obs_names)
        self.observation_space = spaces.Box(-np.inf, np.inf, (n_obs,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
        self._started = False

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """New track; ``options`` may set ``track_class`` and ``speed`` (kept for later
        episodes; a new class without a speed uses that class's speed)."""
        super().reset(seed=seed)
        if options:
            unknown = set(options) - {"track_class", "speed"}
            if unknown:
                raise ValueError(f"unknown reset option(s) {sorted(unknown)}")
            tc = options.get("track_class", self.track_class)
            sp = options.get("speed", self._speed_arg if "track_class" not in options else None)
            self.track_class, self.speed = _check_track(tc, sp)
            self._speed_arg = options.get("speed", self._speed_arg)
        self.sim.reset(0, self.np_random, self.track_class, self.speed)
        self._rng1 = [self.np_random]
        self._started = True
        return self.sim.observe(self._rng1)[0], self._info()

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Advance ``control_dt``; the action is clipped to [−1, 1], non-finite raises."""
        if not self._started:
            raise RuntimeError("call reset() before step()")
        sim = self.sim
        a = np.asarray(action, dtype=np.float64)
        if a.shape != (1,):
            raise ValueError(f"action must have shape (1,), got {a.shape}")
        u = float(a[0])
        if not math.isfinite(u):
            raise ValueError(f"action must be finite, got {action!r}")
        sim.force[0] = min(max(u, -1.0), 1.0) * self.cfg.f_max
        sim.advance()
        diverged = bool(sim.div[0])
        truncated = bool(sim.steps[0] >= self.cfg.n_steps) and not diverged
        if diverged or truncated:
            self._started = False
        info = self._info()
        if diverged:
            info["diverged"] = True
        return sim.observe(self._rng1)[0], float(sim.rew[0]), diverged, truncated, info

    def _info(self) -> dict[str, Any]:
        sim = self.sim
        return {
            "time": float(sim.steps[0] * self.cfg.control_dt),
            "carbody_acc": float(sim.acc[0, 1]),
            "out_of_domain": int(sim.ood[0]),
            "bump_stop_contacts": int(sim.contacts[0]),
            "rms_carbody_acc": float(np.sqrt(sim.acc_sq[0] / max(sim.steps[0], 1))),
            "actuator_force": float(sim.force[0]),
        }

    def render(self) -> np.ndarray | None:
        """RGB frame (H, W, 3) of the schematic when ``render_mode="rgb_array"``."""
        if self.render_mode is None:
            gym.logger.warn("render() called without render_mode; use render_mode='rgb_array'")
            return None
        from railgym.envs.rendering import render_vertical

        return render_vertical(self.sim.render_state(0))


class VerticalSuspensionVectorEnv(VectorEnv):
    """Native vector version: all sub-envs stepped in one compiled kernel call.

    Sub-env ``i`` of ``reset(seed=s)`` reproduces ``VerticalSuspensionEnv.reset(seed=s + i)``
    step for step. Autoreset mode: next step (gymnasium's default).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50,
                "autoreset_mode": AutoresetMode.NEXT_STEP}  # fmt: skip

    def __init__(self, num_envs: int = 1, render_mode: str | None = None, **kwargs: Any) -> None:
        if not (isinstance(num_envs, (int, np.integer)) and num_envs >= 1):
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        self.single_env = VerticalSuspensionEnv(render_mode=render_mode, **kwargs)
        self.num_envs = int(num_envs)
        self.render_mode = render_mode
        self.cfg = self.single_env.cfg
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        single = self.single_env.sim
        self.sim = VerticalBatch(self.num_envs, self.cfg, single.vehicle, single.lpr)
        self.single_observation_space = self.single_env.observation_space
        self.single_action_space = self.single_env.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._rngs: list[np.random.Generator | None] = []
        self._prev_done = np.zeros(self.num_envs, np.bool_)

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the sub-envs; sub-env ``i`` is seeded with ``seed + i`` (or ``seed[i]``).

        ``options["reset_mask"]`` (bool array (num_envs,)) resets only those sub-envs
        (gymnasium's partial reset); a sub-env reset without a seed keeps its generator.
        """
        if seed is not None:
            first = seed if isinstance(seed, (int, np.integer)) else seed[0]
            self._np_random, self._np_random_seed = seeding.np_random(first)
        mask, self._rngs, options = reset_plan(self.num_envs, seed, options, self._rngs)
        env = self.single_env
        if options:
            env.reset(options=options)  # validates and stores track_class / speed
        for i in np.flatnonzero(mask):
            self.sim.reset(i, self._rngs[i], env.track_class, env.speed)
        self._prev_done[mask] = False
        return self.sim.observe(self._rngs), self._infos()

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step all sub-envs; those that ended on the previous step are reset instead."""
        if not self._rngs:
            raise RuntimeError("call reset() before step()")
        sim, env = self.sim, self.single_env
        a = np.asarray(actions, dtype=np.float64)
        if a.shape != (self.num_envs, 1):
            raise ValueError(f"actions must have shape ({self.num_envs}, 1), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError("actions must be finite; got NaN or Inf")
        np.multiply(np.clip(a[:, 0], -1.0, 1.0), self.cfg.f_max, out=sim.force)
        done = np.flatnonzero(self._prev_done)
        for i in done:
            sim.reset(i, self._rngs[i], env.track_class, env.speed)
        sim.advance()
        for i in done:  # sub-envs that were reset do not move on this step
            sim.reset_state(i)
        terminated = sim.div.copy()
        truncated = (sim.steps >= self.cfg.n_steps) & ~terminated
        reward = sim.rew.copy()
        terminated[done] = truncated[done] = False
        self._prev_done = terminated | truncated
        infos = self._infos()
        infos["diverged"] = terminated.copy()
        infos["_diverged"] = np.ones(self.num_envs, np.bool_)
        return sim.observe(self._rngs), reward, terminated, truncated, infos

    def _infos(self) -> dict[str, Any]:
        sim = self.sim
        infos = {
            "time": sim.time(),
            "carbody_acc": sim.acc[:, 1].copy(),
            "out_of_domain": sim.ood.copy(),
            "bump_stop_contacts": sim.contacts.copy(),
            "rms_carbody_acc": sim.rms_acc(),
            "actuator_force": sim.force.copy(),
        }
        mask = np.ones(self.num_envs, np.bool_)
        return {**infos, **{f"_{k}": mask for k in infos}}

    def render(self) -> tuple[np.ndarray, ...] | None:
        """One RGB frame per sub-env."""
        if self.render_mode is None:
            gym.logger.warn("render() called without render_mode; use render_mode='rgb_array'")
            return None
        from railgym.envs.rendering import render_vertical

        return tuple(render_vertical(self.sim.render_state(i)) for i in range(self.num_envs))
