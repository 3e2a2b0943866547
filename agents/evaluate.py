"""``railgym evaluate``: comfort indices of any controller or saved policy, beside passive and
skyhook, on the vertical env (one bogie) and on the whole vehicle (comfort at the front, centre
and rear floor points); crash-safety indices beside the passive absorbers on the crash env, or
over the held-out impact envelope beside the crash baselines.

    railgym evaluate skyhook --backend reference --track-class 4 6 --episodes 10
    railgym evaluate runs/ppo_vertical/model.zip --backend reference --track-class 4 6
    railgym evaluate modal-skyhook lqr --env vehicle --track-class 5 --speed 60 100 144 200
    railgym evaluate runs/ppo_crash/model.zip --env crash --speed 36 40 44
    railgym evaluate runs/ppo_crash/model.zip --env crash --envelope

A policy is a controller name (vertical: ``passive``, ``skyhook``, ``semi-active``,
``groundhook``, ``lqr``, ``lqg``; vehicle: ``passive``, ``skyhook`` (skyhook per bogie),
``modal-skyhook``, ``lqr``, ``lqg``) or a stable-baselines3 ``.zip``: of :mod:`agents.train` (its
``model.zip`` or a checkpoint ``checkpoints/model_N_steps.zip``: the algorithm and the env's
observation settings from the run's ``config.yaml``), of rl-zoo3 (the run's ``args.yml`` and
``config.yml``) or any other (the algorithm and network from the zip's JSON ``data``; the env
from the flags), see :mod:`agents.policy_zip`. The zip must be listed with its SHA-256 in the
``manifest.json`` beside it (``--trust``: any zip, e.g. rl-zoo3's, with a warning), and only
its network weights are read (:mod:`agents.policy_io`). Each case (track class, and speed on
the vehicle) runs ``episodes`` episodes in one native vector env, sub-env ``i`` on the track
of seed ``seed + i`` — the same tracks for every policy. ``--workers N`` / ``--address ADDR``
run the cases of the vertical and vehicle evaluations as parallel tasks
(:func:`railgym.parallel.run_tasks`); the rows do not depend on the number of workers.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from agents._args import (
    MAX_SPEED_KMH,
    add_parallel_arguments,
    bounded_int,
    check_parallel,
    speed_kmh,
)
from agents._extras import require
from agents.controllers import (
    LQG,
    LQR,
    BogieSkyhook,
    Groundhook,
    ModalSkyhook,
    Passive,
    Skyhook,
    VehicleLQG,
    VehicleLQR,
)
from agents.policy_io import check_manifest, load_policy_weights
from agents.policy_zip import find_source, zip_network
from agents.pretrained import PRETRAINED, pretrained_zip
from railgym import _validation as val
from railgym.comfort import sperling_wz, weighted_rms
from railgym.parallel import run_tasks
from railgym.progress import bar

ENV_ID = "railgym/VerticalSuspension-v0"
VEHICLE_ID = "railgym/VerticalVehicle-v0"
CRASH_ID = "railgym/TrainCrash-v0"
#: most episodes per class (one vector sub-env each)
MAX_EPISODES = 1000
CONTROLLERS = {
    "passive": (Passive, {}, {}),
    "skyhook": (Skyhook, {"mode": "active"}, {}),
    "semi-active": (Skyhook, {"mode": "semi-active"}, {}),
    "groundhook": (Groundhook, {}, {}),
    "lqr": (LQR, {}, {"observation": "full"}),
    "lqg": (LQG, {}, {"observation": "sensors"}),
}
#: controllers of ``railgym/VerticalVehicle-v0`` (two actuators)
VEHICLE_CONTROLLERS = {
    "passive": (Passive, {}, {}),
    "skyhook": (BogieSkyhook, {}, {}),
    "modal-skyhook": (ModalSkyhook, {}, {}),
    "lqr": (VehicleLQR, {}, {"observation": "full"}),
    "lqg": (VehicleLQG, {}, {"observation": "sensors"}),
}
#: baseline names accepted by :func:`evaluate_envelope` (all three always run)
ENVELOPE_BASELINES = ("passive", "best-constant", "speed-adaptive")
#: controller names of each env id (the crash env: trained policies only)
CONTROLLERS_OF = {ENV_ID: CONTROLLERS, VEHICLE_ID: VEHICLE_CONTROLLERS}


#: where an RLlib algorithm checkpoint keeps its policy module (see :mod:`agents.train_rllib`)
RLLIB_MODULE_PATH = Path("learner_group") / "learner" / "rl_module" / "default_policy"


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
    if policy in PRETRAINED:  # shipped in the package (agents.pretrained)
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
    require("loading a stable-baselines3 policy", "torch", "stable_baselines3")
    check_manifest(path, trust)
    from agents.train_config import ACTIVATIONS, ALGOS, hyperparameters, load_config

    source = find_source(path)
    obs_shape = None
    if source.kind == "agents.train":
        cfg = load_config(source.config)
        trained_on, algo, policy_name = cfg.env_id, cfg.algo, cfg.policy
        hyper = hyperparameters(ALGOS[cfg.algo], cfg.hyperparameters)
        net_kwargs = dict(hyper.get("policy_kwargs") or {})
        if "use_sde" in hyper:
            net_kwargs["use_sde"] = hyper["use_sde"]
        env_kwargs = cfg.env_kwargs
    else:  # rl-zoo3 or a bare zip: the network from the zip's data entry
        algo, policy_name, net_kwargs, obs_shape = zip_network(path)
        if "activation_fn" in net_kwargs:
            act = net_kwargs["activation_fn"]
            if act not in ACTIVATIONS:
                raise ValueError(f"policy {path}: activation {act!r} is not supported")
            net_kwargs["activation_fn"] = ACTIVATIONS[act]
        trained_on, env_kwargs = source.env_id or env_id, source.env_kwargs
    where = source.config or path
    if trained_on != env_id:
        raise ValueError(f"{where}: the policy was trained on {trained_on}, not {env_id}")
    keep = {
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
    }
    env_kwargs = {k: v for k, v in env_kwargs.items() if k in keep}

    probe = gym.make(env_id, **env_kwargs)  # the single env's spaces
    if obs_shape is not None and obs_shape != probe.observation_space.shape:
        raise ValueError(
            f"policy {path}: it takes observations of shape {obs_shape}, the env gives "
            f"{probe.observation_space.shape} (trained with other env settings: put its "
            "config.yaml, or rl-zoo3's folder, beside it)"
        )
    net = load_policy_weights(
        path, algo, policy_name, net_kwargs, probe.observation_space, probe.action_space
    )
    probe.close()
    run = (source.config.parent if source.kind == "agents.train" else path.parent).name
    final = path.parent.name == run and path.stem in ("model", env_id.replace("/", "-"))
    label = run if final else f"{run}/{path.stem}"
    return (lambda env: net), env_kwargs, label


def run_policy(
    factory: Any, env_kwargs: dict[str, Any], episodes: int, seed: int
) -> dict[str, float]:
    """Run ``episodes`` episodes (one per sub-env) and return the mean comfort indices."""
    venv = gym.make_vec(
        ENV_ID, num_envs=episodes, vectorization_mode="vector_entry_point", **env_kwargs
    )
    ctrl = factory(venv)
    obs, _ = venv.reset(seed=seed)
    acc, defl, contacts = [], [], np.zeros(episodes)
    base: Any = venv.unwrapped  # VerticalSuspensionVectorEnv: state, cfg
    while True:
        action, _ = ctrl.predict(obs, deterministic=True)
        obs, _, term, trunc, info = venv.step(np.asarray(action, np.float32).reshape(episodes, 1))
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
    }


def evaluate(
    policies: Sequence[str],
    backend: str = "reference",
    track_classes: Sequence[int] = (4, 6),
    episodes: int = 10,
    seed: int = 1000,
    trust: bool = False,
) -> list[dict[str, Any]]:
    """One row per (track class, policy): mean RMS ẍ2, Wk a_w, Sperling Wz over episodes
    (``trust``: see :func:`load_policy`)."""
    episodes = val.integer(episodes, "episodes", min=1, max=MAX_EPISODES)
    seed = val.integer(seed, "seed", min=0)
    track_classes = [
        val.integer(tc, "track_classes", min=1, max=6)
        for tc in val.sequence(track_classes, "track_classes")
    ]
    rows = []
    loaded = [load_policy(p, trust=trust) for p in val.sequence(policies, "policies")]
    for tc in track_classes:
        passive = None
        for factory, env_kwargs, label in loaded:
            kwargs = {"backend": backend, "track_class": tc, **env_kwargs}
            ix = run_policy(factory, kwargs, episodes, seed)
            if label == "passive":
                passive = ix["a_w"]
            reduction = float("nan") if passive is None else 100 * (1 - ix["a_w"] / passive)
            rows.append({"track_class": tc, "policy": label, **ix, "a_w_reduction_%": reduction})
    return rows


def format_rows(rows: list[dict[str, Any]]) -> str:
    """Aligned text table of :func:`evaluate` rows."""
    head = (
        f"{'class':>5} {'policy':<16} {'RMS ẍ2 m/s²':>12} {'a_w Wk m/s²':>12} {'Δa_w %':>7} "
        f"{'Wz':>6} {'max |δ| mm':>10} {'contacts':>8}"
    )
    lines = [head]
    for r in rows:
        lines.append(
            f"{r['track_class']:>5} {r['policy']:<16} {r['rms_acc']:12.3f} {r['a_w']:12.3f} "
            f"{r['a_w_reduction_%']:7.1f} {r['wz']:6.2f} {r['max_defl_mm']:10.1f} "
            f"{r['contacts']:8.0f}"
        )
    return "\n".join(lines)


# ================================================ railgym/VerticalVehicle-v0: the whole vehicle
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
    """Run ``episodes`` episodes of ``railgym/VerticalVehicle-v0`` (one per sub-env, tracks of
    seeds ``seed + i``) and return the means over them, each an array (3,) per floor point:
    ``rms_acc`` (RMS floor acceleration, m/s²) and the env's end-of-episode comfort ``a_w``
    (ISO 2631-1 Wk RMS, m/s²), ``a_ZP95_Wb`` (EN 12299, m/s²), ``Wz`` (Sperling); with
    ``speed_kmh`` and the totals ``contacts`` (bump-stop substeps) and ``ood`` (surrogate
    evaluations outside its box)."""
    venv = gym.make_vec(
        VEHICLE_ID, num_envs=episodes, vectorization_mode="vector_entry_point", **env_kwargs
    )
    ctrl = factory(venv)
    obs, _ = venv.reset(seed=seed)
    n_act = venv.single_action_space.shape[0]
    while True:
        action, _ = ctrl.predict(obs, deterministic=True)
        action = np.asarray(action, np.float32).reshape(episodes, n_act)
        obs, _, term, trunc, info = venv.step(action)
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
    }


def _run_vehicle_task(task: VehicleTask) -> dict[str, Any]:
    factory, env_kwargs, _ = load_policy(task.policy, VEHICLE_ID, task.trust)
    return run_vehicle_policy(factory, {**task.env_kwargs, **env_kwargs}, task.episodes, task.seed)


def evaluate_vehicle(
    policies: Sequence[str],
    backend: str = "reference",
    track_classes: Sequence[int] = (4, 6),
    speeds_kmh: Sequence[float | None] = (None,),
    episodes: int = 10,
    seed: int = 1000,
    duration: float = 20.0,
    trust: bool = False,
    workers: int = 1,
    address: str | None = None,
    env_kwargs: dict[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """One row per (track class, speed, policy) of :func:`run_vehicle_policy` on
    ``railgym/VerticalVehicle-v0``, plus ``a_w_reduction_%`` (3,) against the passive row
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
    speeds = [None if v is None else _speed_kmh(v) for v in val.sequence(speeds_kmh, "speeds_kmh")]
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


def format_vehicle_rows(rows: list[dict[str, Any]]) -> str:
    """Aligned text table of :func:`evaluate_vehicle` rows, front / centre / rear per index."""

    def three(x: np.ndarray, fmt: str) -> str:
        return "/".join(fmt.format(v) for v in x)

    head = (
        f"{'class':>5} {'km/h':>5} {'policy':<14} {'RMS acc m/s²':>16} {'a_w Wk m/s²':>16} "
        f"{'Δa_w %':>17} {'a_ZP95 Wb m/s²':>16} {'Wz':>14} {'contacts':>8} {'out-dom':>8}"
    )
    lines = [head]
    for r in rows:
        lines.append(
            f"{r['track_class']:>5} {r['speed_kmh']:5.0f} {r['policy']:<14} "
            f"{three(r['rms_acc'], '{:.3f}'):>16} {three(r['a_w'], '{:.3f}'):>16} "
            f"{three(r['a_w_reduction_%'], '{:.1f}'):>17} "
            f"{three(r['a_ZP95_Wb'], '{:.3f}'):>16} {three(r['Wz'], '{:.2f}'):>14} "
            f"{r['contacts']:8.0f} {r['ood']:8.0f}"
        )
    return "\n".join(lines)


def _speed_kmh(v: Any) -> float:
    """A speed in km/h within (0, MAX_SPEED_KMH], else an error naming ``speeds_kmh``."""
    v = val.real(v, "speeds_kmh")
    if not 0 < v <= MAX_SPEED_KMH:
        raise val.FieldError(
            "speeds_kmh", f"must be in (0, {MAX_SPEED_KMH:g}] km/h, got {v!r} km/h"
        )
    return v


# ================================================================ railgym/TrainCrash-v0
def evaluate_crash(
    policies: Sequence[str],
    backend: str = "reference",
    speeds_kmh: Sequence[float] = (40.0,),
    trust: bool = False,
) -> list[dict[str, Any]]:
    """One row per (speed, policy): episode-end crash-safety indices of ``TrainCrash-v0``
    (``trust``: see :func:`load_policy`)."""
    speeds_kmh = [_speed_kmh(v) for v in val.sequence(speeds_kmh, "speeds_kmh")]
    rows = []
    loaded = [
        load_policy(p, CRASH_ID, trust) if p != "passive" else (None, {}, "passive")
        for p in val.sequence(policies, "policies")
    ]
    for v in bar(speeds_kmh, desc="speeds"):
        passive = None
        for factory, env_kwargs, label in loaded:
            env = gym.make(CRASH_ID, backend=backend, **{**env_kwargs, "speed": v / 3.6})
            ctrl = factory(env) if factory else None
            obs, _ = env.reset(seed=0)
            while True:
                if ctrl is None:
                    action = np.zeros(env.action_space.shape, np.float32)
                else:
                    action, _ = ctrl.predict(obs, deterministic=True)
                obs, _, term, trunc, info = env.step(action)
                if term or trunc:
                    break
            peak = float(np.max(info["peak_decel_g"]))
            passive = peak if label == "passive" else passive
            rows.append(
                {
                    "speed_kmh": v,
                    "policy": label,
                    "peak_decel_g": info["peak_decel_g"],
                    "max_crush_m": info["max_crush_m"],
                    "stroke_exceeded": bool(info["stroke_exceeded"]),
                    "peak_reduction_%": 100 * (1 - peak / passive) if passive else float("nan"),
                }
            )
    return rows


def evaluate_envelope(
    policies: Sequence[str], speeds_kmh: Sequence[float] | None = None, trust: bool = False
) -> list[dict[str, Any]]:
    """The held-out envelope evaluation of ``TrainCrash-v0`` on the reference backend
    (:func:`agents.crash_report.envelope_rows`): the passive absorbers, the best constant
    setting, the speed-adaptive rule and each trained policy ``.zip`` of ``policies`` (the
    baseline names ``passive``, ``best-constant``, ``speed-adaptive`` there are accepted; the
    three always run) at ``speeds_kmh`` (default the held-out speeds) × the two payloads."""
    from agents import crash_report  # imports this module: not at the top

    speeds = (
        crash_report.EVAL_SPEEDS_KMH
        if speeds_kmh is None
        else [_speed_kmh(v) for v in val.sequence(speeds_kmh, "speeds_kmh")]
    )
    factories: dict[str, Any] = dict(crash_report.BASELINES)
    env_kwargs: dict[str, Any] | None = None
    for p in val.sequence(policies, "policies"):
        if p in ENVELOPE_BASELINES:
            continue
        factory, kwargs, label = load_policy(p, CRASH_ID, trust)
        if env_kwargs is not None and kwargs != env_kwargs:
            raise ValueError(
                f"policy {p}: trained with env settings {kwargs}, another policy with "
                f"{env_kwargs}; evaluate them in separate runs"
            )
        env_kwargs, factories[label] = kwargs, factory
    return crash_report.envelope_rows(factories, env_kwargs, speeds)


def format_crash_rows(rows: list[dict[str, Any]]) -> str:
    """Aligned text table of :func:`evaluate_crash` rows."""
    lines = [
        f"{'km/h':>5} {'policy':<16} {'peak decel per car (g)':<24} {'Δpeak %':>7} "
        f"{'max crush per zone (m)':<24} stroke exceeded"
    ]
    for r in rows:
        peaks = " ".join(f"{x:.2f}" for x in np.atleast_1d(r["peak_decel_g"]))
        crush = " ".join(f"{x:.3f}" for x in np.atleast_1d(r["max_crush_m"]))
        lines.append(
            f"{r['speed_kmh']:5.0f} {r['policy']:<16} {peaks:<24} "
            f"{r['peak_reduction_%']:7.1f} {crush:<24} "
            f"{r['stroke_exceeded']}"
        )
    return "\n".join(lines)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``railgym evaluate``."""
    parser.add_argument(
        "policy",
        nargs="+",
        help=f"vertical: {', '.join(CONTROLLERS)}; vehicle: {', '.join(VEHICLE_CONTROLLERS)}; "
        f"a pretrained policy ({', '.join(PRETRAINED)}) or a policy .zip",
    )
    parser.add_argument(
        "--backend",
        default="reference",
        choices=["reference", "surrogate", "linear", "fmu"],
        help="model the policies run on (crash: reference or surrogate; fmu: vertical, with "
        "--fmu-map, docs/fmi.md)",
    )
    parser.add_argument("--fmu", type=Path, help="backend fmu: the FMU (default: the map's fmu:)")
    parser.add_argument("--fmu-map", type=Path, help="backend fmu: its mapping file (YAML)")
    parser.add_argument(
        "--track-class",
        type=bounded_int(1, 6),
        nargs="+",
        default=[4, 6],
        help="vertical, vehicle: FRA track classes 1..6",
    )
    parser.add_argument(
        "--episodes",
        type=bounded_int(1, MAX_EPISODES),
        default=10,
        help=f"vertical, vehicle: episodes per case, 1..{MAX_EPISODES} (one sub-env each)",
    )
    parser.add_argument("--seed", type=bounded_int(0), default=1000, help="track seed of sub-env 0")
    parser.add_argument("--env", choices=["vertical", "vehicle", "crash"], default="vertical")
    parser.add_argument(
        "--speed",
        type=speed_kmh,
        nargs="+",
        help="vehicle: running speeds, km/h (default: each class's maximum speed); "
        "crash: impact speeds, km/h (default 40; --envelope: 25 30 35 40 45 50)",
    )
    parser.add_argument(
        "--duration",
        type=_duration_s,
        help="vehicle: seconds per episode (default 20)",
    )
    parser.add_argument(
        "--gap",
        action="store_true",
        help="run each policy on the surrogate and on --backend (default the reference) over "
        "the same held-out cases and print every task metric on both with their relative gap "
        "(agents.gap)",
    )
    parser.add_argument(
        "--envelope",
        action="store_true",
        help="crash: the held-out envelope evaluation on the reference (speeds × two payloads) "
        "of passive, best constant, speed-adaptive and the given policy .zip files",
    )
    add_parallel_arguments(parser, "vertical, vehicle: ", "the cases", "the rows do")
    parser.add_argument(
        "--trust",
        action="store_true",
        help="load a policy .zip that is not listed with its SHA-256 in the "
        "manifest.json its training wrote (a warning is given); only its network "
        "weights are read, never its pickled fields",
    )


def _duration_s(text: str) -> float:
    """``--duration``: seconds, 0 < t <= 600 (the env's limit)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a duration in s, got {text!r}") from None
    if not (np.isfinite(value) and 0 < value <= 600):
        raise argparse.ArgumentTypeError(f"must be a duration in s with 0 < t <= 600, got {text}")
    return value


def _only_for(args: argparse.Namespace, flags: dict[str, bool], envs: str) -> None:
    """One error naming each flag of ``flags`` that is set (True) but not used by ``--env``."""
    for flag, given in flags.items():
        if given:
            raise ValueError(f"{flag}: only for {envs}, not --env {args.env}")


def run(args: argparse.Namespace) -> int:
    """``railgym evaluate``: the policies plus passive (and skyhook) for comparison."""
    if args.gap:
        from agents.gap import run_gap  # imports this module: not at the top

        return run_gap(args)
    parallel = {"--workers": args.workers != 1, "--address": args.address is not None}
    fmu = {"fmu": args.fmu, "fmu_map": args.fmu_map} if args.backend == "fmu" else {}
    if args.backend != "fmu" and (args.fmu is not None or args.fmu_map is not None):
        raise ValueError("--fmu, --fmu-map: only with --backend fmu")
    if fmu and args.env == "crash":
        raise ValueError("--backend fmu: only for --env vertical and vehicle, not --env crash")
    if args.env == "crash":
        _only_for(args, {**parallel, "--duration": args.duration is not None}, "vertical, vehicle")
        if args.backend == "linear":
            raise ValueError("--backend: the crash env has backends reference and surrogate")
        if args.envelope:
            if args.backend != "reference":
                raise ValueError("--envelope: evaluates on the reference backend only")
            from agents.crash_report import envelope_table

            rows = evaluate_envelope(args.policy, args.speed, args.trust)
            print("TrainCrash-v0 envelope scenario, held-out cases on the reference backend")
            print(envelope_table(rows))
            return 0
        policies = ["passive"] + [p for p in args.policy if p != "passive"]
        rows = evaluate_crash(policies, args.backend, args.speed or [40.0], args.trust)
        print(
            f"TrainCrash-v0, backend: {args.backend}; Δpeak: reduction of the largest car "
            "deceleration vs the passive absorbers"
        )
        print(format_crash_rows(rows))
        return 0
    _only_for(args, {"--envelope": args.envelope}, "--env crash")
    check_parallel(args)
    policies = ["passive", "skyhook"] + [p for p in args.policy if p not in ("passive", "skyhook")]
    if args.env == "vehicle":
        rows = evaluate_vehicle(
            policies,
            args.backend,
            args.track_class,
            args.speed or [None],
            args.episodes,
            args.seed,
            20.0 if args.duration is None else args.duration,
            args.trust,
            args.workers,
            args.address,
            fmu,
        )
        print(
            f"VerticalVehicle-v0, backend: {args.backend}, {args.episodes} episodes per case "
            f"(seeds {args.seed}+i); per floor point front/centre/rear; Δa_w: reduction of the "
            "Wk-weighted RMS vs passive"
        )
        print(format_vehicle_rows(rows))
        return 0
    _only_for(
        args,
        {"--speed": args.speed is not None, "--duration": args.duration is not None},
        "--env vehicle and crash",
    )
    from agents.sweeps import evaluate_sweep  # imports this module: not at the top

    rows = evaluate_sweep(
        policies,
        args.backend,
        args.track_class,
        args.episodes,
        args.seed,
        args.trust,
        args.workers,
        args.address,
        fmu,
    )
    print(
        f"backend: {args.backend}, {args.episodes} episodes per class (seeds {args.seed}+i); "
        "Δa_w: reduction of the Wk-weighted RMS vs passive"
    )
    print(format_rows(rows))
    return 0
