"""The batch of ``railgym/TrainCrash-v1`` (:mod:`railgym.envs.crash`): ``n`` trains stepped by
one compiled call per control step (:mod:`railgym.envs.crash.step`), behind the batch contract
of :mod:`railgym.envs.base`."""

from __future__ import annotations

from typing import Any

import numpy as np

from railgym.envs.batch_base import ArrayBatch
from railgym.envs.compiled import compiled_entry
from railgym.envs.crash.layout import (
    ENV_FIELDS,
    EPISODE,
    INFO_FIELDS,
    REWARD_TERMS,
    Episode,
    InfoColumns,
    info_layout,
    new_episode_arrays,
)
from railgym.envs.crash.params import CrashParams
from railgym.envs.crash.step import (
    ENV_START,
    STATE_START,
    EnvConsts,
    advance_reference,
    advance_surrogate,
    advance_surrogate_parallel,
    crush_limits,
    plain,
)
from railgym.envs.params import consts
from railgym.vehicles.crash.model import CrashModel
from railgym.vehicles.crash.outputs import PARALLEL_MIN, CrashOutputs

__all__ = ["CrashBatch"]


class CrashBatch(ArrayBatch):
    """``n`` trains, stepped by one compiled kernel call of a :class:`CrashModel`.

    Not a Gymnasium object: the batch of :mod:`railgym.envs.base` (its contract is there). It
    holds the arrays and computes the observation, reward, its terms and the ``info``
    quantities of :class:`~railgym.envs.crash.env.TrainCrashEnv`. ``reset`` draws the episode's
    initial speed and payload (:meth:`draw`); ``reset_state`` restarts the same episode.
    """

    REWARD_TERMS = REWARD_TERMS

    def __init__(self, n: int, cfg: CrashParams, model: CrashModel) -> None:
        self.n, self.cfg, self.model = n, cfg, model
        scenario = cfg.scenario
        self.n_cars, self.n_zones = scenario.n_cars, scenario.n_cars
        names = ["wall"] + [f"interface_{k}" for k in range(1, scenario.n_cars)]
        self.zones = np.array([model.zone_names.index(z) for z in names], dtype=np.int64)
        self.layout = info_layout(self.n_cars, self.n_zones)
        n_info = max(sl.stop for sl, _ in self.layout.values())
        state, out = model.new_state(n), model.new_outputs(n)
        nc, nz, nm = self.n_cars, self.n_zones, len(model.zone_names)
        counts = {"cars": nc, "zones": nz, "model_zones": nm, "terms": len(REWARD_TERMS)}
        counts["ring"] = (cfg.criteria.window_steps + 1) * nc
        counts.update(obs=len(cfg.obs_names), info=n_info)
        arrays = new_episode_arrays(n, counts)
        # every per-train float array in one buffer, in the field order of advance_*
        self._state_type = type(state)
        self._buf, self._fields = self._pack([*out, *(arrays[f] for f in ENV_FIELDS), *state])
        self._flag_arrays = [arrays[a.name] for a in EPISODE if a.name not in ENV_FIELDS]
        # (key, kind, index) of each info entry; kinds 0–3 pick from (values, bools, row,
        # bit row) of :meth:`info`, the index is a column (0, 1) or a slice of columns (2, 3)
        self._info_fields = []
        for key in INFO_FIELDS:
            cols, scalar = self.layout[key.name]
            kind = (0 if scalar else 2) + (key.dtype == "bool")
            self._info_fields.append((key.name, kind, cols.start if scalar else cols))
        columns = InfoColumns(*(sl.start for sl, _ in self.layout.values()))
        surrogate = model.backend == "surrogate"
        types = model.params.types if surrogate else None
        kind = model.params.kind if surrogate else np.zeros(0, np.int64)
        lengths = np.array(
            [scenario.lead.length] + [scenario.passenger.length] * (scenario.n_cars - 1)
        )
        self.consts = consts(
            EnvConsts,
            cfg,
            zones=self.zones,
            crush_limit=crush_limits(lengths),
            inv_scale=1.0 / cfg.obs_scale,
            w_decel=cfg.reward_weights["decel"],
            w_intrusion=cfg.reward_weights["intrusion"],
            w_peak=cfg.reward_weights["peak"],
            gravity=scenario.gravity,
            unloading_k=types.unloading_stiffness[kind] if surrogate else np.zeros(0),
            tension_k=types.tension_stiffness[kind] if surrogate else np.zeros(0),
            info=columns,
        )
        #: float64 (n, zones) the actions of the next step (the batch contract)
        self.actions = np.zeros((n, self.n_zones))
        self._all = np.ones(n, np.bool_)
        self._one = np.zeros(n, np.bool_)  # the train of reset_state
        self._link()
        # undeformed front end of each car at first contact (lead car at the wall), m
        self.lengths = lengths
        self.front0 = -np.concatenate(([0.0], np.cumsum(lengths[:-1])))

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

    def _link(self) -> None:
        """Named views of the buffer and the kernel arguments (again after a copy: a pickled
        view is a detached array)."""
        views = [self._view(f) for f in range(self._fields.shape[0])]
        self.out = CrashOutputs(*views[:ENV_START])
        self.episode = Episode(*views[ENV_START:STATE_START], *self._flag_arrays)
        self.state = self._state_type(*views[STATE_START:])
        model = self.model
        flags = tuple(self._flag_arrays)
        stepping = (model.dt, model.n_sub)
        self._args = (
            self._buf,
            self._fields,
            flags,
            plain(model.params),
            stepping,
            plain(self.consts),
        )
        if model.backend == "reference":
            kernel = init_kernel = advance_reference
        else:  # a reset (one train) always runs serially
            init_kernel = advance_surrogate
            parallel = self.n >= PARALLEL_MIN
            kernel = advance_surrogate_parallel if parallel else advance_surrogate
        # resolved once: numba's per-call typing of the nested tuples costs more than a reset
        example = (*self._args, self.actions, self._all, False)
        self._kernel = compiled_entry(kernel, example)
        self._init_kernel = compiled_entry(init_kernel, example)
        self._flags = {"crash_over": self.over, "diverged": self.div}

    _VIEWS = ("out", "episode", "state", "_kernel", "_init_kernel", "_args", "_flags")

    # per-train arrays under their short names (views of the buffer)
    scale = property(lambda self: self.episode.scale)
    speed = property(lambda self: self.episode.speed)
    payload = property(lambda self: self.episode.payload)
    obs = property(lambda self: self.episode.obs)
    reward = property(lambda self: self.episode.reward)
    _terms = property(lambda self: self.episode.terms)
    #: True where the episode reached ``max_duration``
    _truncated = property(lambda self: self.steps >= self.cfg.n_steps)
    div = property(lambda self: self.episode.div)
    over = property(lambda self: self.episode.over)
    steps = property(lambda self: self.episode.steps)

    # the batch contract of railgym.envs.base ------------------------------------------
    def draw(self, rng: np.random.Generator, episode: tuple[Any, Any]) -> tuple[float, np.ndarray]:
        """Initial speed (m/s) and payload per car (kg) of a new episode.

        Draws, in this order and whatever ``episode`` fixes: the speed from the envelope
        ``U(low, high)``, each car's payload ``U(low, high)`` (front to back), then the speed
        jitter ``U(−1, 1)``; without an envelope only the jitter (if any). ``episode`` is
        ``(speed, payload)`` fixed by ``reset(options=...)``, each ``None`` to draw.
        """
        cfg = self.cfg
        fixed_speed, fixed_payload = episode
        v, payload = cfg.scenario.speed, np.zeros(self.n_cars)
        if cfg.speed_range is not None:
            v = rng.uniform(*cfg.speed_range)
            payload = rng.uniform(cfg.payload_range[:, 0], cfg.payload_range[:, 1])
        if cfg.speed_jitter > 0:
            jitter = 1.0 + cfg.speed_jitter * rng.uniform(-1.0, 1.0)
            if fixed_speed is None:
                v *= jitter
        if fixed_speed is not None:
            v = fixed_speed
        if fixed_payload is not None:
            payload = np.array(fixed_payload, dtype=np.float64)
        return v, payload

    def reset_many(
        self, idx: np.ndarray, rngs: list[np.random.Generator], episode: tuple[Any, Any]
    ) -> None:
        """:meth:`reset` of the trains ``idx``, each with its generator of ``rngs``; their
        observations, ``info`` and rewards from one compiled call."""
        for i, rng in zip(idx.tolist(), rngs, strict=True):
            self.speed[i], self.payload[i] = self.draw(rng, episode)
            self._place(i)
        self._init_rows(idx)

    def reset_state(self, i: int) -> None:
        """Train ``i`` back at first contact at its episode's speed and payload."""
        self._place(i)
        self._init_rows(np.array([i]))

    def _place(self, i: int) -> None:
        """State of train ``i`` at first contact at its episode's speed and payload."""
        payload = self.payload[i] if self.payload[i].any() else None
        self.model.reset(self.state, self.out, i, float(self.speed[i]), payload)

    def _init_rows(self, idx: np.ndarray) -> None:
        """Observation, ``info`` and reward of the trains ``idx`` at first contact."""
        self._one[idx] = True
        self._init_kernel(*self._args, self.actions, self._one, True)
        self._one[idx] = False

    def advance(self) -> None:
        """One control step of every train with the stored actions."""
        self._kernel(*self._args, self.actions, self._all, False)

    def advance_holding(self, hold: np.ndarray) -> None:
        """:meth:`advance` of every train but those of the (n,) bool mask ``hold`` (just
        reset: they stay at first contact, observation, ``info`` and reward as the reset
        left them)."""
        self._kernel(*self._args, self.actions, ~hold, False)

    def info(self, i: int | None = None) -> dict[str, Any]:
        """``info`` of train ``i`` (floats, bools and 1-D arrays) or of all (arrays, first axis
        the train), from one fresh copy of the flat rows (``docs/envs/crash.md``)."""
        if i is None:
            rows = self.episode.info.copy()
            bits = rows != 0.0
            srcs = (rows, bits, rows, bits)
            return {key: srcs[kind][:, ix] for key, kind, ix in self._info_fields}
        row = self.episode.info[i].copy()
        bits = row != 0.0
        srcs = (row.tolist(), bits.tolist(), row, bits)
        return {key: srcs[kind][ix] for key, kind, ix in self._info_fields}

    def render_state(self, i: int) -> dict[str, Any]:
        """What :func:`railgym.envs.crash.render.render_crash` draws for train ``i``."""
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
            "speed": float(out.v[i, 0]),  # lead car, m/s
        }
