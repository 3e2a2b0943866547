"""Entries of the leaderboard (:mod:`agents.leaderboard.results`): a classical baseline, an
existing policy (a saved SB3 ``.zip``, or a classical controller's name, i.e. the controller
wrapped as a policy), or a training run of an SB3 algorithm over seeds
(:func:`agents.training.train.train` with :data:`HYPERPARAMETERS`, on the task's env and
training case, then the held-out evaluation of :mod:`agents.leaderboard.cases`), plain or
residual on one of the task's classical controllers (:mod:`agents.controllers.residual`:
the policy's action is added to the controller's, scale 1).

Training uses the task's fixed env arguments on its :func:`training_case` (the nominal
payload on ``bogie-payload``; the crash scenario draws speed and payloads at each reset) and
the env's own track seeds of the training seed; the evaluation tracks are the task's held-out
seeds. A residual agent's controller is designed once, for the training case, and keeps that
design on every evaluation case (as wherever the saved policy is loaded); the baseline row of
the same controller is designed for each case (the payload task's ``lqg``: for the nominal
case, as the residual's).
"""

from __future__ import annotations

import csv
import time
from pathlib import Path
from typing import Any

import numpy as np

from agents.controllers.registry import controllers_of
from agents.leaderboard.cases import NOMINAL_CASE, checked_needs, run_task
from agents.leaderboard.results import RESULTS_DIR, provenance, write_entry
from railgym import _checks as val
from railgym.tasks import TASKS, Task, case_kwargs

__all__ = [
    "ALGOS",
    "HYPERPARAMETERS",
    "RESIDUAL_BASES",
    "baseline_entry",
    "check_residual",
    "entry_name",
    "learned_entry",
    "policy_entry",
    "residual_controllers",
    "training_case",
    "training_config",
]

#: the one hyperparameter set of each algorithm (every task): vector envs, network and SB3
#: arguments; the rest are SB3's defaults
HYPERPARAMETERS: dict[str, dict[str, Any]] = {
    "ppo": {
        "n_envs": 8,
        "n_steps": 256,
        "batch_size": 256,
        "n_epochs": 10,
        "gamma": 0.99,
        "gae_lambda": 0.95,
        "learning_rate": 3.0e-4,
        "policy_kwargs": {"net_arch": [64, 64]},
    },
    "sac": {
        "n_envs": 4,
        "learning_rate": 3.0e-4,
        "buffer_size": 200_000,
        "learning_starts": 2_000,
        "batch_size": 256,
        "gamma": 0.98,
        "policy_kwargs": {"net_arch": [64, 64]},
    },
    "td3": {
        "n_envs": 4,
        "learning_rate": 1.0e-3,
        "buffer_size": 200_000,
        "learning_starts": 2_000,
        "batch_size": 256,
        "gamma": 0.98,
        "policy_kwargs": {"net_arch": [64, 64]},
    },
}
ALGOS = tuple(HYPERPARAMETERS)
#: the classical controller that each task's residual entries of the full set correct (its
#: best baseline that the residual form runs on); the crash task has none
RESIDUAL_BASES: dict[str, str] = {
    "bogie-active": "lqg",
    "bogie-semi-active": "clipped-lqg",
    "vehicle-active": "lqg",
    "vehicle-preview": "lq-preview",
    "bogie-payload": "lqg",
}


def residual_controllers(task: Task) -> tuple[str, ...]:
    """The baselines of ``task`` that a residual agent can correct: those the residual form
    runs on (:func:`agents.controllers.registry.controllers_of` its env), ``passive`` left
    out (a residual on it is the plain agent)."""
    table = controllers_of(task.env_id)
    return tuple(name for name in task.baselines if name in table and name != "passive")


def check_residual(task: Task, name: str, field: str = "residual") -> str:
    """``name`` if it is one of :func:`residual_controllers` of ``task``; else one error
    naming ``field``."""
    options = residual_controllers(task)
    if not options:
        raise val.FieldError(
            field,
            f"{name!r}: task {task.name} has no residual form ({task.env_id} has no classical "
            "controller that agents.controllers.residual adds an action to)",
        )
    if name not in options:
        raise val.FieldError(
            field,
            f"must be a classical controller of task {task.name} ({', '.join(options)}), "
            f"got {name!r}",
        )
    return name


def entry_name(algo: str, residual: str | None = None) -> str:
    """The default name of a learned entry: ``ppo``, or ``ppo-residual-lqg``."""
    return algo if residual is None else f"{algo}-residual-{residual}"


def training_case(task: Task) -> str:
    """The case whose env arguments training uses."""
    return NOMINAL_CASE if task.name == "bogie-payload" else task.cases[0].label


def training_config(
    task: Task, algo: str, steps: int, seed: int, residual: str | None = None
) -> dict[str, Any]:
    """The :func:`agents.training.train.train` config of ``algo`` on ``task`` (``residual``:
    the agent's action added to this classical controller's, with the env arguments the
    controller needs)."""
    hyper = dict(HYPERPARAMETERS[algo])
    n_envs = hyper.pop("n_envs")
    env_kwargs = case_kwargs(task.name, training_case(task))
    extra: dict[str, Any] = {}
    if residual is not None:
        needs = controllers_of(task.env_id)[check_residual(task, residual)][2]
        env_kwargs.update(checked_needs(task, dict(needs)))
        extra = {"residual": residual}
    return {
        task.env_id: {
            "algo": algo,
            "n_timesteps": steps,
            "policy": "MlpPolicy",
            "n_envs": n_envs,
            "seed": seed,
            "env_kwargs": env_kwargs,
            "eval_freq": max(steps // 5, 1),
            "n_eval_episodes": 2,
            "checkpoint_freq": steps,
            **extra,
            **hyper,
        }
    }


def _entry(
    task: Task,
    name: str,
    kind: str,
    metric: dict[str, list[float]],
    config: dict[str, Any],
    wall_s: float,
    seeds: list[int],
    steps: int | None = None,
    curves: dict[str, Any] | None = None,
) -> dict[str, Any]:
    return {
        "task": task.name,
        "name": name,
        "kind": kind,
        "seeds": seeds,
        "steps": steps,
        "metric": metric,
        "curves": curves or {},
        "provenance": provenance(config, wall_s),
    }


def _checked(task: str, name: str) -> Task:
    if task not in TASKS:
        raise val.FieldError("task", f"unknown task {task!r}; tasks: {', '.join(TASKS)}")
    if not name or "/" in name or name.startswith("."):
        raise val.FieldError("name", f"must be a plain file name, got {name!r}")
    return TASKS[task]


def policy_entry(
    task: str,
    policy: str,
    name: str | None = None,
    kind: str = "policy",
    results: Path = RESULTS_DIR,
    trust: bool = False,
) -> dict[str, Any]:
    """Evaluate ``policy`` (a controller name of the task or a saved policy) on every case of
    ``task`` and store it as entry ``name`` (default: the policy's name or file stem)."""
    name = name or Path(policy).stem
    t = _checked(task, name)
    t0 = time.perf_counter()
    metric = {k: [v] for k, v in run_task(task, policy, trust).items()}
    entry = _entry(t, name, kind, metric, {"policy": str(policy)}, time.perf_counter() - t0, [0])
    write_entry(entry, results)
    return entry


def baseline_entry(task: str, name: str, results: Path = RESULTS_DIR) -> dict[str, Any]:
    """The classical baseline ``name`` of ``task`` as an entry of kind ``baseline``."""
    return policy_entry(task, name, name, "baseline", results)


def _curve(run: Path) -> dict[str, list[float]]:
    """The learning curve of a training run: evaluation reward against steps and wall time."""
    with (run / "eval.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    return {
        k: [float(r[c]) for r in rows]
        for k, c in (("steps", "timesteps"), ("wall_s", "wall_s"), ("reward", "mean_reward"))
    }


def learned_entry(
    task: str,
    algo: str,
    seeds: int,
    steps: int,
    runs: Path,
    name: str | None = None,
    results: Path = RESULTS_DIR,
    residual: str | None = None,
) -> dict[str, Any]:
    """Train ``algo`` on ``task`` for ``steps`` env steps with seeds ``0 … seeds − 1`` (run
    folders under ``runs``), plain or residual on the classical controller ``residual``,
    evaluate each seed's final policy on every case as ``railgym evaluate`` runs it, and store
    the entry ``name`` (default :func:`entry_name`) with the learning curves and the
    evaluation's wall time (``eval_wall_s``, s, all seeds)."""
    from agents.training.train import train

    name = name or entry_name(algo, residual)
    t = _checked(task, name)
    if algo not in ALGOS:
        raise val.FieldError("algo", f"must be one of {ALGOS}, got {algo!r}")
    if residual is not None:
        check_residual(t, residual)
    seeds = val.integer(seeds, "seeds", min=1, max=100)
    steps = val.integer(steps, "steps", min=1)
    metric: dict[str, list[float]] = {label: [] for label in t.case_labels}
    curves, wall, evaluation = {}, 0.0, 0.0
    for seed in range(seeds):
        config = training_config(t, algo, steps, seed, residual)
        t0 = time.perf_counter()
        out = train(
            config, Path(runs) / task / name / f"seed{seed}", progress=False, overwrite=True
        )
        t1 = time.perf_counter()
        wall += t1 - t0
        curves[str(seed)] = _curve(out)
        for label, value in run_task(task, str(out / "model.zip")).items():
            metric[label].append(value)
        evaluation += time.perf_counter() - t1
    config = training_config(t, algo, steps, 0, residual)
    entry = _entry(t, name, "learned", metric, config, wall, list(range(seeds)), steps, curves)
    entry["metric"] = {k: [float(v) for v in np.asarray(vs)] for k, vs in metric.items()}
    entry["eval_wall_s"] = round(evaluation, 1)
    write_entry(entry, results)
    return entry
