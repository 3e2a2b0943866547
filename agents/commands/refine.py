"""``railgym refine POLICY``: refine a vertical surrogate element for a policy.

The loop a user runs after training an agent: the reference model is driven by the policy,
reference samples are added where the element's force error is largest (or its inputs leave
the training box), the element is refitted, and the held-out error is printed per round
(:func:`railgym.vehicles.collect.refine`; ``--env vehicle``: the whole vehicle, both bogies,
:func:`railgym.vehicles.vehicle.refine.refine_vehicle`). The refined element is written as
model JSON and used with ``VerticalSuspensionEnv(surrogate=PATH)`` or
``VerticalVehicleEnv(surrogate=PATH)``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents.commands.flags import add_track_classes, bounded_int, duration_s
from agents.controllers.registry import CONTROLLERS, ENV_ID, VEHICLE_CONTROLLERS, VEHICLE_ID
from agents.policies.loading import load_policy
from railgym.envs.vehicle.env import VerticalVehicleEnv
from railgym.envs.vertical.env import VerticalSuspensionEnv
from railgym.fmu.collect import refine_fmu
from railgym.fmu.mapping import fmu_vehicle
from railgym.vehicles.collect import (
    RAW_OBSERVATION,
    default_vertical_surrogate,
    refine,
    save_vertical_surrogate,
)
from railgym.vehicles.refinement import RefineOptions
from railgym.vehicles.vehicle.collect import default_vehicle_surrogate
from railgym.vehicles.vehicle.refine import RAW_VEHICLE_OBSERVATION, refine_vehicle
from surrogates import io
from surrogates.cli_flags import add_out, add_seed

#: env observation channel → entry of the raw observation of ``refine``
_CHANNELS = {
    "x1": "x1",
    "v1": "v1",
    "x2": "x2",
    "v2": "v2",
    "bogie_acc": "a1",
    "carbody_acc": "a2",
    "z": "z",
    "zdot": "zdot",
}


def observation_map(env: VerticalSuspensionEnv) -> Any:
    """``raw (8,) → env observation`` (float32, normalised like the env, no sensor noise)."""
    index = {name: i for i, name in enumerate(RAW_OBSERVATION)}
    inv = 1.0 / np.asarray(env.obs_scale, dtype=np.float64)
    names = list(env.obs_names)

    def observe(raw: np.ndarray) -> np.ndarray:
        values = []
        for name in names:
            if name == "deflection":
                values.append(raw[index["x1"]] - raw[index["x2"]])
            elif name == "deflection_rate":
                values.append(raw[index["v1"]] - raw[index["v2"]])
            elif name == "carbody_vel":
                values.append(raw[index["v2"]])
            else:
                values.append(raw[index[_CHANNELS[name]]])
        return (np.asarray(values) * inv).astype(np.float32)

    return observe


def vehicle_observation_map(env: VerticalVehicleEnv) -> Any:
    """``raw (27,) → VerticalVehicle observation`` (float32, normalised like the env, no
    sensor noise); ``raw`` is :data:`~railgym.vehicles.vehicle.refine.RAW_VEHICLE_OBSERVATION`."""
    index = {name: i for i, name in enumerate(RAW_VEHICLE_OBSERVATION)}
    inv = 1.0 / np.asarray(env.obs_scale, dtype=np.float64)
    names = list(env.obs_names)
    p = env.vehicle_params

    def observe(raw: np.ndarray) -> np.ndarray:
        values = []
        for name in names:
            if name in index:
                values.append(raw[index[name]])
                continue
            quantity, side = name.rsplit("_", 1)
            b = 0 if side == "front" else 1
            xb = p.a if b == 0 else -p.a
            body = raw[0] + xb * raw[1] + p.phi_a * raw[2]
            body_v = raw[7] + xb * raw[8] + p.phi_a * raw[9]
            values.append(
                {
                    "deflection": raw[3 + 2 * b] - body,
                    "deflection_rate": raw[10 + 2 * b] - body_v,
                    "carbody_vel": body_v,
                }[quantity]
            )
        return (np.asarray(values) * inv).astype(np.float32)

    return observe


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``railgym refine``."""
    names = sorted(set(CONTROLLERS) | set(VEHICLE_CONTROLLERS))
    parser.add_argument("policy", help=f"{', '.join(names)} or a policy .zip")
    parser.add_argument(
        "--env",
        choices=("vertical", "vehicle"),
        default="vertical",
        help=f"{ENV_ID} (one bogie) or {VEHICLE_ID} (both bogies)",
    )
    parser.add_argument(
        "--surrogate",
        type=Path,
        help="the element to refine, model JSON (default: the packaged one)",
    )
    parser.add_argument("--rounds", type=bounded_int(0, 50), default=3, help="rounds K per class")
    add_track_classes(parser, [5], "FRA track classes 1..6, refined for in turn (K rounds each)")
    parser.add_argument("--duration", type=duration_s, default=10.0, help="s per track")
    parser.add_argument("--tracks", type=bounded_int(1, 100), default=2, help="tracks per round")
    parser.add_argument(
        "--add", type=bounded_int(1, 10**6), default=400, help="samples added per round"
    )
    add_seed(parser, "seed of the tracks")
    add_out(parser, "write the refined element here (model JSON)")
    parser.add_argument(
        "--trust", action="store_true", help="load a policy .zip not listed in its manifest"
    )
    parser.add_argument("--fmu-map", type=Path, help="an FMU as the reference: its mapping file")
    parser.add_argument("--fmu", type=Path, help="the FMU of --fmu-map (default: the map's fmu:)")
    parser.add_argument(
        "--vehicle",
        help="vertical: vehicle YAML (name or path) of the model (default: the packaged one; "
        "with --fmu-map the mapping's vehicle:)",
    )


def run(args: argparse.Namespace) -> int:
    """``railgym refine``: print the error per round (``--rounds`` per class of
    ``--track-class``, in turn), write ``-o/--out`` if given."""
    if args.out is not None and args.out.exists() and not args.overwrite:
        raise ValueError(f"--out {args.out}: exists; pass --overwrite to replace it")
    if args.out is not None and not args.out.parent.is_dir():  # before the rounds of work
        raise ValueError(f"--out {args.out}: the folder {str(args.out.parent)!r} does not exist")
    vehicle = getattr(args, "env", "vertical") == "vehicle"
    if args.surrogate is not None:
        model = io.load(args.surrogate)
    else:
        model = default_vehicle_surrogate() if vehicle else default_vertical_surrogate()
    if vehicle:
        if args.fmu_map is not None or args.fmu is not None or args.vehicle is not None:
            raise ValueError(
                "--fmu-map/--fmu/--vehicle: an FMU reference is one bogie; use --env vertical"
            )
        factory, env_kwargs, label = load_policy(args.policy, VEHICLE_ID, trust=args.trust)
        env: Any = gym.make(VEHICLE_ID, backend="reference", **env_kwargs).unwrapped
        loop, observe, extra = refine_vehicle, vehicle_observation_map(env), {}
    else:
        factory, env_kwargs, label = load_policy(args.policy, ENV_ID, trust=args.trust)
        veh = args.vehicle
        if args.fmu_map is not None:
            veh = fmu_vehicle(args.fmu_map, args.vehicle, "--vehicle ")
        if veh is not None:
            env_kwargs = {**env_kwargs, "vehicle": str(veh)}
        # the env only designs the policy's controller and scales its observation: an FMU's
        # vehicle needs no nonlinear elements of railgym's, so its linear backend serves
        backend = "reference" if args.fmu_map is None else "linear"
        env = gym.make(ENV_ID, backend=backend, **env_kwargs).unwrapped
        observe, extra = observation_map(env), {"vehicle": env.cfg.vehicle}
        loop = refine
        if args.fmu_map is not None or args.fmu is not None:
            loop, extra = refine_fmu, {**extra, "fmu_map": args.fmu_map, "fmu": args.fmu}
    where = "the whole vehicle" if vehicle else "one bogie"
    classes = " ".join(str(c) for c in args.track_class)
    policy = factory(env)
    for fra_class in args.track_class:
        print(f"refining the element for policy {label} on FRA class {fra_class} ({where})")
        options = RefineOptions(
            track_class=fra_class,
            duration=args.duration,
            n_tracks=args.tracks,
            n_add=args.add,
            control_dt=env.cfg.control_dt,
            f_max=env.cfg.f_max,
            seed=args.seed,
        )
        model, _ = loop(
            model, policy, rounds=args.rounds, options=options, observe=observe, **extra
        )
    if args.out is not None:
        source = f"railgym refine {args.policy}: {args.rounds} rounds on class {classes}"
        save_vertical_surrogate(model, None, args.out, source)
        print(f"written to {args.out}")
    return 0
