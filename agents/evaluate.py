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
from typing import Any

import gymnasium as gym
import numpy as np

from agents import crash_report
from agents._args import (
    add_parallel_arguments,
    bounded_int,
    check_parallel,
    check_speed_kmh,
    duration_s,
    speed_kmh,
)
from agents.gap import run_gap
from agents.policies import (
    CONTROLLERS,
    CONTROLLERS_OF,
    CRASH_ID,
    ENV_ID,
    ENVELOPE_BASELINES,
    MAX_EPISODES,
    RLLIB_MODULE_PATH,
    VEHICLE_COMFORT,
    VEHICLE_CONTROLLERS,
    VEHICLE_ID,
    VehicleTask,
    evaluate_vehicle,
    load_policy,
    run_policy,
    run_vehicle_policy,
)
from agents.pretrained import PRETRAINED
from agents.sweeps import evaluate_sweep
from railgym import _checks as val
from railgym.progress import bar

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
    "add_arguments",
    "evaluate_crash",
    "evaluate_envelope",
    "evaluate_vehicle",
    "format_crash_rows",
    "format_rows",
    "format_vehicle_rows",
    "load_policy",
    "run",
    "run_policy",
    "run_vehicle_policy",
]


def format_rows(rows: list[dict[str, Any]]) -> str:
    """Aligned text table of :func:`agents.sweeps.evaluate_sweep` rows."""
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


# ================================================================ railgym/TrainCrash-v1
def evaluate_crash(
    policies: Sequence[str],
    backend: str = "reference",
    speeds_kmh: Sequence[float] = (40.0,),
    trust: bool = False,
) -> list[dict[str, Any]]:
    """One row per (speed, policy): episode-end crash-safety indices of ``TrainCrash-v1``
    (``trust``: see :func:`load_policy`)."""
    speeds_kmh = [check_speed_kmh(v, "speeds_kmh") for v in val.sequence(speeds_kmh, "speeds_kmh")]
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
    """The held-out envelope evaluation of ``TrainCrash-v1`` on the reference backend
    (:func:`agents.crash_report.envelope_rows`): the passive absorbers, the best constant
    setting, the speed-adaptive rule and each trained policy ``.zip`` of ``policies`` (the
    baseline names ``passive``, ``best-constant``, ``speed-adaptive`` there are accepted; the
    three always run) at ``speeds_kmh`` (default the held-out speeds) × the two payloads."""
    speeds = (
        crash_report.EVAL_SPEEDS_KMH
        if speeds_kmh is None
        else [check_speed_kmh(v, "speeds_kmh") for v in val.sequence(speeds_kmh, "speeds_kmh")]
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
        type=duration_s,
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


def _only_for(args: argparse.Namespace, flags: dict[str, bool], envs: str) -> None:
    """One error naming each flag of ``flags`` that is set (True) but not used by ``--env``."""
    for flag, given in flags.items():
        if given:
            raise ValueError(f"{flag}: only for {envs}, not --env {args.env}")


def run(args: argparse.Namespace) -> int:
    """``railgym evaluate``: the policies plus passive (and skyhook) for comparison."""
    if args.gap:
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
            rows = evaluate_envelope(args.policy, args.speed, args.trust)
            print("TrainCrash-v1 envelope scenario, held-out cases on the reference backend")
            print(crash_report.envelope_table(rows))
            return 0
        policies = ["passive"] + [p for p in args.policy if p != "passive"]
        rows = evaluate_crash(policies, args.backend, args.speed or [40.0], args.trust)
        print(
            f"TrainCrash-v1, backend: {args.backend}; Δpeak: reduction of the largest car "
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
            f"VerticalVehicle-v1, backend: {args.backend}, {args.episodes} episodes per case "
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
