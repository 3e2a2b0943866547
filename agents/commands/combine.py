"""``railgym combine``: an element of a bench-tested damper with the vehicle file's springs
and bump stops (:func:`railgym.vehicles.components.combine_damper`)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from agents.commands.flags import check_out
from railgym.vehicles import components
from railgym.vehicles.collect import save_vertical_surrogate
from railgym.vehicles.components import combine_damper, read_bench_table
from surrogates.cli import add_degree_arguments, degree_candidates, unit_pairs
from surrogates.cli_flags import Parser, add_common, add_out, add_seed, error_status


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym combine``."""
    parser = Parser(prog="railgym combine", description=components.__doc__.split("\n\n")[0])
    parser.add_argument("data", help="CSV of one damper's bench test (stroke, velocity, force)")
    parser.add_argument("--vehicle", required=True, help="vehicle YAML (name or path)")
    parser.add_argument("--dampers", type=int, default=2, help="dampers per bogie (default 2)")
    parser.add_argument(
        "--columns",
        nargs=3,
        default=["du", "dv", "F"],
        metavar=("STROKE", "VELOCITY", "FORCE"),
        help="the table's columns (default du dv F)",
    )
    parser.add_argument(
        "--units",
        nargs="*",
        default=[],
        metavar="NAME=UNIT",
        help="units of the columns (e.g. du=mm dv=mm/s F=kN), else from the header 'du [mm]'",
    )
    parser.add_argument("--m", type=int, default=101, help="training samples (default 101)")
    add_degree_arguments(parser)
    add_out(parser, "element JSON to write", required=True)
    add_seed(parser, "seed of the training samples")
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """``railgym combine``: fit and write the combined element; exit status 2 on bad input."""
    parser = build_parser()
    args = parser.parse_args(argv)
    check_out(parser, args.out, args.overwrite)
    out = Path(args.out)
    try:
        u, force = read_bench_table(args.data, args.columns, unit_pairs(args.units))
        cands = degree_candidates(args.degree, args.max_degree, 2)
        model, report, veh = combine_damper(
            u, force, args.vehicle, args.dampers, m=args.m, seed=args.seed, candidates=cands
        )
        source = (
            f"bench test {args.data} ({args.dampers} dampers per bogie) combined with the "
            f"spring{' and bump stops' if veh.bump_stop else ''} of vehicle {veh.name}"
        )
        command = f"railgym combine {args.data} --vehicle {args.vehicle} --dampers {args.dampers}"
        save_vertical_surrogate(model, report, out, source, command, vehicle=(veh, args.vehicle))
    except Exception as err:
        return error_status(parser.prog, err, args.debug)
    print(report.format("N", table=not args.quiet))
    print(f"written to {out}")
    return 0
