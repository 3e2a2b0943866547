"""Train stable-baselines3 agents on railgym environments from YAML files (agents.training.train
format).

Usage::

    railgym train CONFIG [-o DIR] [--overwrite] [--timesteps N] [--seed S] [--algo ALGO]
                         [--quiet] [--debug]

``CONFIG`` is a ``.yaml`` / ``.yml`` file or the name of a packaged config
(``ppo_vertical``, ``sac_vertical``, ``ppo_crash``; :func:`railgym._checks.resolve_yaml`).
An rl-zoo3 hyperparameter file is read as well, with its algorithm given by ``--algo`` as to
rl-zoo3 (``railgym train railgym/configs/agents/rlzoo_vertical.yml --algo ppo``):
one file serves both.

The full training run of the vertical suspension agent (a documented command, not a CI test):
PPO, 4·10⁶ steps on the surrogate backend, evaluated every 10⁵ steps on the reference model
(4 tracks, FRA class 5, 20 s); measured run times and results are in ``docs/results.md``::

    railgym train configs/agents/ppo_vertical.yaml

``configs/agents/sac_vertical.yaml`` is the off-policy alternative (3·10⁵ steps),
``configs/agents/ppo_crash.yaml`` trains the absorbers of ``railgym/TrainCrash-v1``,
``configs/agents/ppo_vertical_lqg.yaml`` and ``ppo_vehicle_vertical_lqg.yaml`` train a
correction of the LQG (``residual``, :mod:`agents.controllers.residual`).

Config file: one top-level key, the Gymnasium env id; the fields and their limits are in
:mod:`agents.training.train_config`.

Output folder (``--out``; default ``runs/<config-stem>/`` in the working directory; an existing
non-empty folder only with ``--overwrite``): ``model.zip`` (the final policy),
``best_model.zip`` (best evaluation reward), ``manifest.json`` (the SHA-256 of both zips, checked
by ``railgym evaluate``, which reads only their weights), ``checkpoints/`` (with its own
``manifest.json``: ``railgym evaluate`` takes a checkpoint as a final model), ``progress.csv``
(stable-baselines3's training log), ``eval.csv`` (per evaluation: mean/std episode reward,
episode length and the mean of every numeric ``info`` entry at episode end, e.g.
``mean_rms_carbody_acc`` in m/s²) and ``config.yaml`` (the resolved config with its seeds,
loadable again, plus a ``run`` section: package versions, wall and CPU time of ``learn``, env
steps per wall second overall (``steps_per_s``, evaluations included) and of the rollouts and
the updates alone (``rollout_s``, ``rollout_steps_per_s``, ``update_s``,
``update_steps_per_s``; ``eval_s``: the evaluations). The same rates, so far, are in
``progress.csv`` (``time/rollout_steps_per_s``, ``time/update_steps_per_s``).

SB3 expects vector envs that reset a finished sub-env in the same step and put the final
observation into ``info["terminal_observation"]``; :class:`GymVecToSB3` provides this on top of
Gymnasium 1.x vector envs (``NEXT_STEP`` or ``SAME_STEP`` autoreset).
"""

from __future__ import annotations

import csv
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym
import numba
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from tqdm import tqdm

from agents._extras import extra_error

try:  # the 'agents' extra
    import stable_baselines3 as sb3
    import torch
    from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback
    from stable_baselines3.common.logger import configure
    from stable_baselines3.common.utils import set_random_seed
    from stable_baselines3.common.vec_env import VecEnv, VecMonitor
except ImportError as _err:
    raise extra_error(_err, "training (agents.training.train)") from _err

from agents.controllers.action_hold import ActionHold
from agents.controllers.registry import build_controller
from agents.controllers.residual import ResidualVectorEnv
from agents.policies.policy_io import write_manifest
from agents.training.envelope import EnvelopeVectorEnv, check_envelope
from agents.training.run_files import run_folder, versions, write_config
from agents.training.train_config import (
    ALGOS,
    MAX_SEED,
    MAX_TIMESTEPS,
    VECTORIZATION_MODES,
    TrainConfig,
    hyperparameters,
    load_config,
)
from railgym import _checks as val
from railgym.report.output import atomic_path, prepare_output_dir


def _infos_at(infos: dict[str, Any], idx: np.ndarray) -> list[dict[str, Any]]:
    """Sub-envs ``idx`` of Gymnasium's batched ``info`` dict (values + ``_key`` masks): one
    dict each, in the order of ``idx``."""
    out: list[dict[str, Any]] = [{} for _ in idx]
    for key, value in infos.items():
        if key.startswith("_"):
            continue
        mask = infos.get(f"_{key}")
        parts = _infos_at(value, idx) if isinstance(value, dict) else None
        for j, i in enumerate(idx):
            if mask is None or mask[i]:
                out[j][key] = value[i] if parts is None else parts[j]
    return out


class GymVecToSB3(VecEnv):
    """stable-baselines3 ``VecEnv`` view of a Gymnasium 1.x ``VectorEnv``.

    SB3 wants a finished sub-env reset within the same step: the returned observation is the
    first one of the new episode and ``info["terminal_observation"]`` the last one of the old.

    * ``SAME_STEP`` vector envs already do this (``info["final_obs"]``).
    * ``NEXT_STEP`` vector envs reset a finished sub-env on the following ``step`` call and
      ignore its action there; each sub-env keeps its own seeded stream, so sub-env ``i``
      matches a single env seeded ``seed + i``. When every sub-env finishes in the same step
      (fixed-length episodes started together), the adapter makes that reset step at once.
      When only some finish, a step would also advance the others, so the finished ones are
      reset with Gymnasium's partial reset ``reset(options={"reset_mask": mask})`` (as
      ``SyncVectorEnv`` has). If the env rejects it (``ValueError``), the adapter warns once
      and from then on ends every unfinished episode as truncated (``TimeLimit.truncated``;
      SB3 bootstraps its value from ``terminal_observation``) and resets the whole vector env
      with a seed drawn from its generator (seeded by :meth:`reset` after :meth:`seed`).

    The ``infos`` of a step are empty dicts except for the sub-envs whose episode ended there
    (all that SB3 reads): the final step's ``info`` with ``terminal_observation`` and
    ``TimeLimit.truncated``; ``reset_infos[i]`` is the ``info`` of sub-env ``i``'s last reset.
    Observations and rewards are the vector env's arrays (rewards as float32), not copied.

    ``get_attr``/``set_attr``/``env_method`` act on the vector env itself (shared by all
    sub-envs). The wrapped env must not be stepped by anyone else.
    """

    def __init__(self, venv: VectorEnv) -> None:
        mode = venv.metadata.get("autoreset_mode", AutoresetMode.NEXT_STEP)
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(f"venv autoreset_mode must be NEXT_STEP or SAME_STEP, got {mode}")
        self.venv = venv
        self.autoreset_mode = mode
        self.partial_reset = True
        self._rng = np.random.default_rng()
        self._actions: np.ndarray | None = None
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)

    def reset(self) -> np.ndarray:
        """Reset all sub-envs; uses the seed of :meth:`seed` once (sub-env ``i``: seed + i)."""
        seed = self._seeds[0]
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        obs, infos = self.venv.reset(seed=seed, options=self._options[0] or None)
        self.reset_infos = _infos_at(infos, np.arange(self.num_envs))
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        obs, rewards, terminated, truncated, infos = self.venv.step(self._actions)
        dones = terminated | truncated
        out: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if dones.any() and self.autoreset_mode == AutoresetMode.SAME_STEP:
            ended = np.flatnonzero(dones)
            for i, info in zip(ended, _infos_at(infos, ended), strict=True):
                out[i] = {**info.get("final_info", {}), "terminal_observation": info["final_obs"]}
        elif dones.any():
            obs, cut = self._next_step_reset(obs, dones, infos, out)
            if cut:  # every unfinished episode was ended too
                truncated, dones = truncated | ~dones, np.ones(self.num_envs, np.bool_)
        for i in np.flatnonzero(dones):
            out[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return obs, np.asarray(rewards, np.float32), dones, out

    def _next_step_reset(
        self, obs: np.ndarray, dones: np.ndarray, infos: dict[str, Any], out: list[dict]
    ) -> tuple[np.ndarray, bool]:
        """Reset the finished sub-envs of a NEXT_STEP env now (see the class docstring) and
        put the ended episodes' final ``infos`` into ``out``. Returns the new observations and
        whether all sub-envs had to be reset."""
        if dones.all():
            new, _, _, _, new_infos = self.venv.step(self._actions)  # sub-envs only reset
        elif self.partial_reset:
            try:
                new, new_infos = self.venv.reset(options={"reset_mask": dones.copy()})
            except ValueError as err:
                warnings.warn(
                    f"{type(self.venv).__name__} has no partial reset ({err}); "
                    "unfinished episodes are truncated whenever one ends",
                    stacklevel=3,
                )
                self.partial_reset = False
        cut = not (dones.all() or self.partial_reset)
        if cut:
            new, new_infos = self.venv.reset(seed=int(self._rng.integers(2**31 - 1)))
        ended = np.arange(self.num_envs) if cut else np.flatnonzero(dones)
        for i, info in zip(ended, _infos_at(infos, ended), strict=True):
            out[i] = {**info, "terminal_observation": obs[i]}
        for i, info in zip(ended, _infos_at(new_infos, ended), strict=True):
            self.reset_infos[i] = info
        return new, cut

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        value = getattr(self.venv, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *args: Any, indices: Any = None, **kw: Any) -> list:
        result = getattr(self.venv, method_name)(*args, **kw)
        return [result for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


def make_vec(
    env_id: str,
    num_envs: int,
    env_kwargs: dict[str, Any],
    mode: str | None = None,
    field: str = "env_kwargs",
) -> VectorEnv:
    """The env's native vector env (``mode="vector_entry_point"``, the default where the env
    has one) or a ``SAME_STEP`` ``SyncVectorEnv`` of single envs (``mode="sync"``).

    A bad env argument is a ``ValueError`` that starts with ``field`` (the config key the
    arguments come from).
    """
    if mode not in (None, *VECTORIZATION_MODES):
        raise ValueError(f"vectorization_mode must be one of {VECTORIZATION_MODES}, got {mode!r}")
    native = gym.spec(env_id).vector_entry_point is not None
    if mode == "vector_entry_point" and not native:
        raise ValueError(f"vectorization_mode: {env_id} has no native vector env")
    if mode != "sync" and native:
        options: dict[str, Any] = {"vectorization_mode": "vector_entry_point"}
    else:
        options = {
            "vectorization_mode": "sync",
            "vector_kwargs": {"autoreset_mode": AutoresetMode.SAME_STEP},
        }
    try:
        return gym.make_vec(env_id, num_envs, **options, **env_kwargs)
    except (TypeError, ValueError) as err:  # the env's own argument errors, or unknown names
        raise val.FieldError(field, f"{field}: {err}", full=True) from None


def evaluate(policy: Any, venv: VectorEnv, seed: int) -> dict[str, float]:
    """One episode per sub-env of ``venv`` (reset with ``seed``), deterministic actions.

    ``policy`` has SB3's ``predict(obs, deterministic=True)``: a model or a controller.
    Returns ``mean_reward``, ``std_reward``, ``mean_length`` and the mean over the episodes of
    every numeric or boolean ``info`` entry at their end: ``mean_<key>`` for a scalar (e.g.
    ``mean_rms_carbody_acc``, m/s²), ``mean_<key>_<j>`` for the entries of a 1-D array.
    """
    obs, _ = venv.reset(seed=seed)
    n = venv.num_envs
    returns, lengths = np.zeros(n), np.zeros(n, np.int64)
    active = np.ones(n, np.bool_)
    final: list[dict[str, Any]] = [{} for _ in range(n)]
    while active.any():
        action, _ = policy.predict(obs, deterministic=True)
        obs, rewards, terminated, truncated, infos = venv.step(action)
        returns[active] += rewards[active]
        lengths[active] += 1
        ended = (terminated | truncated) & active
        if ended.any():
            idx = np.flatnonzero(ended)
            for i, info in zip(idx, _infos_at(infos, idx), strict=True):
                final[i] = info.get("final_info", info)
            active &= ~ended
    stats = {
        "mean_reward": float(returns.mean()),
        "std_reward": float(returns.std()),
        "mean_length": float(lengths.mean()),
    }
    for key, value in final[0].items():
        value = np.asarray(value)
        if value.dtype.kind not in "biuf" or value.ndim > 1:
            continue
        mean = np.mean([np.asarray(f[key], np.float64) for f in final], axis=0)
        if value.ndim == 0:
            stats[f"mean_{key}"] = float(mean)
        else:
            stats.update({f"mean_{key}_{j}": float(m) for j, m in enumerate(mean)})
    return stats


class _ProgressBar(BaseCallback):
    """tqdm bar over the environment steps of ``learn``."""

    def _on_training_start(self) -> None:
        total = self.locals["total_timesteps"] - self.model.num_timesteps
        # on stderr, off when it is not a terminal (and with --quiet)
        self.bar = tqdm(total=total, unit="step", dynamic_ncols=True, disable=None)

    def _on_step(self) -> bool:
        self.bar.update(self.training_env.num_envs)
        return True

    def _on_training_end(self) -> None:
        self.bar.close()


def _rate(steps: int, seconds: float) -> float | None:
    """Steps per second, 1/s (``None`` for a phase that took no measurable time)."""
    return round(steps / seconds, 1) if seconds > 0 else None


class _Timing(BaseCallback):
    """Wall time of ``learn`` split into collecting env steps (``rollout_s``, s, evaluations
    excluded), updating the networks (``update_s``, s) and evaluating (``eval_s``, s, added by
    :class:`_EvalCallback`); the env steps per second of rollouts and updates so far go to
    SB3's log (``time/rollout_steps_per_s``, ``time/update_steps_per_s``). First in the
    callback list, so that the evaluation after the last update is not update time."""

    def __init__(self) -> None:
        super().__init__()
        self.rollout_s = self.update_s = self.eval_s = 0.0
        self._start = self._eval_at_start = 0.0
        self._end: float | None = None  # end of the last rollout: an update follows it

    def _on_rollout_start(self) -> None:
        self._start, self._eval_at_start = time.perf_counter(), self.eval_s
        if self._end is not None:
            self.update_s += self._start - self._end
            self.logger.record("time/update_steps_per_s", _rate(self.num_timesteps, self.update_s))

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        self._end = time.perf_counter()
        self.rollout_s += self._end - self._start - (self.eval_s - self._eval_at_start)
        self.logger.record("time/rollout_steps_per_s", _rate(self.num_timesteps, self.rollout_s))

    def _on_training_end(self) -> None:
        if self._end is not None:
            self.update_s += time.perf_counter() - self._end
            self._end = None


class _EvalCallback(BaseCallback):
    """Every ``freq`` steps and after the last update (the saved model): :func:`evaluate`, a
    row of ``eval.csv`` and ``best_model.zip`` on a new best mean reward; the time it takes
    is added to ``timing.eval_s``."""

    def __init__(
        self,
        venv: VectorEnv,
        seed: int,
        freq: int,
        out: Path,
        echo: list[str] | None,
        timing: _Timing,
    ) -> None:
        super().__init__()
        self.venv, self.seed, self.freq, self.out, self.echo = venv, seed, freq, out, echo
        self.timing = timing
        self.next_eval, self.best = freq, -np.inf
        self.t0 = time.perf_counter()
        self.fields: list[str] | None = None

    def _on_training_start(self) -> None:
        self.total = self.locals["total_timesteps"]

    def _on_step(self) -> bool:
        if self.next_eval <= self.num_timesteps < self.total:
            self.next_eval += self.freq * (1 + (self.num_timesteps - self.next_eval) // self.freq)
            self._evaluate()
        return True

    def _on_training_end(self) -> None:
        self._evaluate()

    def _evaluate(self) -> None:
        t0 = time.perf_counter()
        stats = evaluate(self.model, self.venv, self.seed)
        row = {
            "timesteps": self.num_timesteps,
            "wall_s": round(time.perf_counter() - self.t0, 2),
            **stats,
        }
        path = self.out / "eval.csv"
        with path.open("w" if self.fields is None else "a", newline="") as fh:
            if self.fields is None:
                self.fields = list(row)
                csv.writer(fh).writerow(self.fields)
            csv.DictWriter(fh, self.fields, extrasaction="ignore").writerow(row)
        if stats["mean_reward"] > self.best:
            self.best = stats["mean_reward"]
            with atomic_path(self.out / "best_model.zip") as tmp:
                self.model.save(tmp)
        if self.echo is not None:
            shown = [
                k
                for k in stats
                for name in self.echo
                if k == f"mean_{name}" or k.removeprefix(f"mean_{name}_").isdigit()
            ]
            extra = "".join(f", {k[5:]} {stats[k]:.4g}" for k in shown)
            tqdm.write(
                f"eval @ {self.num_timesteps} steps: reward {stats['mean_reward']:.4g} "
                f"± {stats['std_reward']:.3g}{extra}"
            )
        self.timing.eval_s += time.perf_counter() - t0


def _replaced(flag: str, given: int, key: str, value: int, show: bool) -> None:
    """The note on stderr (not with ``--quiet``) that the flag's value replaces the config's
    other one: an explicit value wins, never silently."""
    if show and given != value:
        print(f"note: {flag} {given} replaces the config's {key}: {value}", file=sys.stderr)


def train(
    config: str | Path | dict[str, Any],
    out: str | Path | None = None,
    total_timesteps: int | None = None,
    progress: bool = True,
    seed: int | None = None,
    overwrite: bool = False,
    algo: str | None = None,
) -> Path:
    """Train the config's algorithm on its env; returns the output folder.

    ``out`` defaults to ``runs/<config stem>/`` in the working directory (required for a dict
    config); an existing non-empty ``out`` needs ``overwrite``. ``total_timesteps`` and
    ``seed`` override the config's ``n_timesteps`` and ``seed``; ``algo`` is the algorithm of
    an rl-zoo3 hyperparameter file (which has none). Everything is checked before training
    starts.
    """
    cfg = load_config(config, algo)
    out = run_folder(config, out)
    if total_timesteps is not None:
        given = val.integer(total_timesteps, "total_timesteps", 1, MAX_TIMESTEPS)
        _replaced("--timesteps", given, "n_timesteps", cfg.n_timesteps, progress)
        cfg.n_timesteps = given
    if seed is not None:
        given = val.integer(seed, "seed", min=0, max=MAX_SEED)
        _replaced("--seed", given, "seed", cfg.seed, progress)
        cfg.seed = given
    torch.set_num_threads(cfg.n_threads)
    set_random_seed(cfg.seed)
    mode = cfg.vectorization_mode
    venv = make_vec(cfg.env_id, cfg.n_envs, cfg.env_kwargs, mode)
    if cfg.envelope is not None:
        venv = EnvelopeVectorEnv(venv, check_envelope(cfg.envelope), cfg.seed)
    venv = _residual_and_hold(venv, cfg, venv)
    env = VecMonitor(GymVecToSB3(venv))
    opened: list[Any] = [env]
    try:  # evaluation env, model and output folder before anything is written
        eval_kwargs = {**cfg.env_kwargs, **cfg.eval_env_kwargs}
        eval_venv = make_vec(cfg.env_id, cfg.n_eval_episodes, eval_kwargs, mode, "eval_env_kwargs")
        opened.append(eval_venv)
        eval_venv = _residual_and_hold(eval_venv, cfg, venv)  # the training case's base
        hyper = {"device": "cpu", **hyperparameters(ALGOS[cfg.algo], cfg.hyperparameters)}
        try:
            model = ALGOS[cfg.algo](cfg.policy, env, seed=cfg.seed, **hyper)
        except (TypeError, ValueError, AssertionError) as err:  # SB3's own checks
            raise ValueError(f"{cfg.algo} settings: {err}") from None
        out = prepare_output_dir(out, overwrite)
    except ValueError:
        for venv in opened:
            venv.close()
        raise
    run: dict[str, Any] = {"versions": versions(sb3, torch)}
    write_config(out, cfg, run)
    model.set_logger(configure(str(out), ["csv"]))
    echo = cfg.eval_echo if progress else None
    every = max(cfg.checkpoint_freq // cfg.n_envs, 1)
    timing = _Timing()
    callbacks: list[BaseCallback] = [
        timing,
        _EvalCallback(eval_venv, cfg.eval_seed, cfg.eval_freq, out, echo, timing),
        CheckpointCallback(every, str(out / "checkpoints"), name_prefix="model"),
    ]
    if progress:
        callbacks.append(_ProgressBar())
    run.update(_learn(model, cfg, callbacks, timing))
    with atomic_path(out / "model.zip") as tmp:
        model.save(tmp)
    write_manifest(out)
    if (out / "checkpoints").is_dir():
        write_manifest(out / "checkpoints")
    env.close()
    eval_venv.close()
    write_config(out, cfg, run)
    return out


def _residual_and_hold(venv: Any, cfg: TrainConfig, base: Any) -> Any:
    """``venv`` with the config's residual controller (designed on ``base``, the training
    vector env) and action hold, where the config asks for them."""
    if cfg.residual is not None:
        controller = build_controller(cfg.env_id, cfg.residual, base)
        venv = ResidualVectorEnv(venv, controller, cfg.residual_scale)
    if cfg.action_hold > 1:
        venv = ActionHold(venv, cfg.action_hold)
    return venv


def _learn(
    model: Any, cfg: TrainConfig, callbacks: list[BaseCallback], timing: _Timing
) -> dict[str, Any]:
    """Train ``model`` for the config's timesteps on its env threads; the run's times (s) and
    speeds (steps/s)."""
    t0, cpu0 = time.perf_counter(), time.process_time()
    threads = numba.get_num_threads()
    numba.set_num_threads(min(cfg.env_threads, numba.config.NUMBA_NUM_THREADS))
    try:
        model.learn(cfg.n_timesteps, callback=callbacks)
    finally:
        numba.set_num_threads(threads)
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    steps = int(model.num_timesteps)
    return {
        "wall_s": round(wall, 1),
        "steps_per_s": _rate(steps, wall),
        "timesteps": steps,
        "cpu_s": round(cpu, 1),
        "rollout_s": round(timing.rollout_s, 1),
        "rollout_steps_per_s": _rate(steps, timing.rollout_s),
        "update_s": round(timing.update_s, 1),
        "update_steps_per_s": _rate(steps, timing.update_s),
        "eval_s": round(timing.eval_s, 1),
    }
