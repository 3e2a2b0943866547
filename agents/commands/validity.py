"""``railgym validity``: the validity flags against the surrogate's error, per case
(:func:`agents.evaluation.validity.validity_rows`)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from agents.commands.flags import (
    add_track_classes,
    bounded_real,
    duration_s,
    episodes,
    error_status,
)
from agents.evaluation import validity
from agents.evaluation.validity import THRESHOLD, format_rows, target_holds, validity_rows
from agents.evaluation.vehicle_validation import ENVS, SEED
from railgym.progress import quiet
from surrogates.cli_flags import Parser, add_common, add_seed


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym validity``."""
    parser = Parser(prog="railgym validity", description=validity.__doc__.split("\n\n")[0])
    parser.add_argument("--env", choices=sorted(ENVS), default=None, help="the env (default: both)")
    add_track_classes(parser, [3, 4, 5, 6])
    parser.add_argument(
        "--factor",
        type=bounded_real("speed factor", "× the class's maximum speed", 2.0),
        nargs="+",
        default=[1.0, 1.5, 2.0],
        help="speeds as multiples of each class's maximum speed (the envs accept up to 2)",
    )
    parser.add_argument(
        "--controller", nargs="+", default=["passive", "skyhook"], help="closed-loop controllers"
    )
    parser.add_argument("--seeds", type=episodes, default=5, help="tracks per case")
    add_seed(parser, "track seed of the first track (then +1, +2, ...)", default=SEED)
    parser.add_argument("--duration", type=duration_s, default=20.0, help="s per track")
    parser.add_argument(
        "--threshold",
        type=bounded_real("error", "%", 100.0),
        default=THRESHOLD,
        help="relative RMS error, %%, above which an episode must be flagged",
    )
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Print the table; exit status 1 when the target does not hold."""
    parser = build_parser()
    args = parser.parse_args(argv)
    envs = ["vertical", "vehicle"] if args.env is None else [args.env]
    for env in envs:
        for c in args.controller:
            if c not in ENVS[env][1]:
                parser.error(f"--controller {c!r} is not a controller of --env {env}")
    try:
        with quiet(args.quiet):
            rows = validity_rows(
                envs,
                args.track_class,
                args.factor,
                args.controller,
                args.seeds,
                args.duration,
                args.seed,
            )
    except Exception as err:
        return error_status(parser.prog, err, args.debug)
    print(format_rows(rows, args.threshold))
    return 0 if target_holds(rows, args.threshold) else 1
