"""Controller evaluations as parallel tasks (:func:`railgym.parallel.run_tasks`).

* :func:`controller_sweep` — comfort indices (:func:`agents.evaluation.runs.run_policy`) of one
  controller factory on a list of env settings (track classes, backends, speeds, …).
* :func:`evaluate_sweep` — the rows of ``railgym evaluate`` (vertical env), one task per
  (track class, policy); ``railgym evaluate --workers N --address ADDR`` is
  ``evaluate_sweep(..., workers=args.workers, address=args.address)``.

Every task runs its episodes on the tracks of ``seed + i`` (sub-env ``i``), so the numbers do
not depend on the number of workers. For the process pool and Ray the factory must be
picklable: a controller class, or ``functools.partial`` of one (not a lambda).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

from agents.commands.flags import MAX_EPISODES
from agents.controllers.registry import ENV_ID
from agents.evaluation.runs import PolicyTask, loaded_policy, run_policy
from agents.policies.loading import load_policy
from railgym import _checks as val
from railgym.parallel import run_tasks


class ControllerTask(NamedTuple):
    """``run_policy(factory, env_kwargs, episodes, seed)`` as one task."""

    factory: Callable[[Any], Any]  #: env → object with ``predict``
    env_kwargs: dict[str, Any]
    episodes: int
    seed: int


def _run_controller(task: ControllerTask) -> dict[str, float]:
    return run_policy(task.factory, task.env_kwargs, task.episodes, task.seed)


def _run_policy(task: PolicyTask) -> dict[str, float]:
    factory, env_kwargs = loaded_policy(task.policy, task.trust, task.env_kwargs, task.env_id)
    return run_policy(factory, env_kwargs, task.episodes, task.seed, task.env_id)


def controller_sweep(
    factory: Callable[[Any], Any],
    cases: Sequence[dict[str, Any]],
    episodes: int = 10,
    seed: int = 1000,
    workers: int = 1,
    address: str | None = None,
) -> list[dict[str, float]]:
    """Comfort indices of ``factory``'s controller for each env setting of ``cases`` (keyword
    arguments of the newest ``railgym/VerticalSuspension``, e.g. ``{"backend": "reference",
    "track_class": 4}``), in the order of ``cases``."""
    episodes = val.integer(episodes, "episodes", min=1, max=MAX_EPISODES)
    seed = val.integer(seed, "seed", min=0)
    tasks = [ControllerTask(factory, dict(kw), episodes, seed) for kw in cases]
    return run_tasks(_run_controller, tasks, workers, address)


def evaluate_sweep(
    policies: Sequence[str],
    backend: str = "reference",
    track_classes: Sequence[int] = (4, 6),
    episodes: int = 10,
    seed: int = 1000,
    trust: bool = False,
    workers: int = 1,
    address: str | None = None,
    env_kwargs: dict[str, Any] | None = None,
    env_id: str = ENV_ID,
) -> list[dict[str, Any]]:
    """One row per (track class, policy): mean RMS ẍ2, Wk a_w, Sperling Wz over the episodes of
    :func:`agents.evaluation.runs.run_policy` and ``a_w_reduction_%`` against the passive row of the
    same class (NaN without one), one task per (track class, policy); ``env_kwargs`` are added
    to every env (e.g. ``fmu``, ``fmu_map``); ``env_id``: the version of
    ``railgym/VerticalSuspension`` the episodes run on."""
    episodes = val.integer(episodes, "episodes", min=1, max=MAX_EPISODES)
    seed = val.integer(seed, "seed", min=0)
    track_classes = [
        val.integer(tc, "track_classes", min=1, max=6)
        for tc in val.sequence(track_classes, "track_classes")
    ]
    policies = val.sequence(policies, "policies")
    labels = [load_policy(p, env_id, trust)[2] for p in policies]  # bad names fail here
    cases = [{"backend": backend, "track_class": tc, **(env_kwargs or {})} for tc in track_classes]
    tasks = [PolicyTask(p, trust, case, episodes, seed, env_id) for case in cases for p in policies]
    results = iter(run_tasks(_run_policy, tasks, workers, address))
    rows = []
    for tc in track_classes:
        passive = None
        for label in labels:
            ix = next(results)
            if label == "passive":
                passive = ix["a_w"]
            reduction = float("nan") if passive is None else 100 * (1 - ix["a_w"] / passive)
            rows.append({"track_class": tc, "policy": label, **ix, "a_w_reduction_%": reduction})
    return rows


__all__ = ["ControllerTask", "controller_sweep", "evaluate_sweep"]
