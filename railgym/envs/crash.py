"""``railgym/TrainCrash-v0``: adaptive crash energy management of a train hitting a wall.

A lead car and ``n_cars − 1`` passenger cars run into a rigid wall (or a free deformable
obstacle) from the scenario's speed (default: the paper's table 9 case, 40 km/h). Every crush
zone — the lead car's front end at the wall and each interface between two cars — holds a
controllable absorber: the agent sets the force level of each absorber between 0.7 and 1.3
times nominal (rate-limited), trading the cars' decelerations against crush beyond the
absorbers' stroke, i.e. loss of survival space. Action 0 everywhere is the passive train.

The physics is in :mod:`railgym.vehicles.crash`: ``backend="reference"`` is the lumped-mass
chain with hysteretic crush zones (``simulate_reference``), ``"surrogate"`` the paper's eq. (4)
with surrogate elements fitted on a reference run of the scenario (``build_crash_surrogate``).
:class:`CrashBatch` steps any number of trains in one compiled call; the single env and the
native vector env are thin shells around it. See ``docs/envs/crash.md`` for the tables.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from railgym.envs.crash_step import (
    _ENV,
    _STATE,
    INFO_FIELDS,
    EnvConsts,
    Episode,
    InfoColumns,
    _advance_reference,
    _advance_surrogate,
    info_layout,
    plain,
)
from railgym.envs.vector import reset_plan
from railgym.vehicles.crash import (
    VARIANTS,
    BatchOutputs,
    CrashBatchModel,
    CrashScenario,
    CrashSurrogate,
    CrushZone,
    build_crash_surrogate,
    check_real,
    crash_batch_model,
    load_scenario,
    simulate_reference,
)

BACKENDS = ("surrogate", "reference")
DEFAULT_WEIGHTS = {"decel": 1.0, "intrusion": 1.0}
#: largest control step, s: the statistics and the reward sample the state once per step, so
#: a coarser step misses the deceleration peaks of a crash lasting a few hundred ms
MAX_CONTROL_DT = 0.01
#: longest episode, s
MAX_DURATION = 60.0
#: largest reward weight and absorber rate (1/s): keeps every reward finite
MAX_WEIGHT = 1e6
#: observation scales: displacement (m) and acceleration (in g)
X_SCALE = 1.0
A_SCALE_G = 10.0


@dataclass(frozen=True)
class CrashConfig:
    """Validated settings shared by the single and the vector env (SI units)."""

    scenario: CrashScenario
    backend: str
    control_dt: float
    n_steps: int
    absorber_range: float
    max_scale_change: float
    speed_jitter: float
    weights: tuple[float, float]
    absorber_stroke: np.ndarray
    obs_names: tuple[str, ...]
    obs_scale: np.ndarray


def nominal_force(zone: CrushZone) -> float:
    """Largest point force (N) of the zone's envelope within its absorber stroke."""
    inside = [f for s, f in zip(zone.stroke, zone.force, strict=True) if s <= zone.absorber_stroke]
    return max(inside, default=zone.force[0])


def make_config(
    scenario: str | Path | CrashScenario,
    backend: str,
    n_cars: int | None,
    speed: float | None,
    control_dt: float,
    max_duration: float,
    absorber_range: float,
    absorber_rate: float,
    speed_jitter: float,
    reward_weights: dict[str, float] | None,
) -> CrashConfig:
    """Check the env arguments; every error names the argument (scenario errors its field)."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    sc = scenario if isinstance(scenario, CrashScenario) else load_scenario(scenario)
    sc = sc.with_overrides(n_cars=n_cars, speed=speed)
    control_dt = check_real("control_dt", control_dt, 0.0, MAX_CONTROL_DT, low_open=True)
    max_duration = check_real("max_duration", max_duration, 0.0, MAX_DURATION, low_open=True)
    n_steps = round(max_duration / control_dt)
    if n_steps < 1:
        raise ValueError(f"max_duration ({max_duration} s) must be at least control_dt")
    absorber_range = check_real(
        "absorber_range", absorber_range, 0.0, 1.0, low_open=True, high_open=True
    )
    absorber_rate = check_real("absorber_rate", absorber_rate, 0.0, MAX_WEIGHT, low_open=True)
    speed_jitter = check_real("speed_jitter", speed_jitter, 0.0, 1.0, high_open=True)
    weights = dict(DEFAULT_WEIGHTS)
    if reward_weights is not None and not isinstance(reward_weights, dict):
        raise ValueError(f"reward_weights must be a dict, got {type(reward_weights).__name__}")
    for key, value in (reward_weights or {}).items():
        if key not in DEFAULT_WEIGHTS:
            raise ValueError(f"reward_weights has unknown key {key!r}; keys: {list(weights)}")
        weights[key] = check_real(f"reward_weights[{key!r}]", value, 0.0, MAX_WEIGHT)
    zones = [sc.wall] + [sc.interface] * (sc.n_cars - 1)
    stroke = np.array([z.absorber_stroke for z in zones])
    force = np.array([nominal_force(z) for z in zones])
    cars = ["lead"] + [f"car{k + 1}" for k in range(1, sc.n_cars)]
    zn = ["wall"] + [f"interface_{k}" for k in range(1, sc.n_cars)]
    names = (
        [f"x_{c}" for c in cars]
        + [f"v_{c}" for c in cars]
        + [f"a_{c}" for c in cars]
        + [f"crush_{z}" for z in zn]
        + [f"force_{z}" for z in zn]
        + [f"scale_{z}" for z in zn]
    )
    n = sc.n_cars
    scale = np.concatenate(
        [
            np.full(n, X_SCALE),
            np.full(n, sc.speed),
            np.full(n, A_SCALE_G * sc.gravity),
            stroke,
            force,
            np.full(n, absorber_range),
        ]
    )
    return CrashConfig(
        scenario=sc,
        backend=backend,
        control_dt=control_dt,
        n_steps=n_steps,
        absorber_range=float(absorber_range),
        max_scale_change=absorber_rate * control_dt,
        speed_jitter=float(speed_jitter),
        weights=(weights["decel"], weights["intrusion"]),
        absorber_stroke=stroke,
        obs_names=tuple(names),
        obs_scale=scale,
    )


@functools.lru_cache(maxsize=16)
def default_surrogate(scenario: CrashScenario, variant: str = "hysteretic") -> CrashSurrogate:
    """Surrogate elements fitted on a passive reference run of ``scenario`` (cached per
    scenario, i.e. per name/file, number of cars and speed, and process)."""
    return build_crash_surrogate(simulate_reference(scenario), variant=variant, seed=0)


def make_model(cfg: CrashConfig, surrogate: Any, variant: str) -> CrashBatchModel:
    """Batch model of the configured backend; ``surrogate`` = elements or ``None`` (fitted)."""
    if cfg.backend == "reference":
        if surrogate is not None:
            raise ValueError("surrogate is only used by backend='surrogate', not 'reference'")
        return crash_batch_model(cfg.scenario, "reference", cfg.control_dt)
    if surrogate is None:
        if variant not in VARIANTS:
            raise ValueError(f"surrogate_variant must be one of {VARIANTS}, got {variant!r}")
        surrogate = default_surrogate(cfg.scenario, variant)
    if not isinstance(surrogate, CrashSurrogate):
        raise ValueError(
            f"surrogate must be a CrashSurrogate (build_crash_surrogate), got "
            f"{type(surrogate).__name__}"
        )
    if surrogate.source != cfg.scenario.name:
        raise ValueError(
            f"surrogate was built for scenario {surrogate.source!r}, not {cfg.scenario.name!r}"
        )
    try:
        return crash_batch_model(cfg.scenario, "surrogate", cfg.control_dt, surrogate=surrogate)
    except (ValueError, AttributeError, TypeError, IndexError) as err:
        raise ValueError(f"surrogate does not fit this env: {err}") from err


class CrashBatch:
    """``n`` trains, stepped by one compiled kernel call of a :class:`CrashBatchModel`.

    Not a Gymnasium object: it holds the arrays and computes the observation, reward and
    ``info`` quantities of :class:`TrainCrashEnv`.
    """

    def __init__(self, n: int, cfg: CrashConfig, model: CrashBatchModel) -> None:
        self.n, self.cfg, self.model = n, cfg, model
        sc = cfg.scenario
        self.n_cars, self.n_zones = sc.n_cars, sc.n_cars
        self.zones = np.array(
            [
                model.zone_names.index(z)
                for z in ["wall"] + [f"interface_{k}" for k in range(1, sc.n_cars)]
            ],
            dtype=np.int64,
        )
        self.layout = info_layout(self.n_cars, self.n_zones)
        n_info = max(sl.stop for sl, _ in self.layout.values())
        state, out = model.new_state(n), model.new_outputs(n)
        nc, nz = self.n_cars, self.n_zones
        env = [
            np.ones((n, len(model.zone_names))),
            np.zeros(n),
            np.zeros(n),
            np.zeros((n, nc)),
            np.zeros((n, nc)),
            np.zeros((n, nz)),
            np.zeros((n, nz)),
            np.zeros((n, len(cfg.obs_names))),
            np.zeros(n),
            np.zeros((n, n_info)),
        ]
        # every per-train float array in one buffer, in the field order of _advance_*
        self._state_type = type(state)
        self._buf, self._fields = self._pack([*out, *env, *state])
        self.div = np.zeros(n, np.bool_)
        self.over = np.zeros(n, np.bool_)
        self.steps = np.zeros(n, np.int64)
        # (key, kind, first, stop) per info key: kind 0 float, 1 bool, 2 array
        kinds = {"1": 0, "bool": 1, "cars": 2, "zones": 2}
        self._info_fields = [
            (key, kinds[size], self.layout[key][0].start, self.layout[key][0].stop)
            for key, size in INFO_FIELDS
        ]
        self.inv_scale = 1.0 / cfg.obs_scale
        columns = InfoColumns(*(sl.start for sl, _ in self.layout.values()))
        self.consts = EnvConsts(
            zones=self.zones,
            stroke=cfg.absorber_stroke,
            inv_scale=self.inv_scale,
            w_decel=cfg.weights[0],
            w_intrusion=cfg.weights[1],
            gravity=sc.gravity,
            control_dt=cfg.control_dt,
            absorber_range=cfg.absorber_range,
            max_change=cfg.max_scale_change,
            info=columns,
        )
        self._bind()
        self._no_action = np.zeros((n, self.n_zones))
        # undeformed front end of each car at first contact (lead car at the wall), m
        lengths = [sc.lead.length] + [sc.passenger.length] * (sc.n_cars - 1)
        self.lengths = np.array(lengths)
        self.front0 = -np.concatenate(([0.0], np.cumsum(lengths[:-1])))

    def reset(self, rows: np.ndarray, rngs: list[np.random.Generator]) -> None:
        """Put the trains ``rows`` at first contact (initial speed jittered with ``rngs[i]``)."""
        cfg, mask = self.cfg, np.zeros(self.n, np.bool_)
        for i in rows:
            v = cfg.scenario.speed
            if cfg.speed_jitter > 0:
                v *= 1.0 + cfg.speed_jitter * rngs[i].uniform(-1.0, 1.0)
            self.model.reset(self.state, self.out, i, v)
            self.speed[i] = v
            self.scale[i] = 1.0
            self.div[i] = False
            mask[i] = True
        self._call(mask, init=True)

    @staticmethod
    def _pack(arrays: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """One float64 buffer holding ``arrays`` (1-D or 2-D) one after another and the
        (offset, rows, columns) of each (columns 0 for a 1-D array): the compiled step then
        takes one array instead of one per array."""
        buf = np.empty(sum(a.size for a in arrays))
        fields = np.zeros((len(arrays), 3), np.int64)
        o = 0
        for f, a in enumerate(arrays):
            buf[o : o + a.size] = a.ravel()
            fields[f] = o, a.shape[0], a.shape[1] if a.ndim == 2 else 0
            o += a.size
        return buf, fields

    def _view(self, f: int) -> np.ndarray:
        """Array ``f`` of the buffer, as a view."""
        o, r, c = (int(v) for v in self._fields[f])
        return self._buf[o : o + r * max(c, 1)].reshape((r, c) if c else (r,))

    def _bind(self) -> None:
        """Named views of the buffer and the kernel arguments (again after a copy: a pickled
        view is a detached array)."""
        views = [self._view(f) for f in range(self._fields.shape[0])]
        self.out = BatchOutputs(*views[:_ENV])
        self.episode = Episode(*views[_ENV:_STATE], self.div, self.over, self.steps)
        self.state = self._state_type(*views[_STATE:])
        model = self.model
        self._kernel = _advance_reference if model.backend == "reference" else _advance_surrogate
        flags = (self.div, self.over, self.steps)
        stepping = (model.dt, model.n_sub)
        self._args = (
            self._buf,
            self._fields,
            flags,
            plain(model.params),
            stepping,
            plain(self.consts),
        )

    _VIEWS = ("out", "episode", "state", "_kernel", "_args")

    # per-train arrays under their short names (views of the buffer)
    scale = property(lambda self: self.episode.scale)
    speed = property(lambda self: self.episode.speed)
    obs = property(lambda self: self.episode.obs)
    rew = property(lambda self: self.episode.reward)
    info = property(lambda self: self.episode.info)

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k not in self._VIEWS}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._bind()

    def advance(self, actions: np.ndarray, active: np.ndarray) -> bool:
        """One control step of the ``active`` trains with ``actions`` (n, zones) float64,
        clipped to [−1, 1]. Returns ``False``, changing nothing, if any action is not finite."""
        return self._kernel(*self._args, actions, active, False)

    def _call(self, active: np.ndarray, init: bool) -> None:
        self._kernel(*self._args, self._no_action, active, init)

    def observe(self) -> np.ndarray:
        """Observations (n, n_obs), float32."""
        return self.obs.astype(np.float32)

    def infos(self) -> dict[str, np.ndarray]:
        """``info`` of every train as arrays, first axis the train (``docs/envs/crash.md``);
        views of one fresh copy."""
        info = self.info.copy()
        return {
            key: info[:, a] if kind == 0 else info[:, a] != 0.0 if kind == 1 else info[:, a:b]
            for key, kind, a, b in self._info_fields
        }

    def info_row(self, i: int) -> dict[str, Any]:
        """``info`` of train ``i``: floats, bools and 1-D arrays (views of one fresh copy)."""
        row = self.info[i].copy()
        vals = row.tolist()
        return {
            key: vals[a] if kind == 0 else vals[a] != 0.0 if kind == 1 else row[a:b]
            for key, kind, a, b in self._info_fields
        }

    def render_state(self, i: int) -> dict[str, Any]:
        """What :func:`railgym.envs.rendering.render_crash` draws for train ``i``."""
        out, c = self.out, self.n_cars
        wall = float(out.x[i, c]) if out.x.shape[1] > c else 0.0  # the obstacle, if any
        return {
            "positions": self.front0 + out.x[i, :c],
            "lengths": self.lengths,
            "crush": out.crush[i, self.zones],
            "stroke": self.cfg.absorber_stroke,
            "wall_x": wall,
            "time": float(self.steps[i] * self.cfg.control_dt),
            "duration": self.cfg.n_steps * self.cfg.control_dt,
        }


def _real_actions(name: str, value: Any) -> np.ndarray:
    """``value`` as a float64 array if it holds real numbers (not bools, strings, complex);
    else ``ValueError`` naming ``name``."""
    a = np.asarray(value)
    if a.dtype.kind not in "iuf":
        raise ValueError(f"{name} must hold real numbers, got dtype {a.dtype} ({value!r})")
    return a.astype(np.float64)


class TrainCrashEnv(gym.Env[np.ndarray, np.ndarray]):
    """Adaptive crash energy management: a train runs into a wall, the agent sets the force
    level of a controllable absorber in every crush zone.

    Parameters
    ----------
    backend : ``"surrogate"`` (default, paper eq. 4) or ``"reference"`` (lumped-mass chain).
    scenario : packaged scenario name (``"paper"``, ``"speed50"``, ...) or YAML path.
    n_cars : number of cars (``None`` = the scenario's). speed : initial speed, m/s (``None``
        = the scenario's). speed_jitter : initial speed × U(1 − j, 1 + j) at each reset.
    control_dt : agent step, s. max_duration : truncation, s.
    absorber_range : action ±1 sets the absorber force to (1 ± range) × nominal.
    absorber_rate : largest change of the force scale, 1/s.
    reward_weights : ``decel`` and ``intrusion`` weights.
    surrogate : :class:`CrashSurrogate` elements, or ``None`` to fit them on a reference run of
        the scenario (cached per process). surrogate_variant : ``"hysteretic"`` or ``"paper"``.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(
        self,
        backend: str = "surrogate",
        scenario: str | Path | CrashScenario = "paper",
        n_cars: int | None = 2,
        speed: float | None = None,
        control_dt: float = 0.001,
        max_duration: float = 2.0,
        absorber_range: float = 0.3,
        absorber_rate: float = 20.0,
        speed_jitter: float = 0.0,
        reward_weights: dict[str, float] | None = None,
        surrogate: CrashSurrogate | None = None,
        surrogate_variant: str = "hysteretic",
        render_mode: str | None = None,
    ) -> None:
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.cfg = make_config(
            scenario,
            backend,
            n_cars,
            speed,
            control_dt,
            max_duration,
            absorber_range,
            absorber_rate,
            speed_jitter,
            reward_weights,
        )
        self.backend = backend
        self.model = make_model(self.cfg, surrogate, surrogate_variant)
        self.sim = CrashBatch(1, self.cfg, self.model)
        self.render_mode = render_mode
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        n_z = self.sim.n_zones
        self.observation_space = spaces.Box(-np.inf, np.inf, (len(self.obs_names),), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (n_z,), np.float32)
        self._one = np.ones(1, np.bool_)
        self._action_shape, self._batch_shape = (n_z,), (1, n_z)
        self._started = False

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Train at first contact with the wall, absorbers at nominal force."""
        super().reset(seed=seed)
        if options:
            raise ValueError(f"reset takes no options, got {sorted(options)}")
        self.sim.reset(np.zeros(1, np.int64), [self.np_random])
        self._started = True
        return self.sim.observe()[0], self._info()

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Advance ``control_dt``; the action is clipped to [−1, 1], non-finite raises."""
        if not self._started:
            raise RuntimeError("call reset() before step()")
        a = _real_actions("action", action)
        sim = self.sim
        if a.shape != self._action_shape:
            raise ValueError(f"action must have shape ({sim.n_zones},), got {a.shape}")
        if not sim.advance(a.reshape(self._batch_shape), self._one):
            raise ValueError(f"action must be finite, got {action!r}")
        terminated = bool(sim.over[0] or sim.div[0])
        truncated = not terminated and int(sim.steps[0]) >= self.cfg.n_steps
        if terminated or truncated:
            self._started = False
        return (
            sim.obs[0].astype(np.float32),
            float(sim.rew[0]),
            terminated,
            truncated,
            sim.info_row(0),
        )

    def _info(self) -> dict[str, Any]:
        return self.sim.info_row(0)

    def render(self) -> np.ndarray | None:
        """RGB frame (H, W, 3) of the train and the wall when ``render_mode="rgb_array"``."""
        if self.render_mode is None:
            gym.logger.warn("render() called without render_mode; use render_mode='rgb_array'")
            return None
        from railgym.envs.rendering import render_crash

        return render_crash(self.sim.render_state(0))


class TrainCrashVectorEnv(VectorEnv):
    """Native vector version: all sub-envs stepped in one compiled kernel call.

    Sub-env ``i`` of ``reset(seed=s)`` reproduces ``TrainCrashEnv.reset(seed=s + i)`` step
    for step. Autoreset mode: next step (gymnasium's default).
    """

    metadata = {
        "render_modes": ["rgb_array"],
        "render_fps": 50,
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(self, num_envs: int = 1, render_mode: str | None = None, **kwargs: Any) -> None:
        if isinstance(num_envs, bool) or not (
            isinstance(num_envs, int | np.integer) and num_envs >= 1
        ):
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        self.single_env = TrainCrashEnv(render_mode=render_mode, **kwargs)
        self.num_envs = int(num_envs)
        self.render_mode = render_mode
        self.cfg = self.single_env.cfg
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        self.sim = CrashBatch(self.num_envs, self.cfg, self.single_env.model)
        self.single_observation_space = self.single_env.observation_space
        self.single_action_space = self.single_env.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._rngs: list[np.random.Generator | None] = []
        self._prev_done = np.zeros(self.num_envs, np.bool_)
        self._mask_keys = [f"_{k}" for k in self.sim.layout]

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the sub-envs; sub-env ``i`` is seeded with ``seed + i`` (or ``seed[i]``);
        ``options["reset_mask"]`` resets only those (see :func:`railgym.envs.vector.reset_plan`).
        """
        if seed is not None:
            first = seed if isinstance(seed, (int, np.integer)) else seed[0]
            self._np_random, self._np_random_seed = seeding.np_random(first)
        mask, self._rngs, options = reset_plan(self.num_envs, seed, options, self._rngs)
        if options:
            raise ValueError(f"reset takes no options but reset_mask, got {sorted(options)}")
        self.sim.reset(np.flatnonzero(mask), self._rngs)
        self._prev_done[mask] = False
        return self.sim.observe(), self._infos()

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step all sub-envs; those that ended on the previous step are reset instead."""
        if not self._rngs:
            raise RuntimeError("call reset() before step()")
        sim = self.sim
        a = _real_actions("actions", actions)
        shape = (self.num_envs, sim.n_zones)
        if a.shape != shape:
            raise ValueError(f"actions must have shape {shape}, got {a.shape}")
        if not np.isfinite(a).all():  # checked before the resets of the ended sub-envs
            raise ValueError("actions must be finite; got NaN or Inf")
        done = self._prev_done
        if done.any():
            sim.reset(np.flatnonzero(done), self._rngs)
        sim.advance(a, ~done)
        terminated = sim.over | sim.div  # both False for the sub-envs just reset
        truncated = (sim.steps >= self.cfg.n_steps) & ~terminated
        self._prev_done = terminated | truncated
        return sim.observe(), sim.rew.copy(), terminated, truncated, self._infos()

    def _infos(self) -> dict[str, Any]:
        infos = self.sim.infos()
        mask = np.ones(self.num_envs, np.bool_)
        infos.update(dict.fromkeys(self._mask_keys, mask))
        return infos

    def render(self) -> tuple[np.ndarray, ...] | None:
        """One RGB frame per sub-env."""
        if self.render_mode is None:
            gym.logger.warn("render() called without render_mode; use render_mode='rgb_array'")
            return None
        from railgym.envs.rendering import render_crash

        return tuple(render_crash(self.sim.render_state(i)) for i in range(self.num_envs))
