"""The reference values of each task's normalised score: the passive vehicle's metric and the
bound's per case (:data:`railgym.tasks.REFERENCES_FILE`).

The bound of a case is the best metric found by a method no causal controller can beat on
it, *up to the search*: every command sequence is feasible, so the clairvoyant optimum is
at most the best one found, and a causal controller produces one such sequence. The value
stored is the least of the search's result and every baseline's (each a feasible sequence
too), so it is at least as good as every baseline by construction; it is an upper estimate of
the clairvoyant optimum, a later controller could beat it by the search's gap.

* ``bogie-semi-active``: per track, the open-loop damper commands of
  :func:`agents.evaluation.semi_active_bound.optimise_track` (L-BFGS-B with forward-difference
  gradients from the baselines' closed-loop commands);
* ``crash-adaptive``: per case, :func:`search_commands`, a coordinate search over piecewise
  constant absorber commands, started from the best of every constant setting and every
  baseline's recorded commands (the crash is deterministic: a causal controller is one
  command sequence);
* ``bogie-payload`` (linear suspension): per track, the exact clairvoyant optimum of
  :func:`agents.leaderboard.linear_bound.linear_bound` (a convex problem);
* the other active tasks: 0 m/s², a trivial bound (no a_w is negative).
"""

from __future__ import annotations

import itertools
from typing import Any, NamedTuple

import numpy as np

from agents.evaluation.semi_active_bound import optimise_track
from agents.leaderboard.cases import crash_cost, make_case_env, policy_factory, run_task
from agents.leaderboard.linear_bound import linear_bound
from railgym.tasks import TASKS, Task

__all__ = [
    "CRASH_LEVELS",
    "CRASH_SEGMENT",
    "CommandSearch",
    "Sequences",
    "crash_bound",
    "reference_values",
    "replay",
    "search_commands",
    "semi_active_bound",
]

#: command levels of the crash search (absorber action, −1 … 1)
CRASH_LEVELS = tuple(np.linspace(-1.0, 1.0, 9))
#: control steps per piece of the crash search's commands (0.05 s at 5 ms)
CRASH_SEGMENT = 10


class Sequences:
    """Open-loop commands: sub-env ``i`` applies ``u[i, k]`` at its ``k``-th step (the last
    row held beyond the end), whatever it observes."""

    def __init__(self, u: np.ndarray) -> None:
        self.u = np.asarray(u, np.float32)
        self.k = 0

    def predict(self, observation: Any, **_: Any) -> tuple[np.ndarray, None]:
        step = min(self.k, self.u.shape[1] - 1)
        self.k += 1
        return self.u[:, step], None


class _Recorder:
    """A controller whose actions are kept (``actions``: one (n, zones) per step)."""

    def __init__(self, ctrl: Any) -> None:
        self.ctrl, self.actions = ctrl, []

    def predict(self, observation: Any, **kwargs: Any) -> tuple[np.ndarray, None]:
        action, _ = self.ctrl.predict(observation, **kwargs)
        action = np.clip(np.asarray(action, np.float32), -1.0, 1.0)
        self.actions.append(action.copy())
        return action, None


def replay(task: Task, label: str, u: np.ndarray) -> np.ndarray:
    """Crash cost (g) of each command sequence ``u`` (k, steps, zones) on case ``label``."""
    from agents.controllers.crash_baselines import rollout

    venv = make_case_env(task, label, {}).unwrapped
    env = type(venv)(num_envs=len(u), **dict(venv.cfg.arguments()))
    runs = rollout(env, Sequences(u), seed=task.seed, options=dict(task.case(label).options))
    return np.array([np.inf if r.diverged else crash_cost(r.criteria()) for r in runs])


class CommandSearch(NamedTuple):
    """Result of :func:`search_commands`: the best commands (steps, zones), their crash cost
    (g), the start's cost and the costs of the recorded baselines' replays."""

    u: np.ndarray
    cost: float
    start_cost: float
    baselines: dict[str, float]


def _recorded(task: Task, label: str, name: str) -> np.ndarray:
    """The commands (steps, zones) baseline ``name`` applied on case ``label``."""
    from agents.controllers.crash_baselines import rollout

    factory, _ = policy_factory(task, name)
    venv = make_case_env(task, label).unwrapped
    rec = _Recorder(factory(venv, label))
    rollout(venv, rec, seed=task.seed, options=dict(task.case(label).options))
    return np.array([a[0] for a in rec.actions])


def _held(u: np.ndarray, steps: int) -> np.ndarray:
    """``u`` (k, zones) with its last row held to ``steps`` rows."""
    return np.vstack([u, np.repeat(u[-1:], steps - len(u), axis=0)])


def search_commands(
    task: Task,
    label: str,
    levels: tuple[float, ...] = CRASH_LEVELS,
    segment: int = CRASH_SEGMENT,
    segments: int = 14,
    sweeps: int = 2,
    baselines: tuple[str, ...] = (),
) -> CommandSearch:
    """Best piecewise-constant absorber commands found on case ``label``: ``segments``
    pieces of ``segment`` steps (the last held to the end; the recorded commands of a
    baseline are kept whole), each zone's command of a piece in ``levels``. Start: the best
    of every constant setting of ``levels`` and the recorded commands of ``baselines``; then
    ``sweeps`` passes of a coordinate search (each piece and zone set to every level, all at
    once in one vector env; a change only where it lowers the cost)."""
    recorded = {name: _recorded(task, label, name) for name in baselines}
    steps = max([segment * segments, *(len(u) for u in recorded.values())])
    zones = make_case_env(task, label).single_action_space.shape[0]
    consts = np.array(list(itertools.product(levels, repeat=zones)))
    starts = [np.repeat(c[None, :], steps, axis=0) for c in consts]
    starts += [_held(u, steps) for u in recorded.values()]
    costs = replay(task, label, np.array(starts))
    base_costs = dict(zip(recorded, costs[len(consts) :].tolist(), strict=True))
    best = int(np.argmin(costs))
    u, cost = starts[best].copy(), float(costs[best])
    start_cost = cost
    for _ in range(sweeps):
        for piece, zone in itertools.product(range(segments), range(zones)):
            cand = np.repeat(u[None], len(levels), axis=0)
            cand[:, piece * segment : (piece + 1) * segment, zone] = np.array(levels)[:, None]
            c = replay(task, label, cand)
            k = int(np.argmin(c))
            if c[k] < cost:
                u, cost = cand[k], float(c[k])
    return CommandSearch(u, cost, start_cost, base_costs)


def crash_bound(task: Task, label: str) -> float:
    """Bound of a crash case: :func:`search_commands` from the task's baselines."""
    return search_commands(task, label, baselines=task.baselines).cost


def semi_active_bound(task: Task, label: str, screen_eval: int = 4, max_eval: int = 10) -> float:
    """Bound of a semi-active case: the mean over its tracks of the best of
    :func:`~agents.evaluation.semi_active_bound.optimise_track` and its baselines."""
    case = task.case(label)
    tc, duration = int(case.env_kwargs["track_class"]), float(task.env_kwargs["duration"])
    best = []
    for i in range(task.episodes):
        r = optimise_track(
            tc,
            task.seed + i,
            duration,
            screen_eval=screen_eval,
            max_eval=max_eval,
            env_id=task.env_id,
        )
        best.append(min(r.a_w.values()))
    return float(np.mean(best))


def reference_values(name: str, quick: bool = False) -> dict[str, dict[str, Any]]:
    """Case → ``{"passive", "bound", "bound_method", "baselines": {name: value}}`` of task
    ``name``: the bound is the least of every baseline's value and the search's
    (``bound_method`` ``"search"``), or 0 (``"trivial"``, the active tasks), or, with
    ``quick`` (no search), the best baseline's alone (``"baselines"``)."""
    task = TASKS[name]
    values = {b: run_task(name, b) for b in task.baselines}
    out: dict[str, dict[str, Any]] = {}
    for label in task.case_labels:
        base = {b: values[b][label] for b in task.baselines}
        found, method = np.inf, "baselines"
        if "trivial" in task.bound:
            found, method = 0.0, "trivial"
        elif not quick and task.env_id.startswith("railgym/TrainCrash"):
            found, method = crash_bound(task, label), "search"
        elif not quick and task.name == "bogie-semi-active":
            found, method = semi_active_bound(task, label), "search"
        elif not quick and "exact" in task.bound:
            tracks = [linear_bound(name, label, i) for i in range(task.episodes)]
            found, method = float(np.mean(tracks)), "exact"
        out[label] = {
            "passive": base["passive"],
            "bound": float(min(found, *base.values())),
            "bound_method": method,
            "baselines": base,
        }
    return out
