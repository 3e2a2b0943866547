"""``railgym crash-limits``: ceilings of constant absorber settings per absorber range
(:func:`agents.evaluation.crash_limits.ceilings`, :func:`agents.evaluation.crash_limits.rule`)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from agents.evaluation import crash_limits
from agents.evaluation.crash_limits import ceilings, rule
from agents.evaluation.crash_report import train_line
from railgym.progress import quiet
from surrogates.cli_flags import Parser, add_common, error_status


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym crash-limits``."""
    parser = Parser(prog="railgym crash-limits", description=crash_limits.__doc__.split("\n\n")[0])
    parser.add_argument(
        "--range",
        type=float,
        nargs="+",
        default=[0.3, 0.5],
        dest="ranges",
        help="absorber ranges ±r of the env (absorber_range, 0 < r < 1)",
    )
    parser.add_argument("--levels", type=int, default=9, help="grid values per zone")
    parser.add_argument(
        "--scenario",
        default="envelope",
        help="crash scenario (name or YAML) with an impact envelope: its cars, zones and "
        "held-out cases (a grid of --levels values per zone: levels^zones runs per case)",
    )
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Print the markdown table of :func:`ceilings` and :func:`rule` per absorber range."""
    parser = build_parser()
    args = parser.parse_args(argv)
    for r in args.ranges:
        if not 0.0 < r < 1.0:
            parser.error(f"--range: must be in (0, 1), got {r}")
    if args.levels < 2:
        parser.error(f"--levels: must be at least 2, got {args.levels}")
    try:
        with quiet(args.quiet):
            title = train_line(args.scenario, "held-out cases of its impact envelope")
            sc = args.scenario
            rows = [
                (r, ceilings(r, args.levels, scenario=sc), rule(r, scenario=sc), rule(r, 200.0, sc))
                for r in args.ranges
            ]
    except Exception as err:
        return error_status(parser.prog, err, args.debug)
    print(title)
    print(
        "| absorber range | passive | best single setting | best per speed | best per case "
        "| speed-adaptive | speed-adaptive, 10× rate |"
    )
    print("|---|---|---|---|---|---|---|")
    for r, c, adaptive, fast in rows:
        cells = [c["one"], c["per_speed"], c["per_case"], adaptive, fast]
        text = " | ".join(f"{x:.2f} ({100 * (x / c['passive'] - 1):+.1f} %)" for x in cells)
        print(f"| ±{100 * r:.0f} % | {c['passive']:.2f} | {text} |")
    return 0
