"""``railgym evaluate``: comfort indices of any controller or saved policy, beside passive and
skyhook, on the vertical env; crash-safety indices beside the passive absorbers on the crash env.

    railgym evaluate skyhook --backend reference --track-class 4 6 --episodes 10
    railgym evaluate runs/ppo_vertical/model.zip --backend reference --track-class 4 6
    railgym evaluate runs/ppo_crash/model.zip --env crash --speed 36 40 44

A policy is a controller name (``passive``, ``skyhook``, ``semi-active``, ``groundhook``,
``lqr``) or a stable-baselines3 ``.zip``; for a zip, the algorithm and the env's observation
settings are read from the ``config.yaml`` that :mod:`agents.train` writes beside it, the zip
must be listed with its SHA-256 in the ``manifest.json`` beside it (``--trust``: any zip, with a
warning), and only its network weights are read (:mod:`agents.policy_io`). Each track class
runs ``episodes`` episodes in one native vector env, sub-env ``i`` on the track of seed
``seed + i`` — the same tracks for every policy.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from agents._args import MAX_SPEED_KMH, bounded_int, speed_kmh
from agents.controllers import LQR, Groundhook, Passive, Skyhook
from agents.policy_io import check_manifest, load_policy_weights
from railgym import _validation as val
from railgym.comfort import sperling_wz, weighted_rms

ENV_ID = "railgym/VerticalSuspension-v0"
CRASH_ID = "railgym/TrainCrash-v0"
#: most episodes per class (one vector sub-env each)
MAX_EPISODES = 1000
CONTROLLERS = {
    "passive": (Passive, {}, {}),
    "skyhook": (Skyhook, {"mode": "active"}, {}),
    "semi-active": (Skyhook, {"mode": "semi-active"}, {}),
    "groundhook": (Groundhook, {}, {}),
    "lqr": (LQR, {}, {"observation": "full"}),
}


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
    if policy in CONTROLLERS:
        cls, kwargs, env_kwargs = CONTROLLERS[policy]
        return (lambda env: cls(env, **kwargs)), env_kwargs, policy
    path = Path(policy)
    if path.is_dir() and (path / RLLIB_MODULE_PATH).is_dir():
        return _rllib_policy(path, env_id, trust)
    if path.suffix != ".zip" or not path.is_file():
        raise ValueError(
            f"policy must be one of {sorted(CONTROLLERS)}, an existing stable-baselines3 .zip "
            f"or an RLlib checkpoint folder, got {policy!r}"
        )
    cfg_path = path.parent / "config.yaml"
    if not cfg_path.is_file():
        raise ValueError(f"policy {policy}: no config.yaml beside it to tell the algorithm")
    check_manifest(path, trust)
    from agents.train_config import ALGOS, hyperparameters, load_config

    cfg = load_config(cfg_path)
    if cfg.env_id != env_id:
        raise ValueError(f"{cfg_path}: the policy was trained on {cfg.env_id}, not {env_id}")
    hyper = hyperparameters(ALGOS[cfg.algo], cfg.hyperparameters)
    net_kwargs = dict(hyper.get("policy_kwargs") or {})
    if "use_sde" in hyper:
        net_kwargs["use_sde"] = hyper["use_sde"]
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
    }
    env_kwargs = {k: v for k, v in cfg.env_kwargs.items() if k in keep}

    probe = gym.make(env_id, **env_kwargs)  # the single env's spaces
    net = load_policy_weights(
        path, cfg.algo, cfg.policy, net_kwargs, probe.observation_space, probe.action_space
    )
    probe.close()
    return (lambda env: net), env_kwargs, path.parent.name


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
        f"{'class':>5} {'policy':<16} {'RMS ẍ2':>8} {'a_w Wk':>8} {'Δa_w %':>7} "
        f"{'Wz':>6} {'max |δ| mm':>10} {'contacts':>8}"
    )
    lines = [head]
    for r in rows:
        lines.append(
            f"{r['track_class']:>5} {r['policy']:<16} {r['rms_acc']:8.3f} {r['a_w']:8.3f} "
            f"{r['a_w_reduction_%']:7.1f} {r['wz']:6.2f} {r['max_defl_mm']:10.1f} "
            f"{r['contacts']:8.0f}"
        )
    return "\n".join(lines)


def evaluate_crash(
    policies: Sequence[str],
    backend: str = "reference",
    speeds_kmh: Sequence[float] = (40.0,),
    trust: bool = False,
) -> list[dict[str, Any]]:
    """One row per (speed, policy): episode-end crash-safety indices of ``TrainCrash-v0``
    (``trust``: see :func:`load_policy`)."""
    speeds_kmh = [val.real(v, "speeds_kmh") for v in val.sequence(speeds_kmh, "speeds_kmh")]
    for v in speeds_kmh:
        if not 0 < v <= MAX_SPEED_KMH:
            raise val.FieldError(
                "speeds_kmh", f"must be in (0, {MAX_SPEED_KMH:g}] km/h, got {v!r} km/h"
            )
    rows = []
    loaded = [
        load_policy(p, CRASH_ID, trust) if p != "passive" else (None, {}, "passive")
        for p in val.sequence(policies, "policies")
    ]
    for v in speeds_kmh:
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
    parser.add_argument("policy", nargs="+", help=f"{', '.join(CONTROLLERS)} or a policy .zip")
    parser.add_argument(
        "--backend",
        default="reference",
        choices=["reference", "surrogate", "linear"],
        help="model the policies run on (crash: reference or surrogate)",
    )
    parser.add_argument(
        "--track-class",
        type=bounded_int(1, 6),
        nargs="+",
        default=[4, 6],
        help="vertical: FRA track classes 1..6",
    )
    parser.add_argument(
        "--episodes",
        type=bounded_int(1, MAX_EPISODES),
        default=10,
        help=f"vertical: episodes per class, 1..{MAX_EPISODES} (one sub-env each)",
    )
    parser.add_argument("--seed", type=bounded_int(0), default=1000, help="track seed of sub-env 0")
    parser.add_argument("--env", choices=["vertical", "crash"], default="vertical")
    parser.add_argument(
        "--speed", type=speed_kmh, nargs="+", default=[40.0], help="crash: impact speeds, km/h"
    )
    parser.add_argument(
        "--trust",
        action="store_true",
        help="load a policy .zip that is not listed with its SHA-256 in the "
        "manifest.json its training wrote (a warning is given); only its network "
        "weights are read, never its pickled fields",
    )


def run(args: argparse.Namespace) -> int:
    """``railgym evaluate``: the policies plus passive (and skyhook) for comparison."""
    if args.env == "crash":
        if args.backend == "linear":
            raise ValueError("--backend: the crash env has backends reference and surrogate")
        policies = ["passive"] + [p for p in args.policy if p != "passive"]
        rows = evaluate_crash(policies, args.backend, args.speed, args.trust)
        print(
            f"TrainCrash-v0, backend: {args.backend}; Δpeak: reduction of the largest car "
            "deceleration vs the passive absorbers"
        )
        print(format_crash_rows(rows))
        return 0
    policies = ["passive", "skyhook"] + [p for p in args.policy if p not in ("passive", "skyhook")]
    rows = evaluate(policies, args.backend, args.track_class, args.episodes, args.seed, args.trust)
    print(
        f"backend: {args.backend}, {args.episodes} episodes per class (seeds {args.seed}+i); "
        "Δa_w: reduction of the Wk-weighted RMS vs passive"
    )
    print(format_rows(rows))
    return 0
