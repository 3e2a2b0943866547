"""Policies run over episodes: the metrics (:mod:`agents.evaluation.metrics`) of one policy
over ``episodes`` episodes in one native vector env (sub-env ``i`` on the track of
``seed + i``): :func:`run_policy` (a version of ``railgym/VerticalSuspension``, default the
newest), :func:`run_vehicle_policy` (of ``railgym/VerticalVehicle``, default the newest), and
:func:`evaluate_vehicle`, the rows of ``railgym evaluate --env vehicle``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np

from agents.commands.flags import (
    MAX_EPISODES,
    VEHICLE_DURATION_S,
    check_speed_kmh,
    with_policy_kwargs,
)
from agents.controllers.registry import ENV_ID, VEHICLE_ID
from agents.evaluation.metrics import VERTICAL, Metric
from agents.policies.loading import load_policy, without_version_warning
from railgym import _checks as val
from railgym.comfort import sperling_wz, weighted_rms
from railgym.parallel import run_tasks

__all__ = [
    "VEHICLE_COMFORT",
    "PolicyTask",
    "evaluate_vehicle",
    "loaded_policy",
    "run_policy",
    "run_vehicle_policy",
    "with_aliases",
]


def with_aliases(values: Mapping[str, Any], table: Sequence[Metric]) -> dict[str, Any]:
    """``values`` and each value of a metric of ``table`` under its old keys too."""
    out = dict(values)
    for m in table:
        if m.key in values:
            out.update(dict.fromkeys(m.aliases, values[m.key]))
    return out


def _validity(outside_steps: np.ndarray, steps: int, info: dict[str, Any]) -> dict[str, Any]:
    """The validity flags of a run (docs/validation.md, *Validity flags*): ``outside_element_%``
    (share of the steps of all episodes with an element evaluation outside the training box,
    %; ``outside_steps`` (episodes,) counts them over ``steps`` steps each) and
    ``outside_envelope`` (any episode outside the element's envelope, from the last ``info``)."""
    return {
        "outside_element_%": float(
            100.0 * np.sum(outside_steps) / max(steps * len(outside_steps), 1)
        ),
        "outside_envelope": bool(np.any(info["outside_envelope"])),
    }


def run_policy(
    factory: Any, env_kwargs: dict[str, Any], episodes: int, seed: int, env_id: str = ENV_ID
) -> dict[str, Any]:
    """Run ``episodes`` episodes (one per sub-env) of ``env_id`` (a version of
    ``railgym/VerticalSuspension``) and
    return the means over them of the metrics of :data:`agents.evaluation.metrics.VERTICAL`
    (the Sperling index also under its old key ``wz``), with the env's ``backend`` and the
    validity flags of :func:`_validity`."""
    venv = gym.make_vec(
        env_id, num_envs=episodes, vectorization_mode="vector_entry_point", **env_kwargs
    )
    ctrl = factory(venv)
    obs, _ = venv.reset(seed=seed)
    acc, defl, contacts = [], [], np.zeros(episodes)
    outside = np.zeros(episodes, np.int64)
    base: Any = venv.unwrapped  # VerticalSuspensionVectorEnv: state, cfg
    while True:
        action, _ = ctrl.predict(obs, deterministic=True)
        obs, _, term, trunc, info = venv.step(np.asarray(action, np.float32).reshape(episodes, 1))
        outside += info["outside_element"]
        acc.append(info["carbody_acc"].copy())
        state = base.state
        defl.append(state[:, 0] - state[:, 2])
        contacts = np.maximum(contacts, info["bump_stop_contacts"])
        if np.any(term):
            raise RuntimeError(f"an episode diverged (sub-envs {np.flatnonzero(term).tolist()})")
        if np.all(trunc):
            break
    a = np.array(acc)  # (steps, episodes)
    fs = 1.0 / base.cfg.control_dt
    values = {
        "rms_acc": float(np.mean(np.sqrt(np.mean(a**2, axis=0)))),
        "a_w": float(
            np.mean(
                [weighted_rms(a[:, i], fs, discard=2.0, lowpass=False) for i in range(episodes)]
            )
        ),
        "Wz": float(np.mean([sperling_wz(a[:, i], fs) for i in range(episodes)])),
        "max_defl_mm": float(np.max(np.abs(defl)) * 1e3),
        "contacts": float(np.sum(contacts)),
    }
    return {
        **with_aliases(values, VERTICAL),
        "backend": str(base.cfg.backend),
        **_validity(outside, len(acc), info),
    }


#: keys of the vehicle's ``info["comfort"]``, each (3,): front, centre, rear floor point
VEHICLE_COMFORT = ("a_w", "a_ZP95_Wb", "Wz")


class PolicyTask(NamedTuple):
    """A named controller or saved policy (loaded in the worker) on one setting of env
    ``env_id`` (the task of :func:`evaluate_vehicle` and
    :func:`agents.evaluation.sweeps.evaluate_sweep`)."""

    policy: str
    trust: bool
    env_kwargs: dict[str, Any]
    episodes: int
    seed: int
    env_id: str


def run_vehicle_policy(
    factory: Any, env_kwargs: dict[str, Any], episodes: int, seed: int, env_id: str = VEHICLE_ID
) -> dict[str, Any]:
    """Run ``episodes`` episodes of ``env_id`` (a version of ``railgym/VerticalVehicle``; one
    per sub-env, tracks of
    seeds ``seed + i``) and return the means over them, each an array (3,) per floor point:
    ``rms_acc`` (RMS floor acceleration, m/s²) and the env's end-of-episode comfort ``a_w``
    (ISO 2631-1 Wk RMS, m/s²), ``a_ZP95_Wb`` (EN 12299, m/s²), ``Wz`` (Sperling); with
    ``speed_kmh`` and the totals ``contacts`` (bump-stop substeps) and ``ood`` (surrogate
    evaluations outside its box), the env's ``backend`` and the validity flags of
    :func:`_validity`."""
    venv = gym.make_vec(
        env_id, num_envs=episodes, vectorization_mode="vector_entry_point", **env_kwargs
    )
    ctrl = factory(venv)
    obs, _ = venv.reset(seed=seed)
    n_act = venv.single_action_space.shape[0]
    outside, steps = np.zeros(episodes, np.int64), 0
    while True:
        action, _ = ctrl.predict(obs, deterministic=True)
        action = np.asarray(action, np.float32).reshape(episodes, n_act)
        obs, _, term, trunc, info = venv.step(action)
        outside += info["outside_element"]
        steps += 1
        if np.any(term):
            raise RuntimeError(f"an episode diverged (sub-envs {np.flatnonzero(term).tolist()})")
        if np.all(trunc):
            break
    venv.close()
    comfort = info["comfort"]
    return {
        "speed_kmh": float(np.mean(info["speed"]) * 3.6),
        "rms_acc": np.mean(info["rms_carbody_acc"], axis=0),
        **{k: np.mean(comfort[k], axis=0) for k in VEHICLE_COMFORT},
        "contacts": float(np.sum(info["bump_stop_contacts"])),
        "ood": float(np.sum(info["out_of_domain"])),
        "backend": str(venv.unwrapped.cfg.backend),
        **_validity(outside, steps, info),
    }


def loaded_policy(
    policy: str, trust: bool, env_kwargs: dict[str, Any], env_id: str = ENV_ID
) -> tuple[Any, dict[str, Any]]:
    """The factory of a controller or saved policy (:func:`load_policy`, in the worker that
    runs the task) and ``env_kwargs`` with the env keywords the policy needs; no version
    warning (the caller loaded the policy before its tasks and warned once)."""
    with without_version_warning():
        factory, needed, _ = load_policy(policy, env_id, trust)
    return factory, with_policy_kwargs(needed, env_kwargs, policy)


def _run_vehicle_task(task: PolicyTask) -> dict[str, Any]:
    factory, env_kwargs = loaded_policy(task.policy, task.trust, task.env_kwargs, task.env_id)
    return run_vehicle_policy(factory, env_kwargs, task.episodes, task.seed, task.env_id)


def evaluate_vehicle(
    policies: Sequence[str],
    backend: str = "reference",
    track_classes: Sequence[int] = (4, 6),
    speeds_kmh: Sequence[float | None] = (None,),
    episodes: int = 10,
    seed: int = 1000,
    duration: float = VEHICLE_DURATION_S,
    trust: bool = False,
    workers: int = 1,
    address: str | None = None,
    env_kwargs: dict[str, Any] | None = None,
    env_id: str = VEHICLE_ID,
) -> list[dict[str, Any]]:
    """One row per (track class, speed, policy) of :func:`run_vehicle_policy` on ``env_id``
    (a version of ``railgym/VerticalVehicle``), plus ``a_w_reduction_%`` (3,) against the
    passive row of the same case (NaN without one).

    ``speeds_kmh``: km/h, ``None`` the class's maximum speed; ``duration``: s per episode;
    ``trust``: see :func:`load_policy`; ``workers``, ``address``: see
    :func:`railgym.parallel.run_tasks` (one task per row, the same rows for any number);
    ``env_kwargs`` are added to every env (e.g. ``fmu``, ``fmu_map``).
    """
    episodes = val.integer(episodes, "episodes", min=1, max=MAX_EPISODES)
    seed = val.integer(seed, "seed", min=0)
    duration = val.positive(duration, "duration")
    track_classes = [
        val.integer(tc, "track_classes", min=1, max=6)
        for tc in val.sequence(track_classes, "track_classes")
    ]
    speeds = [
        None if v is None else check_speed_kmh(v, "speeds_kmh")
        for v in val.sequence(speeds_kmh, "speeds_kmh")
    ]
    policies = [str(p) for p in val.sequence(policies, "policies")]
    labels = [load_policy(p, env_id, trust)[2] for p in policies]  # bad names fail here
    cases = [(tc, v) for tc in track_classes for v in speeds]
    tasks = [
        PolicyTask(
            p,
            trust,
            {
                "backend": backend,
                "track_class": tc,
                "speed": None if v is None else v / 3.6,
                "duration": duration,
                **(env_kwargs or {}),
            },
            episodes,
            seed,
            env_id,
        )
        for tc, v in cases
        for p in policies
    ]
    results = iter(run_tasks(_run_vehicle_task, tasks, workers, address, desc="cases"))
    rows = []
    for tc, _ in cases:
        passive = None
        for label in labels:
            ix = next(results)
            if label == "passive":
                passive = ix["a_w"]
            reduction = np.full(3, np.nan) if passive is None else 100 * (1 - ix["a_w"] / passive)
            rows.append({"track_class": tc, "policy": label, **ix, "a_w_reduction_%": reduction})
    return rows
