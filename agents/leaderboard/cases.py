"""A policy on the evaluation cases of a task (:mod:`railgym.tasks`): the task's metric per
case, each case ``task.episodes`` episodes in one native vector env (sub-env ``i`` on the
track of seed ``task.seed + i``, the same tracks for every policy).

* the vertical tasks: ``a_w`` (ISO 2631-1 Wk RMS carbody acceleration, m/s², the first 2 s
  left out) of each episode, as :func:`agents.evaluation.runs.run_policy`;
* the vehicle tasks: the env's end-of-episode ``a_w`` of the front, centre and rear floor
  points, their mean;
* the crash task: the crash cost, worst-car peak deceleration (g) +
  :data:`railgym.tasks.CRASH_COST_G_PER_MM` × largest intrusion (mm), of the crash of each
  case (deterministic: one episode).

A policy is a factory ``factory(venv, case_label) → object with predict``:
:func:`policy_factory` makes it of a classical controller's name or a saved policy.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from agents.controllers.crash_baselines import rollout
from agents.controllers.lqg import LQG
from agents.controllers.registry import CRASH_CONTROLLERS, controllers_of
from agents.policies.loading import load_policy
from railgym import _checks as val
from railgym.comfort import weighted_rms
from railgym.tasks import CRASH_COST_G_PER_MM, TASKS, Task, case_kwargs

__all__ = [
    "DISCARD_S",
    "NOMINAL_CASE",
    "Factory",
    "checked_needs",
    "crash_cost",
    "make_case_env",
    "policy_factory",
    "run_case",
    "run_task",
]

#: settling time left out of the vertical ``a_w``, s
DISCARD_S = 2.0
#: the case of the payload task that its nominal LQG is designed for (nominal mass, 144 km/h)
NOMINAL_CASE = "m100-v40"
#: ``factory(venv, case_label)`` → an object with stable-baselines3's ``predict``
Factory = Callable[[Any, str], Any]


def make_case_env(task: Task, label: str, extra: dict[str, Any] | None = None) -> Any:
    """The native vector env of case ``label`` of ``task`` (``task.episodes`` sub-envs)."""
    kwargs = {**case_kwargs(task.name, label), **(extra or {})}
    return gym.make_vec(
        task.env_id, num_envs=task.episodes, vectorization_mode="vector_entry_point", **kwargs
    )


def crash_cost(criteria: Any) -> float:
    """Crash cost of :class:`~railgym.vehicles.crash.criteria.CrashCriteria`, g."""
    peak = float(np.max(criteria.peak_decel_g))
    return peak + CRASH_COST_G_PER_MM * 1e3 * float(np.max(criteria.intrusion_m))


def _nominal_lqg(task: Task) -> Factory:
    """The LQG designed for the payload task's nominal case, whatever the case it runs on."""

    def factory(venv: Any, label: str) -> Any:
        return LQG(make_case_env(task, NOMINAL_CASE))

    return factory


def policy_factory(task: Task, policy: str, trust: bool = False) -> tuple[Factory, dict[str, Any]]:
    """``(factory, env kwargs the policy needs)`` of a controller name of the task's env
    (``railgym evaluate``'s names; the payload task's ``lqg`` is designed for the nominal
    vehicle at 144 km/h, ``lqg-scheduled`` for each case's payload and speed) or of a saved
    policy (:func:`agents.policies.loading.load_policy`: an SB3 ``.zip`` with its manifest)."""
    if task.name == "bogie-payload" and policy in ("lqg", "lqg-scheduled"):
        if policy == "lqg":
            return _nominal_lqg(task), {}
        return (lambda venv, label: LQG(venv)), {}
    if task.env_id.startswith("railgym/TrainCrash") and policy in CRASH_CONTROLLERS:
        cls, kwargs, needs = CRASH_CONTROLLERS[policy]
        return (lambda venv, label: cls(venv, **kwargs)), dict(needs)
    if policy in controllers_of(task.env_id):
        cls, kwargs, needs = controllers_of(task.env_id)[policy]
        return (lambda venv, label: cls(venv, **kwargs)), dict(needs)
    factory, needs, _ = load_policy(policy, task.env_id, trust)
    return (lambda venv, label: factory(venv)), dict(needs)


def checked_needs(task: Task, needs: dict[str, Any]) -> dict[str, Any]:
    """The env arguments a policy needs that the task leaves free; one the task fixes to
    another value is refused (the policy does not fit the task)."""
    extra = {}
    for key, value in needs.items():
        fixed = task.env_kwargs.get(key)
        if key in task.env_kwargs and fixed != value:
            raise val.FieldError("policy", f"needs {key}={value!r}, task {task.name} has {fixed!r}")
        if key not in task.env_kwargs:
            extra[key] = value
    return extra


def _run_track(venv: Any, ctrl: Any, task: Task) -> np.ndarray:
    """One episode per sub-env of a vertical or vehicle case: the metric of each."""
    obs, _ = venv.reset(seed=task.seed)
    n_act = venv.single_action_space.shape[0]
    acc = []
    while True:
        action, _ = ctrl.predict(obs, deterministic=True)
        obs, _, term, trunc, info = venv.step(
            np.asarray(action, np.float32).reshape(task.episodes, n_act)
        )
        if np.any(term):
            raise RuntimeError(f"{task.name}: an episode diverged")
        if "comfort" not in info:
            acc.append(np.asarray(info["carbody_acc"], float).copy())
        if np.all(trunc):
            break
    if "comfort" in info:  # the vehicle: front, centre, rear floor points
        return np.asarray(np.mean(info["comfort"]["a_w"], axis=1), float)
    a = np.array(acc)
    fs = 1.0 / venv.unwrapped.cfg.control_dt
    return np.array(
        [weighted_rms(a[:, i], fs, discard=DISCARD_S, lowpass=False) for i in range(a.shape[1])]
    )


def run_case(
    task: Task, label: str, factory: Factory, needs: dict[str, Any] | None = None
) -> np.ndarray:
    """The metric of each episode of case ``label`` of ``task`` under the policy of
    ``factory`` (``needs``: env arguments it needs, :func:`policy_factory`)."""
    venv = make_case_env(task, label, checked_needs(task, needs or {}))
    try:
        ctrl = factory(venv, label)
        case = task.case(label)
        if task.env_id.startswith("railgym/TrainCrash"):
            runs = rollout(venv.unwrapped, ctrl, seed=task.seed, options=dict(case.options))
            if any(r.diverged for r in runs):
                raise RuntimeError(f"{task.name} {label}: the crash diverged")
            return np.array([crash_cost(r.criteria()) for r in runs])
        return _run_track(venv, ctrl, task)
    finally:
        venv.close()


def run_task(
    name: str, policy: str, trust: bool = False, cases: tuple[str, ...] | None = None
) -> dict[str, float]:
    """Mean metric over the episodes of each case (all, or ``cases``) of task ``name`` under
    ``policy`` (:func:`policy_factory`)."""
    task = TASKS[name]
    factory, needs = policy_factory(task, policy, trust)
    return {
        label: float(np.mean(run_case(task, label, factory, needs)))
        for label in (cases or task.case_labels)
    }
