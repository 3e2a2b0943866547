"""``railgym evaluate``: comfort indices of any controller or saved policy, beside passive and
skyhook, on the vertical env (one bogie) and on the whole vehicle (comfort at the front, centre
and rear floor points); crash-safety indices beside the passive absorbers on the crash env, or
over the held-out impact envelope beside the crash baselines.

    railgym evaluate skyhook --backend reference --track-class 4 6 --episodes 10
    railgym evaluate runs/ppo_vertical/model.zip --backend reference --track-class 4 6
    railgym evaluate modal-skyhook lqr --env vehicle --track-class 5 --speed 60 100 144 200
    railgym evaluate runs/ppo_crash/model.zip --env crash --speed 36 40 44
    railgym evaluate runs/ppo_crash/model.zip --env crash --envelope
    railgym evaluate clipped-lqg skyhook-onoff groundhook --actuator semi-active

``--env-id ID`` (or ``--env-version N``) runs the episodes on that registered version of the
env of ``--env`` (default: its newest version, ``VerticalSuspension-v3``, ``VerticalVehicle-v3``,
``TrainCrash-v1``; the table's header names the id).

Without ``--actuator`` the command takes the actuator a trained policy was trained with (its
run's settings; e.g. ``ppo-semiactive``: the damper), so that its comparison rows run on the
same actuator; an ``--actuator`` other than a trained policy's is refused.

A policy is a controller name (vertical: ``passive``, ``skyhook``, ``semi-active``,
``groundhook``, ``lqr``, ``lqg``; with ``--actuator semi-active``, the command of the env's
controllable damper: ``passive`` (command 0), ``constant-max``, ``skyhook-onoff``, ``skyhook``,
``groundhook``, ``clipped-lqg`` of :mod:`agents.controllers.semi_active_control`, and a controller
of the other actuator is refused; vehicle: ``passive``, ``skyhook`` (skyhook per bogie),
``modal-skyhook``, ``lqr``, ``lqg``, and with ``--actuator semi-active`` the same damper
controllers per bogie) or a stable-baselines3 ``.zip``: of :mod:`agents.training.train` (its
``model.zip`` or a checkpoint ``checkpoints/model_N_steps.zip``: the algorithm and the env's
observation settings from the run's ``config.yaml``), of rl-zoo3 (the run's ``args.yml`` and
``config.yml``) or any other (the algorithm and network from the zip's JSON ``data``; the env
from the flags), see :mod:`agents.policies.policy_zip`. The zip must be listed with its SHA-256 in
the ``manifest.json`` beside it (``--trust``: any zip, e.g. rl-zoo3's, with a warning), and only
its network weights are read (:mod:`agents.policies.policy_io`). Each case (track class, and speed
on the vehicle) runs ``episodes`` episodes in one native vector env, sub-env ``i`` on the track
of seed ``seed + i`` — the same tracks for every policy. ``--workers N`` / ``--address ADDR``
run the cases of the vertical and vehicle evaluations as parallel tasks
(:func:`railgym.parallel.run_tasks`); the rows do not depend on the number of workers.

The command always adds rows to compare against, whether or not they are named: ``passive``
and ``skyhook`` on the vertical env and the vehicle (first, in that order; the Δa_w column is
the reduction against passive), ``passive`` on the crash env (Δpeak against it), and the three
crash baselines ``passive``, ``best-constant``, ``speed-adaptive`` with ``--envelope``. Naming
one of them as well adds no second row. Beside ``a_w`` the vertical and vehicle tables give the
bump-stop contacts (substeps), and a column ``note`` says where a trained policy's ``a_w`` beats
a classical controller's with more contacts (:mod:`agents.evaluation.contacts`). A crash run that
the env cut as diverged (``info["diverged"]``) is marked in the table and named in a line under it.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents.commands.flags import (
    MAX_EPISODES,
    VEHICLE_DURATION_S,
    add_env_id,
    add_parallel_arguments,
    add_track_classes,
    backend_kwargs,
    check_parallel,
    check_speed_kmh,
    duration_s,
    env_id_flag,
    env_id_of,
    env_kwargs_of,
    episodes,
    seed_number,
    speed_kmh,
    vehicle_cases,
    vertical_cases,
    with_policy_kwargs,
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
    crash_factories,
)
from agents.controllers.semi_active_control import SEMI_ACTIVE_CONTROLLERS
from agents.evaluation import crash_report
from agents.evaluation.contacts import Score, contact_note, more_contacts
from agents.evaluation.gap import run_gap
from agents.evaluation.metrics import VEHICLE, VERTICAL, Metric
from agents.evaluation.runs import (
    evaluate_vehicle,
)
from agents.evaluation.sweeps import evaluate_sweep
from agents.policies.loading import load_policy, trained_actuator
from agents.policies.pretrained import PRETRAINED
from railgym import _checks as val
from railgym.progress import bar
from railgym.registration import newest
from surrogates.cli_flags import add_deprecated

__all__ = [
    "ENV_IDS",
    "actuator_kwargs",
    "add_arguments",
    "evaluate_crash",
    "evaluate_envelope",
    "format_crash_rows",
    "format_rows",
    "format_vehicle_rows",
    "run",
]


#: the env id of each ``--env`` without ``--env-id`` / ``--env-version``: its newest version
ENV_IDS = {
    env: newest(env_id)
    for env, env_id in {"vertical": ENV_ID, "vehicle": VEHICLE_ID, "crash": CRASH_ID}.items()
}


def _aligned(columns: Sequence[tuple[str, str, int]], cells: list[list[str]]) -> str:
    """A text table: columns ``(title, align, least width)`` (align ``"<"`` or ``">"``), each
    as wide as its title and its widest cell (a long policy name widens its column)."""
    widths = [
        max([least, len(title), *(len(row[k]) for row in cells)])
        for k, (title, _, least) in enumerate(columns)
    ]

    def line(values: Sequence[str]) -> str:
        parts = zip(values, columns, widths, strict=True)
        return " ".join(f"{v:{align}{w}}" for v, (_, align, _), w in parts).rstrip()

    return "\n".join([line([c[0] for c in columns]), *(line(row) for row in cells)])


#: columns of the surrogate's validity flags (docs/validation.md, *Validity flags*): the share
#: of steps with an element input outside its training box, and the case against the
#: element's operating envelope
VALIDITY_COLUMNS = [("out-box %", ">", 9), ("envelope", ">", 8)]


def _with_validity(
    rows: list[dict[str, Any]], columns: list[tuple[str, str, int]], cells: list[list[str]]
) -> tuple[list[tuple[str, str, int]], list[list[str]]]:
    """``columns`` and ``cells`` with :data:`VALIDITY_COLUMNS` added where a row ran the
    surrogate backend (``-`` in the others' rows: they never flag)."""
    if not any(r.get("backend") == "surrogate" for r in rows):
        return columns, cells

    def flags(r: dict[str, Any]) -> list[str]:
        if r.get("backend") != "surrogate":
            return ["-", "-"]
        return [f"{r['outside_element_%']:.3g}", "outside" if r["outside_envelope"] else "inside"]

    return columns + VALIDITY_COLUMNS, [c + flags(r) for c, r in zip(cells, rows, strict=True)]


def _with_contact_notes(
    scores: list[Score],
    baselines: Sequence[str],
    columns: list[tuple[str, str, int]],
    cells: list[list[str]],
) -> tuple[list[tuple[str, str, int]], list[list[str]]]:
    """``columns`` and ``cells`` with a column ``note`` where a trained policy's ``a_w`` beats
    a baseline's of its case (a classical controller: a name of ``baselines``) with more
    bump-stop contacts (:func:`agents.evaluation.contacts.more_contacts`): ``more contacts than
    lqg``."""
    notes = [contact_note(names) for names in more_contacts(scores, baselines)]
    if not any(notes):
        return columns, cells
    return columns + [("note", "<", 4)], [c + [n] for c, n in zip(cells, notes, strict=True)]


def _metric_columns(table: Sequence[Metric]) -> list[tuple[str, str, int]]:
    """Text-table columns of the metrics ``table``: title, right-aligned, least width."""
    return [(m.title, ">", m.width) for m in table]


def format_rows(rows: list[dict[str, Any]]) -> str:
    """Aligned text table of :func:`agents.evaluation.sweeps.evaluate_sweep` rows, the metrics
    of :data:`agents.evaluation.metrics.VERTICAL` (each column as wide as its widest entry; on
    the surrogate backend with :data:`VALIDITY_COLUMNS`; a column ``note`` names the classical
    controllers a trained policy beats in ``a_w`` with more bump-stop contacts)."""
    columns = [("class", ">", 5), ("policy", "<", 16), *_metric_columns(VERTICAL)]
    cells = [
        [str(r["track_class"]), str(r["policy"]), *(m.cell(r) for m in VERTICAL)] for r in rows
    ]
    scores = [Score(r["track_class"], str(r["policy"]), r["a_w"], r["contacts"]) for r in rows]
    return _aligned(
        *_with_contact_notes(scores, list(CONTROLLERS), *_with_validity(rows, columns, cells))
    )


def format_vehicle_rows(rows: list[dict[str, Any]]) -> str:
    """Aligned text table of :func:`evaluate_vehicle` rows, the metrics of
    :data:`agents.evaluation.metrics.VEHICLE`, front / centre / rear per index (each column as
    wide as its widest entry; on the surrogate backend with :data:`VALIDITY_COLUMNS`; a column
    ``note`` names the classical controllers a trained policy beats in ``a_w``, the mean over
    the floor points, with more bump-stop contacts)."""
    columns = [("class", ">", 5), ("km/h", ">", 5), ("policy", "<", 14), *_metric_columns(VEHICLE)]
    cells = [
        [
            str(r["track_class"]),
            f"{r['speed_kmh']:.0f}",
            str(r["policy"]),
            *(m.cell(r) for m in VEHICLE),
        ]
        for r in rows
    ]
    scores = [
        Score(
            (r["track_class"], r["speed_kmh"]),
            str(r["policy"]),
            float(np.mean(r["a_w"])),
            r["contacts"],
        )
        for r in rows
    ]
    notes = _with_contact_notes(
        scores, list(VEHICLE_CONTROLLERS), *_with_validity(rows, columns, cells)
    )
    return _aligned(*notes)


# ================================================================ railgym/TrainCrash-v1
def evaluate_crash(
    policies: Sequence[str],
    backend: str = "reference",
    speeds_kmh: Sequence[float] | None = None,
    trust: bool = False,
    env_kwargs: dict[str, Any] | None = None,
    env_id: str = CRASH_ID,
) -> list[dict[str, Any]]:
    """One row per (speed, policy): episode-end crash-safety indices of ``env_id`` (a version
    of ``railgym/TrainCrash``; ``trust``: see :func:`load_policy`); ``env_kwargs`` (e.g. the
    user's ``scenario``, ``surrogate``) are added to each policy's training settings;
    ``speeds_kmh`` ``None``:
    each env's scenario speed (its ``speed_kmh``). ``diverged``: the env cut the run where its
    state diverged (``info["diverged"]``), the indices are those at the cut; ``scenario``: the
    :class:`~railgym.vehicles.crash.scenario.CrashScenario` each row ran."""
    speeds: list[float | None] = (
        [None]
        if speeds_kmh is None
        else [check_speed_kmh(v, "speeds_kmh") for v in val.sequence(speeds_kmh, "speeds_kmh")]
    )
    rows = []
    extra = dict(env_kwargs or {})
    loaded = [
        load_policy(p, env_id, trust) if p != "passive" else (None, {}, "passive")
        for p in val.sequence(policies, "policies")
    ]
    for v in bar(speeds, desc="speeds"):
        passive = None
        for factory, env_kwargs, label in loaded:
            # the speed as a reset option: the observation keeps the scales the policy was
            # trained with (an explicit `speed` would rescale an envelope's velocities)
            kwargs = with_policy_kwargs(env_kwargs, backend_kwargs(backend, extra), label)
            env = gym.make(env_id, backend=backend, **kwargs)
            scenario = env.unwrapped.cfg.scenario
            kmh = 3.6 * scenario.speed if v is None else v
            ctrl = factory(env) if factory else None
            obs, _ = env.reset(seed=0, options={"speed_kmh": kmh})
            while True:
                if ctrl is None:
                    action = np.zeros(env.action_space.shape or (), np.float32)
                else:
                    action, _ = ctrl.predict(obs, deterministic=True)
                obs, _, term, trunc, info = env.step(action)
                if term or trunc:
                    break
            peak = float(np.max(info["peak_decel_g"]))
            passive = peak if label == "passive" else passive
            rows.append(
                {
                    "speed_kmh": kmh,
                    "scenario": scenario,
                    "policy": label,
                    "peak_decel_g": info["peak_decel_g"],
                    "max_crush_m": info["max_crush_m"],
                    "stroke_exceeded": bool(info["stroke_exceeded"]),
                    "diverged": bool(info["diverged"]),
                    "peak_reduction_%": 100 * (1 - peak / passive) if passive else float("nan"),
                }
            )
    return rows


def evaluate_envelope(
    policies: Sequence[str],
    speeds_kmh: Sequence[float] | None = None,
    trust: bool = False,
    env_kwargs: dict[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """The held-out envelope evaluation of ``TrainCrash-v1`` on the reference backend
    (:func:`agents.evaluation.crash_report.envelope_rows`): the passive absorbers, the best constant
    setting, the speed-adaptive rule and each trained policy ``.zip`` of ``policies`` (the
    baseline names ``passive``, ``best-constant``, ``speed-adaptive`` there are accepted; the
    three always run) at ``speeds_kmh`` (default the held-out speeds of the scenario's
    envelope, :func:`~agents.evaluation.crash_report.envelope_cases`) × its lightest and
    heaviest payloads; ``env_kwargs`` (the user's ``scenario``) join the policies' training
    settings (another value than a policy's is an error naming it)."""
    speeds = (
        None
        if speeds_kmh is None
        else [check_speed_kmh(v, "speeds_kmh") for v in val.sequence(speeds_kmh, "speeds_kmh")]
    )
    factories = crash_factories(BASELINES[CRASH_ID])
    kwargs = dict(env_kwargs or {})
    trained: dict[str, Any] | None = None
    for p in val.sequence(policies, "policies"):
        if crash_factories([p]):
            continue
        factory, settings, label = load_policy(p, CRASH_ID, trust)
        if trained is not None and settings != trained:
            raise ValueError(
                f"policy {p}: trained with env settings {settings}, another policy with "
                f"{trained}; evaluate them in separate runs"
            )
        trained, factories[label] = settings, factory
        kwargs = with_policy_kwargs(settings, kwargs, label)
    return crash_report.envelope_rows(factories, kwargs, speeds)


def crash_header(
    rows: list[dict[str, Any]], backend: str, speed_flag: bool, env_id: str = CRASH_ID
) -> str:
    """The line over :func:`format_crash_rows`: ``env_id``, the train(s) the rows ran
    (scenario, cars, the scenario's speed) and, where ``--speed-kmh`` was given
    (``speed_flag``), that it overrides that speed."""
    speeds = (
        "impact speeds from --speed-kmh (override the scenario's speed_kmh)"
        if speed_flag
        else "impact speed: the scenario's speed_kmh"
    )
    return (
        f"{env_id}, {crash_report.trains_of(rows)}, backend: {backend}; {speeds}; Δpeak: "
        "reduction of the largest car deceleration vs the passive absorbers"
    )


def format_crash_rows(rows: list[dict[str, Any]]) -> str:
    """Aligned text table of :func:`evaluate_crash` rows (each column as wide as its widest
    entry); a run the env cut as diverged is marked in the column ``diverged`` and named in a
    line under the table."""
    columns = [
        ("km/h", ">", 5),
        ("policy", "<", 16),
        ("peak decel per car (g)", "<", 24),
        ("Δpeak %", ">", 7),
        ("max crush per zone (m)", "<", 24),
        ("stroke exceeded", "<", 15),
        ("diverged", "<", 8),
    ]
    cells = [
        [
            f"{r['speed_kmh']:.0f}",
            str(r["policy"]),
            " ".join(f"{x:.2f}" for x in np.atleast_1d(r["peak_decel_g"])),
            f"{r['peak_reduction_%']:.1f}",
            " ".join(f"{x:.3f}" for x in np.atleast_1d(r["max_crush_m"])),
            str(r["stroke_exceeded"]),
            "yes" if r.get("diverged", False) else "no",
        ]
        for r in rows
    ]
    cut = [f"{r['policy']} at {r['speed_kmh']:g} km/h" for r in rows if r.get("diverged", False)]
    return "\n".join([_aligned(columns, cells), *crash_report.diverged_lines(cut)])


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
    speed = parser.add_argument(
        "--speed-kmh",
        dest="speed",
        type=speed_kmh,
        nargs="+",
        help="vehicle: running speeds, km/h (default: each class's maximum speed); "
        "crash: impact speeds, km/h (default: the scenario's speed_kmh; --envelope: six speeds "
        "over its envelope); given, they override the scenario's and the table's header says so",
    )
    add_deprecated(parser, speed, "--speed")
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
        {"--speed": args.speed is not None, "--duration": args.duration is not None},
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
