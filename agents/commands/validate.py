"""``railgym validate``: the surrogate against the reference or an FMU, per track class
(:func:`agents.evaluation.vehicle_validation.validation_rows`)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

from agents.commands.flags import add_track_classes, duration_s, episodes, error_status
from agents.evaluation import vehicle_validation
from agents.evaluation.vehicle_validation import ENVS, SEED, format_rows, validation_rows
from railgym.progress import quiet
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.vehicle.collect import default_vehicle_surrogate
from surrogates.cli_flags import Parser, add_common, add_seed


def _packaged(name: str) -> Any:
    """A packaged element by name (``vehicle``, ``maxwell``, ``static``), else ``name`` (a path)."""
    if name == "vehicle":
        return default_vehicle_surrogate()
    if name in ("maxwell", "static"):
        return default_vertical_surrogate(name)
    return name


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym validate``."""
    parser = Parser(
        prog="railgym validate", description=vehicle_validation.__doc__.split("\n\n")[0]
    )
    parser.add_argument("--env", choices=sorted(ENVS), default="vehicle", help="the env")
    parser.add_argument(
        "--element",
        nargs="+",
        default=None,
        help="packaged element (vehicle: the whole vehicle's default; maxwell, static: the "
        "one-bogie elements) or JSON (default: the env's packaged one)",
    )
    add_track_classes(parser, [3, 4, 5, 6])
    parser.add_argument(
        "--controller", nargs="+", default=["passive"], help="closed-loop controllers"
    )
    parser.add_argument("--seeds", type=episodes, default=20, help="tracks per class")
    add_seed(parser, "track seed of the first track (then +1, +2, ...)", default=SEED)
    parser.add_argument("--duration", type=duration_s, default=20.0, help="s per track")
    parser.add_argument(
        "--backend", choices=("reference", "fmu"), default="reference", help="the model compared"
    )
    parser.add_argument("--fmu-map", help="--backend fmu: the FMU's mapping file")
    parser.add_argument("--fmu", help="--backend fmu: the FMU (default: the mapping's fmu:)")
    parser.add_argument(
        "--vehicle",
        help="vehicle YAML (name or path) of both envs (default: the packaged one; with "
        "--backend fmu the mapping's vehicle:)",
    )
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Print the table (relative RMS error, %, median / 90th percentile / max per point)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    _, table, _ = ENVS[args.env]
    for c in args.controller:
        if c not in table:
            parser.error(f"--controller must be among {sorted(table)}, got {c!r}")
    if args.backend != "fmu" and (args.fmu_map or args.fmu):
        parser.error("--fmu-map, --fmu: only with --backend fmu")
    if args.backend == "fmu" and not args.fmu_map:
        parser.error("--backend fmu needs --fmu-map")
    reference: dict[str, Any] = {"backend": args.backend}
    if args.backend == "fmu":
        reference.update(fmu_map=args.fmu_map, fmu=args.fmu)
    try:
        if args.backend == "fmu":
            from railgym.fmu.mapping import fmu_vehicle

            reference["vehicle"] = str(fmu_vehicle(args.fmu_map, args.vehicle, "--vehicle "))
        elif args.vehicle is not None:
            reference["vehicle"] = args.vehicle
        names = args.element or ["vehicle" if args.env == "vehicle" else "maxwell"]
        elements = {e: _packaged(e) for e in names}
        with quiet(args.quiet):
            rows = validation_rows(
                elements,
                args.track_class,
                args.controller,
                args.seeds,
                args.duration,
                env_name=args.env,
                reference=reference,
                seed=args.seed,
            )
    except Exception as err:
        return error_status(parser.prog, err, args.debug)
    print(format_rows(rows))
    return 0
