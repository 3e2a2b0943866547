"""Policies and the envs they run on, shared by the commands of :mod:`agents`.

* the env ids (:data:`ENV_ID`, :data:`VEHICLE_ID`, :data:`CRASH_ID`) and the classical
  controllers of each (:data:`CONTROLLERS`, :data:`VEHICLE_CONTROLLERS`, :data:`CONTROLLERS_OF`);
* :func:`load_policy` — a controller name, a pretrained policy (:mod:`agents.pretrained`), a
  stable-baselines3 ``.zip`` (:mod:`agents.policy_zip`; manifest checked, only the network
  weights read: :mod:`agents.policy_io`) or an RLlib checkpoint folder, as a factory
  ``env → object with predict``;
* :func:`run_policy` / :func:`run_vehicle_policy` — the comfort indices of one policy over
  ``episodes`` episodes in one native vector env (sub-env ``i`` on the track of ``seed + i``),
  and :func:`evaluate_vehicle`, the rows of ``railgym evaluate --env vehicle``.

``railgym evaluate`` (:mod:`agents.evaluate`) is the command over these.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from agents._args import MAX_EPISODES, VEHICLE_DURATION_S, check_speed_kmh, with_policy_kwargs
from agents._extras import require
from agents.action_hold import HeldPolicy
from agents.controllers import (  # noqa: F401  (the tables re-exported)
    CONTROLLERS,
    CONTROLLERS_OF,
    CRASH_ID,
    ENV_ID,
    VEHICLE_CONTROLLERS,
    VEHICLE_ID,
    build_controller,
)
from agents.policy_io import RLLIB_MODULE_PATH, check_manifest, load_policy_weights
from agents.policy_zip import PolicySource, find_source, zip_network
from agents.pretrained import PRETRAINED, pretrained_zip
from agents.residual import ResidualPolicy
from railgym import _checks as val
from railgym.comfort import sperling_wz, weighted_rms
from railgym.parallel import run_tasks
from railgym.registration import env_family

#: baseline names accepted by :func:`evaluate_envelope` (all three always run)
ENVELOPE_BASELINES = ("passive", "best-constant", "speed-adaptive")


def _rllib_policy(path: Path, env_id: str, trust: bool) -> tuple[Any, dict[str, Any], str]:
    """:func:`load_policy` for an RLlib checkpoint folder (needs the ``rllib`` extra)."""
    try:
        from agents.train_rllib import load_rllib_policy
    except ImportError as err:
        raise ValueError(
            f"policy {path} is an RLlib checkpoint: install the 'rllib' extra to load it ({err})"
        ) from err
    policy = load_rllib_policy(path, env_id, trust)
    return (lambda env: policy), {}, f"rllib:{path.name}"


def load_policy(
    policy: str, env_id: str = ENV_ID, trust: bool = False
) -> tuple[Any, dict[str, Any], str]:
    """``(factory(env) → object with predict, env kwargs it needs, label)`` for a name or zip.

    A zip must be listed with its SHA-256 in the ``manifest.json`` that :mod:`agents.train`
    writes beside it (or ``trust`` given, with a warning); only its network weights are read
    (:func:`agents.policy_io.load_policy_weights`), nothing in it is unpickled or run.
    """
    if not isinstance(policy, str | Path):
        raise val.FieldTypeError("policy", f"must be a controller name or a path, got {policy!r}")
    policy = str(policy)
    controllers = CONTROLLERS_OF.get(env_id, {})
    if policy in controllers:
        cls, kwargs, env_kwargs = controllers[policy]
        return (lambda env: cls(env, **kwargs)), env_kwargs, policy
    pretrained = policy in PRETRAINED
    if pretrained:  # shipped in the package (agents.pretrained), for any version of its env
        policy = str(pretrained_zip(policy, env_id))
    path = Path(policy)
    if path.is_dir() and (path / RLLIB_MODULE_PATH).is_dir():
        return _rllib_policy(path, env_id, trust)
    if path.suffix != ".zip" or not path.is_file():
        names = f"one of {sorted(controllers)}, " if controllers else ""
        raise ValueError(
            f"policy must be {names}an existing stable-baselines3 .zip or an RLlib checkpoint "
            f"folder, got {policy!r}"
        )
    return _sb3_policy(path, env_id, trust, pretrained)


def trained_actuator(policy: str, env_id: str = ENV_ID) -> str | None:
    """The actuator (``"force"`` or ``"semi-active"``) a trained policy was trained with, read
    from its run's settings without loading it: an :mod:`agents.train` or rl-zoo3 zip (or a
    pretrained name); ``None`` for a controller name, an RLlib checkpoint, a bare zip (its env
    comes from the command) or a path that is not there (:func:`load_policy` says why)."""
    if not isinstance(policy, str | Path) or str(policy) in CONTROLLERS_OF.get(env_id, {}):
        return None
    policy = str(policy)
    if policy in PRETRAINED:
        try:
            path = pretrained_zip(policy, env_id)
        except ValueError:
            return None
    else:
        path = Path(policy)
    if path.suffix != ".zip" or not path.is_file():
        return None
    source = find_source(path)
    if source.kind == "agents.train":
        from agents.train_config import load_config

        env_kwargs = load_config(source.config).env_kwargs
    elif source.kind == "rl-zoo3":
        env_kwargs = source.env_kwargs
    else:
        return None
    return str(env_kwargs.get("actuator", "force"))


#: the env arguments a trained policy carries to the env it runs on (they shape its
#: observation and action); the others are the run's own
POLICY_ENV_KWARGS = frozenset(
    {
        "observation",
        "sensor_noise",
        "f_max",
        "control_dt",
        "wheelbase",
        "absorber_range",
        "absorber_rate",
        "n_cars",
        "scenario",
        "n_actuators",
        "flexible",
        "vehicle",
        "actuator",
        "damper",
        "preview",
    }
)


#: the training env arguments a residual policy's controller is designed with (its case)
RESIDUAL_DESIGN_KWARGS = POLICY_ENV_KWARGS | {"track_class", "speed", "reward_weights"}


def design_env_kwargs(env_id: str, kwargs: dict[str, Any]) -> dict[str, Any]:
    """``kwargs`` of an env made only for its spaces and its controller design: the linear
    backend of a track env (it needs nothing of the vehicle but its linear description, so a
    user's vehicle file works; no element is loaded), the crash env as it is."""
    if env_family(env_id) == env_family(CRASH_ID):
        return kwargs
    return {**kwargs, "backend": "linear"}


class _Network(NamedTuple):
    """What a stable-baselines3 zip was trained with."""

    trained_on: str  #: env id
    algo: str
    policy: str  #: SB3 policy class name
    net_kwargs: dict[str, Any]
    env_kwargs: dict[str, Any]
    obs_shape: tuple[int, ...] | None  #: from the zip's data entry (``None``: from a config)
    hold: int = 1  #: env steps per decision (``action_hold`` of an agents.train config)
    residual: str | None = None  #: controller the action is added to (``residual``)
    residual_scale: float = 1.0


def _network(path: Path, source: PolicySource, env_id: str) -> _Network:
    """The network and env of the zip ``path``: from its run's ``config.yaml`` (agents.train),
    else from the zip's data entry (rl-zoo3 or a bare zip)."""
    from agents.train_config import ACTIVATIONS, ALGOS, hyperparameters, load_config

    if source.kind == "agents.train":
        cfg = load_config(source.config)
        hyper = hyperparameters(ALGOS[cfg.algo], cfg.hyperparameters)
        net_kwargs = dict(hyper.get("policy_kwargs") or {})
        if "use_sde" in hyper:
            net_kwargs["use_sde"] = hyper["use_sde"]
        return _Network(
            cfg.env_id,
            cfg.algo,
            cfg.policy,
            net_kwargs,
            cfg.env_kwargs,
            None,
            cfg.action_hold,
            cfg.residual,
            cfg.residual_scale,
        )
    algo, policy_name, net_kwargs, obs_shape = zip_network(path)
    if "activation_fn" in net_kwargs:
        act = net_kwargs["activation_fn"]
        if act not in ACTIVATIONS:
            raise ValueError(f"policy {path}: activation {act!r} is not supported")
        net_kwargs["activation_fn"] = ACTIVATIONS[act]
    trained_on = source.env_id or env_id
    return _Network(trained_on, algo, policy_name, net_kwargs, source.env_kwargs, obs_shape)


def _sb3_policy(
    path: Path, env_id: str, trust: bool, pretrained: bool
) -> tuple[Any, dict[str, Any], str]:
    """:func:`load_policy` of a stable-baselines3 zip: manifest checked, weights only."""
    require("loading a stable-baselines3 policy", "torch", "stable_baselines3")
    check_manifest(path, trust)
    source = find_source(path)
    network = _network(path, source, env_id)
    trained_on = network.trained_on
    where = source.config or path
    if env_family(trained_on) != env_family(env_id):
        raise ValueError(f"{where}: the policy was trained on {trained_on}, not {env_id}")
    if trained_on != env_id and not pretrained:
        warnings.warn(
            f"{where}: the policy was trained on {trained_on} and runs on {env_id} (same "
            "spaces and reference model; the surrogate differs between versions)",
            UserWarning,
            stacklevel=3,
        )
    env_kwargs = {k: v for k, v in network.env_kwargs.items() if k in POLICY_ENV_KWARGS}
    probe = gym.make(env_id, **design_env_kwargs(env_id, env_kwargs))  # the single env's spaces
    obs_shape = network.obs_shape
    if obs_shape is not None and obs_shape != probe.observation_space.shape:
        raise ValueError(
            f"policy {path}: it takes observations of shape {obs_shape}, the env gives "
            f"{probe.observation_space.shape} (trained with other env settings: put its "
            "config.yaml, or rl-zoo3's folder, beside it)"
        )
    net = load_policy_weights(
        path,
        network.algo,
        network.policy,
        network.net_kwargs,
        probe.observation_space,
        probe.action_space,
    )
    probe.close()
    run = (source.config.parent if source.kind == "agents.train" else path.parent).name
    final = path.parent.name == run and path.stem in ("model", env_id.replace("/", "-"))
    label = run if final else f"{run}/{path.stem}"
    if network.hold > 1:  # trained to decide every `hold` steps: one held phase per factory call
        return (lambda env: HeldPolicy(net, network.hold)), env_kwargs, label
    name, scale = network.residual, network.residual_scale
    if name is not None:  # one controller per factory call, designed for the training case
        design = {k: v for k, v in network.env_kwargs.items() if k in RESIDUAL_DESIGN_KWARGS}
        design_env = gym.make(env_id, **design_env_kwargs(env_id, design))
        space = design_env.action_space
        bounds = (np.asarray(space.low, np.float64), np.asarray(space.high, np.float64))
        return (
            (
                lambda env: ResidualPolicy(
                    net, build_controller(env_id, name, design_env), scale, bounds
                )
            ),
            env_kwargs,
            label,
        )
    return (lambda env: net), env_kwargs, label


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
    factory: Any, env_kwargs: dict[str, Any], episodes: int, seed: int
) -> dict[str, Any]:
    """Run ``episodes`` episodes (one per sub-env) and return the mean comfort indices, with
    the env's ``backend`` and the validity flags of :func:`_validity`."""
    venv = gym.make_vec(
        ENV_ID, num_envs=episodes, vectorization_mode="vector_entry_point", **env_kwargs
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
    return {
        "rms_acc": float(np.mean(np.sqrt(np.mean(a**2, axis=0)))),
        "a_w": float(
            np.mean(
                [weighted_rms(a[:, i], fs, discard=2.0, lowpass=False) for i in range(episodes)]
            )
        ),
        "wz": float(np.mean([sperling_wz(a[:, i], fs) for i in range(episodes)])),
        "max_defl_mm": float(np.max(np.abs(defl)) * 1e3),
        "contacts": float(np.sum(contacts)),
        "backend": str(base.cfg.backend),
        **_validity(outside, len(acc), info),
    }


# ================================================ railgym/VerticalVehicle-v1: the whole vehicle
#: keys of the vehicle's ``info["comfort"]``, each (3,): front, centre, rear floor point
VEHICLE_COMFORT = ("a_w", "a_ZP95_Wb", "Wz")


class VehicleTask(NamedTuple):
    """A named controller or saved policy (loaded in the worker) on one vehicle env setting."""

    policy: str
    trust: bool
    env_kwargs: dict[str, Any]
    episodes: int
    seed: int


def run_vehicle_policy(
    factory: Any, env_kwargs: dict[str, Any], episodes: int, seed: int
) -> dict[str, Any]:
    """Run ``episodes`` episodes of ``railgym/VerticalVehicle-v1`` (one per sub-env, tracks of
    seeds ``seed + i``) and return the means over them, each an array (3,) per floor point:
    ``rms_acc`` (RMS floor acceleration, m/s²) and the env's end-of-episode comfort ``a_w``
    (ISO 2631-1 Wk RMS, m/s²), ``a_ZP95_Wb`` (EN 12299, m/s²), ``Wz`` (Sperling); with
    ``speed_kmh`` and the totals ``contacts`` (bump-stop substeps) and ``ood`` (surrogate
    evaluations outside its box), the env's ``backend`` and the validity flags of
    :func:`_validity`."""
    venv = gym.make_vec(
        VEHICLE_ID, num_envs=episodes, vectorization_mode="vector_entry_point", **env_kwargs
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


def _run_vehicle_task(task: VehicleTask) -> dict[str, Any]:
    factory, env_kwargs, _ = load_policy(task.policy, VEHICLE_ID, task.trust)
    return run_vehicle_policy(
        factory,
        with_policy_kwargs(env_kwargs, task.env_kwargs, task.policy),
        task.episodes,
        task.seed,
    )


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
) -> list[dict[str, Any]]:
    """One row per (track class, speed, policy) of :func:`run_vehicle_policy` on
    ``railgym/VerticalVehicle-v1``, plus ``a_w_reduction_%`` (3,) against the passive row
    of the same case (NaN without one).

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
    labels = [load_policy(p, VEHICLE_ID, trust)[2] for p in policies]  # bad names fail here
    cases = [(tc, v) for tc in track_classes for v in speeds]
    tasks = [
        VehicleTask(
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


__all__ = [
    "CONTROLLERS",
    "CONTROLLERS_OF",
    "CRASH_ID",
    "ENVELOPE_BASELINES",
    "ENV_ID",
    "MAX_EPISODES",
    "RLLIB_MODULE_PATH",
    "VEHICLE_COMFORT",
    "VEHICLE_CONTROLLERS",
    "VEHICLE_ID",
    "VehicleTask",
    "evaluate_vehicle",
    "load_policy",
    "run_policy",
    "run_vehicle_policy",
    "trained_actuator",
]
