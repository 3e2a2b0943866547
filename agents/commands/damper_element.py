"""``railgym damper-element``: build the data-driven element of a controllable damper
(:func:`railgym.vehicles.semi_active_element.build_damper_element`), print its held-out error
and cost, and write it (the packaged ``railgym/data/damper_mr_secondary.json`` is rebuilt by
``railgym damper-element -o railgym/data/damper_mr_secondary.json --overwrite``)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from agents.commands.flags import check_out
from railgym.progress import quiet, stages
from railgym.vehicles.semi_active import load_damper
from railgym.vehicles.semi_active_element import (
    DURATION,
    LENGTHS,
    RUNS,
    build_damper_element,
    element_cost,
    heldout_error,
)
from surrogates.cli_flags import Parser, add_common, add_out, add_seed, error_status


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym damper-element``."""
    parser = Parser(
        prog="railgym damper-element",
        description="Build the data-driven element of a controllable damper (random command "
        "and velocity histories, GA samples, degree and memory length out of bag) and write "
        "it (docs/envs/vertical.md).",
    )
    parser.add_argument(
        "--damper", default="mr_secondary", help="the damper: packaged name or .yaml path"
    )
    add_out(parser, "element JSON to write", required=True)
    add_seed(parser, "seed of the histories and the GA")
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """``railgym damper-element``: build, report and write the element; exit status 2 on bad
    input."""
    parser = build_parser()
    args = parser.parse_args(argv)
    check_out(parser, args.out, args.overwrite)
    out = Path(args.out)
    try:
        return _build(args, out)
    except Exception as err:
        return error_status(parser.prog, err, args.debug)


def _build(args: argparse.Namespace, out: Path) -> int:
    """``railgym damper-element`` after the parse: build, report, write ``out``."""
    damper = load_damper(args.damper)
    name = Path(args.damper).stem if str(args.damper).endswith((".yaml", ".yml")) else args.damper
    if not args.quiet:
        print(
            f"collecting {RUNS} × {DURATION:g} s of the damper and fitting {len(LENGTHS)} "
            "memory lengths (GA sampling: a few minutes)",
            file=sys.stderr,
        )
    with quiet(args.quiet):
        element = build_damper_element(damper, args.seed, name=name, progress=stages())
    element.report["heldout_rel_rms"] = heldout_error(element, damper, args.seed)
    element.save(out, overwrite=args.overwrite)
    ns_el, ns_ref = element_cost(element, damper)
    rep = element.report
    for row in rep["lengths"]:
        print(
            f"l = {1e3 * row['length']:g} mm: degree {row['degree']}, "
            f"OOB rel. RMS {row['oob_nrms']:.4f}"
        )
    print(
        f"chosen l = {1e3 * element.length:g} mm, degree {rep['chosen']['degree']}; held-out "
        f"force rel. RMS {rep['heldout_rel_rms']:.4f}; training {rep['training_time_s']:.1f} s; "
        f"{ns_el:.0f} ns per step (reference damper {ns_ref:.0f} ns)"
    )
    print(f"written to {out}")
    return 0
