"""Env shells around a batch simulator: seeding, reset plan, autoreset, info, render.

An env is a thin shell around a *batch*, an object that holds the arrays of ``n`` simulated
systems and steps them all by one compiled call. The single env is the shell around a batch
of one (:class:`BatchEnv`), the native vector env around a batch of ``num_envs``
(:class:`BatchVectorEnv`); both share the batch, so sub-env ``i`` of ``reset(seed=s)``
reproduces the single env reset with ``seed=s + i`` step for step.

The batch contract (:class:`~railgym.envs.batch_base.ArrayBatch`)
-----------------------------------------------------------------
``n``
    Number of systems.
``reset(i, rng, episode)``
    New episode for system ``i``: draw what is random (a track, a scenario) from ``rng``;
    ``episode`` is what the env's :meth:`BatchEnv._episode` returns (e.g. track class and
    speed).
``reset_many(idx, rngs, episode)``
    :meth:`reset` of the systems ``idx`` (int array) with their generators ``rngs`` (a list
    in the order of ``idx``): the same result as one reset after another, free to do the
    work of several at once (the track batches synthesise the tracks on threads).
``reset_state(i)``
    System ``i`` back to its initial state on its current episode data, counters cleared.
``actions``
    The (n, *action_shape) float64 actions of the next :meth:`advance`; the shells write the
    validated, clipped actions into it.
``advance()``
    One control step of every system; afterwards ``reward`` (n,) is the step reward,
    ``reward_terms(i=None)`` the weighted terms that sum to it, ``info(i=None)`` the env's
    ``info`` layout (declared once by the batch) — both as Python numbers of system ``i`` or,
    for ``i=None``, as (n,) array copies —, ``flags()`` a dict of (n,) bool arrays of events
    (``diverged``; every flag terminates the episode) and ``truncated()`` (n,) bool.
``outcome(i)``
    ``(reward, terminated, truncated, info)`` of system ``i`` after :meth:`advance`, as the
    single env's step returns them (``info`` with ``reward_terms`` and the flags set): the
    base assembles it from the five reads above; a batch may read it in one.
``advance_holding(hold)`` (optional)
    :meth:`advance` of every system but those of the (n,) bool mask ``hold``, which keep the
    state, observation, ``info`` and reward their reset left; without it the shell advances
    all and restores the held ones with ``reset_state``.
``observe(rngs, i=None)``
    Observations (n, *obs_shape) float32, any sensor noise drawn from the per-system ``rngs``;
    with ``i``, system ``i``'s alone (*obs_shape), its noise drawn from ``rngs[0]``.
``render_state(i)``
    What the env's frame function draws for system ``i``.
``close()`` (optional)
    Release what the batch holds (FMU instances); called by the env's ``close()``.

Using the shells
----------------
A new env (the crash env, a whole-vehicle env) writes its batch, then::

    class MyEnv(BatchEnv):
        def __init__(self, ..., render_mode=None):
            self._init_shell(MyBatch(1, ...), render_mode, obs_space, action_space)
        def _episode(self):                       # per-episode settings passed to reset
            return (self.scenario,)
        _case_attrs = ("scenario",)               # what the reset options set
        def _apply_options(self, options):        # validate / store reset options
            ...
        def _case(self, sim, idx):                # info["case"] of systems idx
            return {"scenario": np.full(len(idx), self.scenario)}
        def _frame(self, state):                  # RGB frame from render_state(i)
            return render_my_env(state)

    class MyVectorEnv(BatchVectorEnv):
        def __init__(self, num_envs=1, render_mode=None, **kwargs):
            single = MyEnv(render_mode=render_mode, **kwargs)
            self._init_vector(single, MyBatch(num_envs, ...), num_envs)

Single-env ``info``: the batch's ``info()`` entries as Python scalars, ``reward_terms`` as a
dict of floats, and each flag of ``flags()`` as ``True`` only on the step where it is set.
Vector ``info``: the same keys as arrays with gymnasium's ``_key`` masks (flags always
present); ``reward_terms`` a dict of arrays with its own masks.

Reset options and the held case
-------------------------------
Options set the env's *case* (track class and speed, impact conditions: the attributes named
by :attr:`BatchEnv._case_attrs`) for this and later episodes, the vector env's autoresets
included. ``options={"hold": False}`` first returns them to the constructor's values (other
options of the same call then apply); ``{"hold": True}`` keeps the held case (as no option
does) and says so. Every reset's ``info["case"]`` is the env's :meth:`BatchEnv._case` of the
episode plus ``from_options`` (the episode's case differs from the constructor's); the vector
env reports it per sub-env at reset and, masked to the reset sub-envs, on autoreset steps.
The first ``reset(seed=...)`` without options that runs a held case gives a ``UserWarning``
(once per env, a vector env's included); an unseeded reset without options (the next episode
of a run: gymnasium's and SB3's autoresets) and a partial reset (``reset_mask`` alone) do not.
"""

from __future__ import annotations

import math
import sys
import warnings
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from railgym import _checks as val
from railgym.envs.vector import reset_options, reset_plan

if TYPE_CHECKING:
    from railgym.envs.batch_base import ArrayBatch

__all__ = ["BatchEnv", "BatchVectorEnv", "ResetNeeded", "check_actions", "step_grid"]


class ResetNeeded(gym.error.ResetNeeded, RuntimeError):
    """A step before the first ``reset()`` or after the episode ended (gymnasium's
    ``ResetNeeded``, also a ``RuntimeError``): the envs enforce the order themselves, so
    ``gym.make`` adds no ``OrderEnforcing`` wrapper."""


def step_grid(dt: float, control_dt: float, duration: float) -> tuple[int, int]:
    """``(n_sub, n_steps)``: integration steps ``dt`` (s) per control step ``control_dt`` (s),
    and control steps per episode of ``duration`` (s); each must divide the next exactly."""
    if dt > control_dt:
        raise val.FieldError("dt", f"must be at most control_dt ({control_dt} s), got {dt!r}")
    n_sub = round(control_dt / dt)
    if abs(n_sub * dt - control_dt) > 1e-9 * control_dt:
        raise val.FieldError(
            "control_dt", f"({control_dt} s) must be a whole multiple of dt ({dt} s)", full=False
        )
    n_steps = round(duration / control_dt)
    if n_steps < 1 or abs(n_steps * control_dt - duration) > 1e-9 * duration:
        raise val.FieldError("duration", f"({duration} s) must be a whole multiple of control_dt")
    return n_sub, n_steps


def check_actions(
    actions: Any, shape: tuple[int, ...], low: np.ndarray, high: np.ndarray, field: str = "action"
) -> np.ndarray:
    """Actions as float64 of ``shape`` clipped to ``[low, high]`` (float64 bounds; documented
    clipping).

    Strings, bools, complex numbers, objects, NaN/Inf and a wrong shape raise ``ValueError``
    (wrong types also ``TypeError``) naming ``field``.
    """
    if isinstance(actions, np.ndarray) and actions.dtype.kind == "f":
        if actions.shape != shape:
            raise val.FieldError(field, f"must have shape {shape}, got {actions.shape}")
        a = actions.astype(np.float64)
        if not np.isfinite(a).all():
            raise val.FieldError(field, "must be finite; got NaN or Inf")
    else:
        a = val.numeric_array(actions, field, shape)
    np.maximum(a, low, out=a)
    return np.minimum(a, high, out=a)


#: largest action (elements) taken by the element-wise path of :func:`_check_small`
_SMALL = 8


def _check_small(
    actions: Any, shape: tuple[int, ...], bounds: tuple[list[float], list[float]], out: np.ndarray
) -> bool:
    """:func:`check_actions` of a float array of the 1-D ``shape`` written into ``out[0]``
    (``out`` float64 (1, m)) element by element: the same checks, messages and clipping with
    fewer numpy calls. False (nothing done) for any other input."""
    if type(actions) is not np.ndarray or actions.shape != shape or actions.dtype.char not in "efd":
        return False
    low, high = bounds
    j = 0  # a counter, not enumerate(): one step's action is one or two elements
    for v in actions.tolist():
        if not low[j] <= v <= high[j]:  # NaN and ±Inf fail this too
            if not math.isfinite(v):
                raise val.FieldError("action", "must be finite; got NaN or Inf")
            v = min(max(v, low[j]), high[j])
        out[0, j] = v
        j += 1
    return True


#: the system of a single env's batch, as an index array
_ONE = np.zeros(1, np.intp)


def _same(a: Any, b: Any) -> bool:
    """Whether two case values (numbers, strings, ``None``, arrays and tuples, lists or dicts
    of them) are equal."""
    if a is b:
        return True
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (
            isinstance(a, np.ndarray)
            and isinstance(b, np.ndarray)
            and a.shape == b.shape
            and bool(np.array_equal(a, b))
        )
    if isinstance(a, tuple | list) and isinstance(b, tuple | list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    return bool(a == b)


def caller_level() -> int:
    """``stacklevel`` of a warning given by the caller of this function that names the first
    frame outside the env shells, railgym's wrappers and gymnasium (the user's ``reset``)."""
    level, frame = 1, sys._getframe(1)
    inside = ("railgym.envs", "railgym.wrappers", "gymnasium")
    while frame.f_back is not None and frame.f_globals.get("__name__", "").startswith(inside):
        level, frame = level + 1, frame.f_back
    return level


def _render_mode(render_mode: Any, modes: list[str]) -> str | None:
    if render_mode is not None and render_mode not in modes:
        raise ValueError(f"render_mode must be None or one of {modes}, got {render_mode!r}")
    return render_mode


class BatchEnv(gym.Env[np.ndarray, np.ndarray]):
    """Single-env shell around a batch of one (see the module docstring)."""

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 50}
    sim: ArrayBatch
    #: the attributes that reset options set (the env's case); their values when the shell is
    #: made are the constructor's case, to which ``options={"hold": False}`` returns
    _case_attrs: tuple[str, ...] = ()

    def _init_shell(
        self,
        sim: ArrayBatch,
        render_mode: str | None,
        observation_space: spaces.Space,
        action_space: spaces.Box,
    ) -> None:
        self.render_mode = _render_mode(render_mode, self.metadata["render_modes"])
        self.sim = sim
        self.observation_space = observation_space
        self.action_space = action_space
        self._bounds = (action_space.low.astype(np.float64), action_space.high.astype(np.float64))
        self._flat_bounds = (self._bounds[0].ravel().tolist(), self._bounds[1].ravel().tolist())
        self._shape = action_space.shape
        self._small = len(self._shape) == 1 and self._shape[0] <= _SMALL
        self._rng1: list[np.random.Generator] = []
        self._started = False
        self._own_case = tuple(getattr(self, a) for a in self._case_attrs)
        self._own_episode = self._episode()
        self._case_held = False  # the case differs from the constructor's
        self._held_warned = False

    # hooks --------------------------------------------------------------------------
    def _episode(self) -> tuple:
        """Per-episode settings passed to ``sim.reset``."""
        return ()

    def _apply_options(self, options: dict[str, Any]) -> None:
        """Validate and store ``reset`` options; the default accepts none."""
        if options:
            raise ValueError(f"options: unknown reset option(s) {sorted(options)}")

    def _case(self, sim: ArrayBatch, idx: np.ndarray) -> dict[str, np.ndarray]:
        """``info["case"]`` of the systems ``idx`` of ``sim`` (this env's batch or its vector
        env's) after their reset, arrays with a first axis ``len(idx)``; ``from_options`` is
        added by the shell."""
        return {}

    def _case_text(self, episode: tuple) -> str:
        """The case of ``episode`` (what :meth:`_episode` returns) in words, for the warning."""
        return repr(episode)

    def _frame(self, state: dict[str, Any]) -> np.ndarray:
        """RGB frame of ``sim.render_state(i)``."""
        raise NotImplementedError

    # reset options ------------------------------------------------------------------
    def _take_options(
        self, options: dict[str, Any], seeded: bool, partial: bool = False, owner: Any = None
    ) -> None:
        """Apply the reset ``options`` (``hold`` here, the others by :meth:`_apply_options`;
        nothing changes when they raise) and note whether the case is held; warn (once per
        env) when a seeded reset without options runs a case held from earlier options, unless
        ``partial`` (a vector env's ``reset_mask`` reset). ``owner``: the vector env whose
        single env this is (named in the warning)."""
        given = bool(options)
        hold = val.boolean(options.pop("hold", True), "options['hold']")
        before = tuple(getattr(self, a) for a in self._case_attrs)
        try:
            if not hold:
                for name, value in zip(self._case_attrs, self._own_case, strict=True):
                    setattr(self, name, value)
            self._apply_options(options)
        except BaseException:
            for name, value in zip(self._case_attrs, before, strict=True):
                setattr(self, name, value)
            raise
        episode = self._episode()
        self._case_held = not _same(episode, self._own_episode)
        if self._case_held and seeded and not given and not partial and not self._held_warned:
            self._held_warned = True
            warnings.warn(
                f"{type(owner or self).__name__}: reset(seed=...) without options runs "
                f"{self._case_text(episode)}, held from an earlier reset(options=...) (reset "
                f"options are kept for later episodes); the env was made for "
                f"{self._case_text(self._own_episode)}. Give options={{'hold': False}} to "
                "return to it, options={'hold': True} to keep the held case without this "
                "warning; info['case'] reports the case of each reset (warned once per env)",
                UserWarning,
                stacklevel=caller_level(),
            )

    def _case_arrays(self, sim: ArrayBatch, idx: np.ndarray) -> dict[str, np.ndarray]:
        """:meth:`_case` of the systems ``idx`` of ``sim`` with ``from_options``."""
        return {**self._case(sim, idx), "from_options": np.full(len(idx), self._case_held)}

    # gymnasium API ------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """New episode; ``options``: ``hold`` and those of the env's ``_apply_options``;
        ``info["case"]``: the episode's case (see the module docstring)."""
        super().reset(seed=seed)
        self._take_options(reset_options(options), seed is not None)
        self.sim.reset(0, self.np_random, self._episode())
        self._rng1 = [self.np_random]
        self._started = True
        info = self.sim.info(0)
        info["case"] = {
            k: v[0].item() if v.ndim == 1 else v[0].copy()
            for k, v in self._case_arrays(self.sim, _ONE).items()
        }
        return self.sim.observe(self._rng1, 0), info

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Advance one control step; the action is clipped to the action space."""
        if not self._started:
            raise ResetNeeded("call reset() before step() (the first, and after an episode ended)")
        sim = self.sim
        if not (self._small and _check_small(action, self._shape, self._flat_bounds, sim.actions)):
            sim.actions[0] = check_actions(action, self._shape, *self._bounds)
        sim.advance()
        reward, terminated, truncated, info = sim.outcome(0)
        if terminated or truncated:
            self._started = False
        return sim.observe(self._rng1, 0), reward, terminated, truncated, info

    def _rows(self, a: np.ndarray) -> Any:
        """The accessors' value of a per-system array ``a`` (n, …): sub-env 0's entry, a copy
        (a Python number for a scalar entry)."""
        row = a[0]
        return row.copy() if isinstance(row, np.ndarray) else row.item()

    def render(self) -> np.ndarray | None:
        """RGB frame (H, W, 3) when ``render_mode="rgb_array"``."""
        if not self._rng1:
            raise ResetNeeded("call reset() before render()")
        if self.render_mode is None:
            gym.logger.warn("render() called without render_mode; use render_mode='rgb_array'")
            return None
        return self._frame(self.sim.render_state(0))

    def close(self) -> None:
        """Release what the batch holds (``close()`` of the batch, if it has one: the FMU
        instances of ``backend="fmu"``)."""
        _close_batch(self.sim)


def _close_batch(sim: Any) -> None:
    close = getattr(sim, "close", None)
    if close is not None:
        close()


class BatchVectorEnv(VectorEnv):
    """Native vector shell: every sub-env stepped by one batch call, next-step autoreset.

    Sub-env ``i`` of ``reset(seed=s)`` is seeded with ``s + i`` (or ``seed[i]``);
    ``options["reset_mask"]`` resets only those sub-envs (a sub-env reset without a seed keeps
    its generator); other options go to the single env's (shared by every sub-env, held across
    autoresets). ``info["case"]``: each sub-env's case at reset, and on an autoreset step that
    of the sub-envs reset there (mask ``info["_case"]``).
    """

    metadata: dict[str, Any] = {
        "render_modes": ["rgb_array"],
        "render_fps": 50,
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def _init_vector(self, single_env: BatchEnv, sim: ArrayBatch, num_envs: int) -> None:
        self.single_env = single_env
        self.num_envs = num_envs
        self.render_mode = single_env.render_mode
        self.sim = sim
        self.single_observation_space = single_env.observation_space
        self.single_action_space = single_env.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._bounds = (
            self.action_space.low.astype(np.float64),
            self.action_space.high.astype(np.float64),
        )
        self._rngs: list[np.random.Generator | None] = []
        self._prev_done = np.zeros(num_envs, np.bool_)
        self._case_rows: dict[str, np.ndarray] = {}  # each sub-env's info["case"]

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the sub-envs (all, or those of ``options["reset_mask"]``); ``info["case"]``:
        every sub-env's case."""
        partial = options is not None and "reset_mask" in options
        mask, rngs, options = reset_plan(self.num_envs, seed, options, self._rngs)
        env = self.single_env
        env._take_options(options, seed is not None, partial, self)
        if seed is not None:
            first = seed if isinstance(seed, int | np.integer) else seed[0]
            self._np_random, self._np_random_seed = seeding.np_random(first)
        self._rngs = rngs
        reset = np.flatnonzero(mask)
        self._reset_rows(reset)
        self._prev_done[mask] = False
        self._note_case(reset)
        infos = self._infos()
        infos["case"], infos["_case"] = self._case_infos(np.ones(self.num_envs, np.bool_))
        return self.sim.observe(self._rngs), infos

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step all sub-envs; those that ended on the previous step are reset instead."""
        if not self._rngs:
            raise ResetNeeded("call reset() before step()")
        sim = self.sim
        sim.actions[...] = check_actions(actions, self.action_space.shape, *self._bounds, "actions")
        done = np.flatnonzero(self._prev_done)
        if done.size:
            self._reset_rows(done)
            self._note_case(done)
            was_reset = self._prev_done.copy()
        if done.size and hasattr(sim, "advance_holding"):
            sim.advance_holding(self._prev_done)  # sub-envs that were reset do not move
        else:
            sim.advance()
            for i in done:  # sub-envs that were reset do not move on this step
                sim.reset_state(i)
        flags = {k: v.copy() for k, v in sim.flags().items()}
        terminated = np.zeros(self.num_envs, np.bool_)
        for v in flags.values():
            terminated |= v
        truncated = sim.truncated() & ~terminated
        reward = sim.reward.copy()
        terminated[done] = truncated[done] = False
        self._prev_done = terminated | truncated
        infos = self._infos()
        mask = np.ones(self.num_envs, np.bool_)
        terms = sim.reward_terms()
        infos["reward_terms"] = {**terms, **{f"_{k}": mask for k in terms}}
        infos["_reward_terms"] = mask
        for k, v in flags.items():
            infos[k], infos[f"_{k}"] = v, mask
        if done.size:
            infos["case"], infos["_case"] = self._case_infos(was_reset)
        return sim.observe(self._rngs), reward, terminated, truncated, infos

    def _reset_rows(self, idx: np.ndarray) -> None:
        """``sim.reset`` of the sub-envs ``idx`` with their generators and the env's episode
        settings; all at once by ``sim.reset_many`` where the batch has it."""
        sim, episode = self.sim, self.single_env._episode()
        if hasattr(sim, "reset_many"):
            sim.reset_many(idx, [self._rngs[i] for i in idx], episode)
            return
        for i in idx:
            sim.reset(i, self._rngs[i], episode)

    def _note_case(self, idx: np.ndarray) -> None:
        """Record the case of the sub-envs ``idx`` just reset (their ``info["case"]``)."""
        case = self.single_env._case_arrays(self.sim, idx)
        if not self._case_rows:
            n = self.num_envs
            self._case_rows = {k: np.zeros((n, *v.shape[1:]), v.dtype) for k, v in case.items()}
        for k, v in case.items():
            self._case_rows[k][idx] = v

    def _case_infos(self, mask: np.ndarray) -> tuple[dict[str, Any], np.ndarray]:
        """``(info["case"], info["_case"])`` of the sub-envs in ``mask``: copies of every
        sub-env's case with gymnasium's masks."""
        rows = self._case_rows
        return {**{k: v.copy() for k, v in rows.items()}, **{f"_{k}": mask for k in rows}}, mask

    def _rows(self, a: np.ndarray) -> np.ndarray:
        """The accessors' value of a per-system array ``a`` (n, …): a copy."""
        return a.copy()

    def _infos(self) -> dict[str, Any]:
        infos = self.sim.info()
        mask = np.ones(self.num_envs, np.bool_)
        return {**infos, **{f"_{k}": mask for k in infos}}

    def render(self) -> tuple[np.ndarray, ...] | None:
        """One RGB frame per sub-env."""
        if self.render_mode is None:
            gym.logger.warn("render() called without render_mode; use render_mode='rgb_array'")
            return None
        return tuple(self.single_env._frame(self.sim.render_state(i)) for i in range(self.num_envs))

    def close_extras(self, **kwargs: Any) -> None:
        """Release what the batch and the single env hold (the FMU instances of
        ``backend="fmu"``); gymnasium's ``close()`` calls this once."""
        _close_batch(getattr(self, "sim", None))
        single = getattr(self, "single_env", None)
        if single is not None:
            single.close()
