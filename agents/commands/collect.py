"""``railgym collect``: collect training data on the built-in reference (or, with
``--fmu-map``, on an FMU: :func:`railgym.fmu.collect.fmu_design_runs`) and build a vertical
element (:mod:`railgym.vehicles.collect`, :mod:`railgym.vehicles.memory_element`)."""

from __future__ import annotations

import argparse
import itertools
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from agents.commands.flags import check_out
from railgym import _checks as val
from railgym.vehicles import collect as vertical_collect
from railgym.vehicles.collect import PACKAGED, build_vertical_surrogate, save_vertical_surrogate
from railgym.vehicles.collect_design import DESIGNS, MEMORY_SAMPLE_RATE
from railgym.vehicles.memory_element import (
    MEMORY_DESIGN,
    PACKAGED_GRID,
    PACKAGED_TAUS,
    build_memory_surrogate,
    design_with,
    memory_degrees,
    stage,
)
from railgym.vehicles.vertical.params import load_vehicle
from surrogates.cli_flags import (
    Parser,
    RawHelpFormatter,
    add_common,
    add_out,
    add_seed,
    error_status,
)
from surrogates.memory import TauSelection
from surrogates.models import SurrogateModel


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym collect``."""
    from surrogates.cli import add_degree_arguments, add_memory_arguments

    parser = Parser(
        prog="railgym collect",
        description=vertical_collect.__doc__,
        formatter_class=RawHelpFormatter,
    )
    parser.add_argument(
        "--features",
        choices=sorted(PACKAGED),
        help="the element's form: maxwell (one memory state, k-fold recipe) or static (the "
        "paper's GA recipe); default: the k-fold recipe with the memory states the data ask "
        "for (--memory-states), maxwell when regenerating the packaged file (no -o/--out: "
        "with that file's own tau values and degree grid unless --tau / --degree / "
        "--max-degree are given)",
    )
    parser.add_argument(
        "--design",
        choices=DESIGNS,
        help=f"data collection (default: maxwell {MEMORY_DESIGN}, static paper)",
    )
    add_out(
        parser,
        "model JSON (default: regenerate the packaged file of the form); an existing file is "
        "replaced only with --overwrite",
        overwrite="replace an existing -o/--out",
        type=str,
    )
    parser.add_argument("--m", type=int, default=101, help="static: GA training samples")
    add_seed(
        parser,
        "seed of the paper design's track, the sampling and the folds (default: 0, the "
        "packaged elements'; another needs -o/--out)",
        default=None,
    )
    parser.add_argument(
        "--fmu-map",
        help="collect from this FMU mapping file (env: vertical or vehicle; docs/fmi.md)",
    )
    parser.add_argument("--fmu", help="the FMU of --fmu-map (default: the map's fmu:)")
    parser.add_argument(
        "--vehicle",
        help="vehicle YAML (name or path) of the model: masses for the force balance, bump "
        "stops for the element's known physics; with --fmu-map required unless the mapping "
        "has vehicle:, the whole-vehicle file for env: vehicle (default without --fmu-map: "
        "manchester)",
    )
    add_degree_arguments(
        parser,
        "; static default 16 per input; maxwell: the grid of each input (from 12, 12, 14 in "
        "steps of 2) up to N, default 16 16 20",
    )
    add_memory_arguments(parser)
    add_common(parser)
    return parser


def _candidates(args: argparse.Namespace) -> list[tuple[int, ...]] | None:
    """Degree candidates of ``--degree`` / ``--max-degree`` (``None``: the form's default);
    ``UsageError`` or ``ValueError`` for bad values."""
    from surrogates.cli import check_degrees

    n_inputs = 2 if args.features == "static" else 3
    degree = check_degrees(args.degree, "--degree", n_inputs)
    top = check_degrees(args.max_degree, "--max-degree", n_inputs)
    if args.features == "static":
        if top is not None:
            return list(itertools.product(*(range(1, t + 1) for t in top)))
        return [degree] if degree else None
    if not (degree or top) and args.out is None:
        top = PACKAGED_GRID  # regenerating the packaged element: its own grid, not widened
    return [degree] if degree else (memory_degrees(top) if top else None)


def main(argv: Sequence[str] | None = None) -> int:
    """Regenerate a packaged element (or write one elsewhere); ``--fmu-map`` collects on the
    FMU of that mapping (:func:`railgym.fmu.collect.fmu_design_runs`)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return _collect(parser, args)
    except Exception as err:
        return error_status(parser.prog, err, args.debug)


def _memory_flags(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int | None:
    """The number of memory states of ``--features`` / ``--memory-states`` (``None``: from the
    data); ``--features`` set to ``maxwell`` when regenerating the packaged file; a
    contradiction exits 2 naming the flags."""
    memory = (args.tau, args.memory_states, args.coupled or None)
    if args.features == "static" and any(v is not None for v in memory):
        parser.error(
            "--tau, --memory-states, --coupled: for the k-fold memory recipe, not --features static"
        )
    if args.features == "maxwell" and args.memory_states == 0:
        parser.error("--memory-states 0 contradicts --features maxwell (one memory state)")
    if args.features is None and args.out is None:
        args.features = "maxwell"  # regenerating the packaged memory element
    if args.features == "maxwell" and args.out is None and args.tau is None:
        args.tau = list(PACKAGED_TAUS)  # the packaged element's own τ values
    return 1 if args.features == "maxwell" else args.memory_states


def _build_memory(
    args: argparse.Namespace,
    cands: Any,
    seed: int,
    progress: Any,
    data: dict[str, Any] | None,
    veh: Any,
    states: int | None,
) -> tuple[SurrogateModel, TauSelection]:
    """The k-fold memory element of ``railgym collect`` (:func:`build_memory_surrogate`;
    the coupled map scored with ``--coupled``; the product input δ·ζ without ``--features``,
    not for ``--features maxwell`` nor a whole vehicle's mapping, whose kernels take the
    ``"maxwell"`` form); the edge warning of the τ search is a line of the printed report,
    not a Python warning."""
    from railgym.fmu.mapping import mapping_env

    whole = args.fmu_map is not None and mapping_env(args.fmu_map) == "vehicle"
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "tau = .* end of the search", UserWarning)
        model, report, _ = build_memory_surrogate(
            design=args.design,
            degrees=cands,
            seed=seed,
            progress=progress,
            data=data,
            vehicle=veh,
            tau=args.tau,
            memory_states=states,
            coupled=None if args.coupled else False,
            product=args.features is None and not whole,
        )
    return model, report


def _checked(parser: argparse.ArgumentParser, args: argparse.Namespace) -> Any:
    """The degree candidates of ``railgym collect`` after checking ``-o/--out`` and the flags
    that need it, before the minutes of work; a bad one exits 2 naming it."""
    from surrogates.cli import UsageError

    if args.out is not None:
        check_out(parser, args.out, args.overwrite)
    try:
        cands = _candidates(args)
    except (UsageError, ValueError) as err:
        parser.error(str(err))
    if args.fmu is not None and args.fmu_map is None:
        parser.error("--fmu: only with --fmu-map (the FMU of that mapping file)")
    given = (("--fmu-map", args.fmu_map), ("--vehicle", args.vehicle), ("--seed", args.seed))
    for flag, value in given:
        if args.out is None and value is not None:
            parser.error(f"{flag} needs -o/--out: the packaged element is not replaced")
    return cands


def _collect(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    """``railgym collect`` after the parse: check, collect, fit, write."""
    from railgym.progress import quiet, stages

    states = _memory_flags(parser, args)
    if args.design is None:
        args.design = "paper" if args.features == "static" else MEMORY_DESIGN
    cands = _checked(parser, args)
    progress = stages()
    data = None
    seed = 0 if args.seed is None else args.seed
    vehicle = args.vehicle or "manchester"
    try:
        if args.fmu_map is not None:
            from railgym.fmu.collect import fmu_design_runs

            rate = 50.0 if args.features == "static" else MEMORY_SAMPLE_RATE
            with quiet(args.quiet):
                vehicle, data = fmu_design_runs(
                    args.fmu_map,
                    args.fmu,
                    args.vehicle,
                    design_with(args.design, None, rate),
                    stage(progress, "FMU runs"),
                )
        veh = load_vehicle(vehicle)
    except (val.FieldError, OSError) as err:
        parser.exit(2, f"{parser.prog}: error: {err}\n")
    out = args.out or str(
        Path(vertical_collect.__file__).parents[1] / "data" / PACKAGED[args.features]
    )
    where = (
        f"FRA class 5, 144 km/h, 20 s, track seed {seed}"
        if args.design == "paper"
        else "envelope design (classes 3-6, 0.7/1.0 of class speed, passive + excited)"
    )
    with quiet(args.quiet):
        if args.features == "static":
            model, report, _ = build_vertical_surrogate(
                m=args.m,
                seed=seed,
                track_seed=seed,
                design=args.design,
                candidates=cands,
                progress=progress,
                data=data,
                vehicle=veh,
            )
            text = report.format("N")
            source = f"railgym dynamic reference ({veh.name}), {where}, 50 Hz, M = {args.m} (GA)"
        else:
            model, report = _build_memory(args, cands, seed, progress, data, veh, states)
            text = report.format()
            target = "F_s - F_bump" if veh.known_physics else "F_s"
            memory = model.features_["form"] != "static"
            state = "the Maxwell state" if memory else "no memory state"
            source = (
                f"railgym dynamic reference ({veh.name}), {where}, 200 Hz; passive LPR on "
                f"{target} with {state}"
            )
    if args.fmu_map is not None:
        source = f"FMU of {args.fmu_map} (vehicle {veh.name})" + source[source.index(",") :]
    record = (veh, vehicle)  # metadata.vehicle: the vehicle collected on
    save_vertical_surrogate(model, report, out, source, envelope=args.design, vehicle=record)
    print(text)
    print(f"written to {out}")
    return 0
