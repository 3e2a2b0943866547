"""``railgym evaluate``: the arguments of the command and the run of its tables
(:mod:`agents.evaluation.evaluate`, :mod:`agents.evaluation.gap`)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from agents.commands.flags import (
    MAX_EPISODES,
    VEHICLE_DURATION_S,
    add_env_id,
    add_parallel_arguments,
    add_track_classes,
    check_parallel,
    duration_s,
    env_id_flag,
    env_id_of,
    env_kwargs_of,
    episodes,
    seed_number,
    speed_kmh,
    vehicle_cases,
    vertical_cases,
)
from agents.controllers.registry import (
    BASELINES,
    COMPARISON,
    CONTROLLERS,
    CRASH_ID,
    ENV_ID,
    FORCE_CONTROLLERS,
    VEHICLE_CONTROLLERS,
    VEHICLE_FORCE_CONTROLLERS,
    VEHICLE_ID,
)
from agents.controllers.semi_active_control import SEMI_ACTIVE_CONTROLLERS
from agents.evaluation import crash_report
from agents.evaluation.evaluate import (
    ENV_IDS,
    crash_header,
    evaluate_crash,
    evaluate_envelope,
    format_crash_rows,
    format_rows,
    format_vehicle_rows,
)
from agents.evaluation.gap import (
    SURROGATE,
    format_gap,
    gap_crash,
    gap_vehicle,
    gap_vertical,
)
from agents.evaluation.runs import (
    evaluate_vehicle,
)
from agents.evaluation.sweeps import evaluate_sweep
from agents.evaluation.vehicle_validation import whole_track_version
from agents.policies.loading import trained_actuator
from agents.policies.pretrained import PRETRAINED


def _listed(names: Sequence[str]) -> str:
    """``a, b and c``."""
    return " and ".join([", ".join(names[:-1]), names[-1]] if len(names) > 1 else names)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``railgym evaluate``: what runs, on which cases, how."""
    _add_models(parser)
    _add_cases(parser)
    _add_modes(parser)


def _add_models(parser: argparse.ArgumentParser) -> None:
    """``railgym evaluate``: the policies, the model they run on and its files."""
    parser.add_argument(
        "policy",
        nargs="+",
        help=f"vertical: {', '.join(CONTROLLERS)}; vehicle: {', '.join(VEHICLE_CONTROLLERS)}; "
        f"a pretrained policy ({', '.join(PRETRAINED)}) or a policy .zip. The comparison rows "
        f"are always added: {_listed(COMPARISON[ENV_ID])} (vertical, vehicle), "
        f"{_listed(COMPARISON[CRASH_ID])} (crash), {_listed(BASELINES[CRASH_ID])} "
        "(crash --envelope)",
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
        "--surrogate",
        type=Path,
        help="the element of --backend surrogate (and of the surrogate side of --gap): a model "
        "JSON (vertical, vehicle) or crash elements (railgym.vehicles.crash.fe)",
    )
    parser.add_argument(
        "--scenario",
        help="crash: scenario YAML (name or path) of the train: its cars and speed (and "
        "envelope, with --envelope; default: the policies' own, passive: paper, --envelope: "
        "envelope)",
    )
    parser.add_argument(
        "--vehicle",
        help="vertical, vehicle: vehicle YAML (name or path) the envs run and the controllers "
        "are designed for (default: the packaged one; with --backend fmu the mapping's "
        "vehicle:)",
    )


def _add_cases(parser: argparse.ArgumentParser) -> None:
    """``railgym evaluate``: the env, its tracks, speeds and episodes."""
    add_track_classes(parser, [4, 6], "vertical, vehicle: FRA track classes 1..6")
    parser.add_argument(
        "--episodes",
        type=episodes,
        default=10,
        help=f"vertical, vehicle: episodes per case, 1..{MAX_EPISODES} (one sub-env each)",
    )
    parser.add_argument("--seed", type=seed_number, default=1000, help="track seed of sub-env 0")
    parser.add_argument(
        "--env",
        choices=["vertical", "vehicle", "crash"],
        default="vertical",
        help="the env: VerticalSuspension, VerticalVehicle or TrainCrash (its version: "
        "--env-id, --env-version)",
    )
    add_env_id(parser, ENV_IDS)
    parser.add_argument(
        "--actuator",
        choices=["force", "semi-active"],
        help="vertical, vehicle: what the policies command, an actuator force or the "
        "controllable damper (semi-active; default: the actuator a trained policy was trained "
        "with, else the force; another one than the policy's is refused; semi-active "
        f"controllers: {', '.join(SEMI_ACTIVE_CONTROLLERS)}; passive is "
        "command 0; vehicle: one damper per bogie)",
    )
    parser.add_argument(
        "--speed-kmh",
        dest="speed",
        type=speed_kmh,
        nargs="+",
        help="vehicle: running speeds, km/h (default: each class's maximum speed); "
        "crash: impact speeds, km/h (default: the scenario's speed_kmh; --envelope: six speeds "
        "over its envelope); given, they override the scenario's and the table's header says so",
    )
    parser.add_argument(
        "--duration",
        type=duration_s,
        help=f"vehicle: seconds per episode (default {VEHICLE_DURATION_S:g})",
    )
    parser.add_argument(
        "--preview",
        type=float,
        default=0.0,
        help="vehicle: track preview horizon ahead of the rear wheelset, m (the env's preview=; "
        "0, the default: none; at most the front-to-rear wheelset distance, 21.56 m on the "
        "packaged vehicle); every policy runs with it (lq-preview uses it)",
    )


def _add_modes(parser: argparse.ArgumentParser) -> None:
    """``railgym evaluate``: the gap and envelope modes, workers, trust."""
    parser.add_argument(
        "--gap",
        action="store_true",
        help="run each policy on the surrogate and on --backend (default the reference) over "
        "the same held-out cases and print every task metric on both with their relative gap "
        "(agents.evaluation.gap)",
    )
    parser.add_argument(
        "--envelope",
        action="store_true",
        help="crash: the held-out envelope evaluation on the reference (speeds × two payloads) "
        f"of {', '.join(BASELINES[CRASH_ID])} and the given policy .zip files",
    )
    add_parallel_arguments(parser, "vertical, vehicle: ", "the cases", "the rows do")
    parser.add_argument(
        "--trust",
        action="store_true",
        help="load a policy .zip that is not listed with its SHA-256 in the "
        "manifest.json its training wrote (a warning is given); only its network "
        "weights are read, never its pickled fields",
    )


def actuator_kwargs(args: argparse.Namespace, env_id: str | None = None) -> dict[str, Any]:
    """The env keyword of ``--actuator``, or without the flag the actuator the trained
    policies were trained with (``{}`` where none says: the force), so that the comparison
    rows run on the same actuator as the policy; a trained policy of another actuator than
    ``--actuator`` (or than another trained policy) and a classical controller of the other
    actuator are refused, naming the flag; ``env_id``: the env the policies run on (default:
    that of ``--env`` without ``--env-id``)."""
    if args.env == "crash":
        if args.actuator is not None:
            raise ValueError(
                f"--actuator: only for --env vertical and vehicle, not --env {args.env}"
            )
        return {}
    vehicle = args.env == "vehicle"
    env_id = env_id or ENV_IDS[args.env]
    trained = {p: a for p in args.policy if (a := trained_actuator(p, env_id)) is not None}
    for p, a in trained.items():
        if args.actuator is not None and a != args.actuator:
            raise ValueError(
                f"--actuator {args.actuator}: policy {p} was trained with actuator {a}; drop "
                f"the flag (the policy's actuator is used) or give --actuator {a}"
            )
    if len(set(trained.values())) > 1:
        raise ValueError(
            "the trained policies were trained with different actuators ("
            + ", ".join(f"{p}: {a}" for p, a in trained.items())
            + "); evaluate each actuator's policies in their own command"
        )
    given = args.actuator or next(iter(trained.values()), None)
    actuator = given or "force"
    both = VEHICLE_CONTROLLERS if vehicle else CONTROLLERS
    force = VEHICLE_FORCE_CONTROLLERS if vehicle else FORCE_CONTROLLERS
    names = SEMI_ACTIVE_CONTROLLERS if actuator == "semi-active" else force
    for p in args.policy:
        if p in both and p not in names:
            other = "--actuator semi-active" if actuator == "force" else "the force actuator"
            raise ValueError(
                f"--actuator {actuator}: {p} is a controller of {other}; the controllers of "
                f"--actuator {actuator} are {', '.join(names)}"
            )
    return {} if given is None else {"actuator": given}


def _only_for(args: argparse.Namespace, flags: dict[str, bool], envs: str) -> None:
    """One error naming each flag of ``flags`` that is set (True) but not used by ``--env``."""
    for flag, given in flags.items():
        if given:
            raise ValueError(f"{flag}: only for {envs}, not --env {args.env}")


def run(args: argparse.Namespace) -> int:
    """``railgym evaluate``: the policies plus passive (and skyhook) for comparison."""
    env_id = env_id_of(args, ENV_IDS)
    actuated = actuator_kwargs(args, env_id)
    if args.preview and (args.env != "vehicle" or args.gap):
        raise ValueError("--preview: only for --env vehicle (and not with --gap)")
    if args.gap:
        return run_gap(args, actuated, env_id)
    parallel = {"--workers": args.workers != 1, "--address": args.address is not None}
    fmu = env_kwargs_of(args)
    if args.env == "crash":
        _only_for(
            args,
            {**parallel, "--duration": args.duration is not None, "--vehicle": bool(args.vehicle)},
            "vertical, vehicle",
        )
        if args.backend == "linear":
            raise ValueError("--backend: the crash env has backends reference and surrogate")
        if args.envelope:
            if env_id != CRASH_ID:
                raise ValueError(f"{env_id_flag(args)}: --envelope runs {CRASH_ID} only")
            if args.backend != "reference":
                raise ValueError("--envelope: evaluates on the reference backend only")
            rows = evaluate_envelope(args.policy, args.speed, args.trust, fmu)
            print(crash_report.envelope_header(rows, args.speed is not None))
            print(crash_report.envelope_table(rows))
            return 0
        first = COMPARISON[CRASH_ID]
        policies = [*first, *(p for p in args.policy if p not in first)]
        rows = evaluate_crash(policies, args.backend, args.speed, args.trust, fmu, env_id)
        print(crash_header(rows, args.backend, args.speed is not None, env_id))
        print(format_crash_rows(rows))
        return 0
    _only_for(args, {"--envelope": args.envelope}, "--env crash")
    check_parallel(args)
    first = COMPARISON[VEHICLE_ID if args.env == "vehicle" else ENV_ID]
    policies = [*first, *(p for p in args.policy if p not in first)]
    damper = (
        ", actuator: semi-active (passive: damper command 0)"
        if actuated.get("actuator") == "semi-active"
        else ""
    )
    if args.env == "vehicle":
        preview = {"preview": args.preview} if args.preview else {}
        rows = evaluate_vehicle(
            policies,
            args.backend,
            env_kwargs={**fmu, **preview, **actuated},
            env_id=env_id,
            **vehicle_cases(args),
        )
        print(
            f"{env_id}, backend: {args.backend}{damper}"
            f"{f', preview {args.preview:g} m' if args.preview else ''}, {args.episodes} "
            "episodes per case "
            f"(seeds {args.seed}+i); per floor point front/centre/rear; Δa_w: reduction of the "
            "Wk-weighted RMS vs passive"
        )
        print(format_vehicle_rows(rows))
        return 0
    _only_for(
        args,
        {"--speed-kmh": args.speed is not None, "--duration": args.duration is not None},
        "--env vehicle and crash",
    )
    env_kwargs = {**fmu, **actuated}
    rows = evaluate_sweep(
        policies, args.backend, env_kwargs=env_kwargs, env_id=env_id, **vertical_cases(args)
    )
    print(
        f"{env_id}, backend: {args.backend}{damper}, {args.episodes} episodes per class (seeds "
        f"{args.seed}+i); Δa_w: reduction of the Wk-weighted RMS vs passive; contacts: "
        "bump-stop substeps"
    )
    print(format_rows(rows))
    return 0


def _element_of(models: dict[str, Any]) -> str:
    """The surrogate side of ``--gap`` in words: the ``--surrogate`` file or the packaged
    element."""
    element = models.get("surrogate")
    return "the packaged element" if element is None else f"element {element}"


def _reference_of(args: argparse.Namespace) -> str:
    """The reference side of ``--gap`` in words: the FMU of ``--fmu-map`` or railgym's model
    of ``--backend`` (``"reference"``, ``"linear"``)."""
    if args.backend == "fmu":
        fmu = f"{args.fmu}, " if args.fmu is not None else ""
        return f"the FMU {fmu}mapping {args.fmu_map}"
    return "railgym's linear suspension" if args.backend == "linear" else "railgym's model"


def _whole_tracks(args: argparse.Namespace, env_id: str) -> str:
    """The env id of a gap against an FMU: the FMU backend draws its tracks whole, so both
    sides run the newest version that does (:func:`whole_track_version`); a streaming version
    named by ``--env-id`` / ``--env-version`` is refused, naming the flag."""
    whole = whole_track_version(env_id)
    given = args.env_id is not None or args.env_version is not None
    if given and whole != env_id:
        raise ValueError(
            f"{env_id_flag(args)}: streams its tracks, and the FMU backend draws them whole, so "
            f"--gap --backend fmu would compare other tracks; use {whole} (the default)"
        )
    return whole


def run_gap(
    args: argparse.Namespace, actuated: dict[str, Any] | None = None, env_id: str | None = None
) -> int:
    """``railgym evaluate POLICY... --gap``: gap rows of the given policies between the
    surrogate and ``--backend`` (default the reference), printed as a table; ``actuated``: the
    env keyword of ``--actuator`` (:func:`actuator_kwargs`), to both
    sides; ``env_id``: the env of ``--env-id`` (default: the one of ``--env``; the crash gap
    runs ``railgym/TrainCrash-v1`` only)."""
    if args.envelope:
        raise ValueError("--gap: runs the held-out envelope itself (--env crash), not --envelope")
    if args.backend == "fmu" and args.env != "crash":
        env_id = _whole_tracks(args, env_id or ENV_IDS[args.env])
    backends = (SURROGATE, args.backend)
    # --fmu, --fmu-map, --vehicle, --actuator: checked, passed to both
    models = {**env_kwargs_of(args), **(actuated or {})}
    on = "" if args.env == "crash" else f" on vehicle {models.get('vehicle', 'the packaged one')}"
    against = _element_of(models) if args.backend == SURROGATE else _reference_of(args)
    what = (
        f"surrogate ({_element_of(models)}) vs {args.backend} ({against}){on}; "
        f"gap = (surrogate − {args.backend}) / |{args.backend}|"
    )
    counted = f"; contacts: bump-stop substeps, surrogate / {args.backend}"
    if args.env == "crash":
        if env_id not in (None, CRASH_ID):
            raise ValueError(f"{env_id_flag(args)}: --gap on --env crash runs {CRASH_ID} only")
        if args.backend == "linear":
            raise ValueError("--backend: the crash env has backends reference and surrogate")
        for flag, given in {
            "--workers": args.workers != 1,
            "--address": args.address is not None,
            "--duration": args.duration is not None,
        }.items():
            if given:
                raise ValueError(f"{flag}: only for vertical, vehicle, not --env crash")
        rows = gap_crash(
            args.policy, args.speed, trust=args.trust, backends=backends, env_kwargs=models
        )
        scenario = models.get("scenario", "envelope")
        print(crash_report.train_line(scenario, f"held-out cases of its envelope; {what}"))
    elif args.env == "vehicle":
        cases = vehicle_cases(args)
        env_id = env_id or VEHICLE_ID
        rows = gap_vehicle(
            args.policy, backends=backends, env_kwargs=models, env_id=env_id, **cases
        )
        print(f"{env_id}, {args.episodes} episodes per case (seeds {args.seed}+i); {what}{counted}")
    else:
        for flag, given in {"--speed-kmh": args.speed, "--duration": args.duration}.items():
            if given is not None:
                raise ValueError(f"{flag}: only for --env vehicle and crash, not --env vertical")
        env_id = env_id or ENV_ID
        rows = gap_vertical(
            args.policy, backends=backends, env_kwargs=models, env_id=env_id, **vertical_cases(args)
        )
        print(
            f"{env_id}, {args.episodes} episodes per track class "
            f"(seeds {args.seed}+i); {what}{counted}"
        )
    print(format_gap(rows, args.backend))
    return 0
