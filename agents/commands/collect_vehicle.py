"""``railgym collect-vehicle``: build the whole-vehicle element
(:func:`railgym.vehicles.vehicle.collect.build_vehicle_surrogate`) and write it."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from agents.commands.flags import check_out
from railgym.vehicles.collect import save_vertical_surrogate
from railgym.vehicles.element_envelope import design_envelope
from railgym.vehicles.vehicle import collect as vehicle_collect
from railgym.vehicles.vehicle.collect import VEHICLE_DESIGN, build_vehicle_surrogate
from surrogates.cli_flags import Parser, add_common, add_out, add_seed, error_status


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym collect-vehicle``."""
    fmu = "the element of a whole-vehicle FMU is built by `railgym collect --fmu-map MAP.yaml`"
    parser = Parser(
        prog="railgym collect-vehicle",
        description=vehicle_collect.__doc__.split("\n\n")[0],
        elsewhere={"--fmu-map": f"{fmu} (a mapping with env: vehicle)"},
    )
    add_out(parser, "model JSON to write", required=True)
    add_seed(parser, "seed of the folds")
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Build the whole-vehicle element of :data:`VEHICLE_DESIGN` and write it to ``-o/--out``."""
    parser = build_parser()
    args = parser.parse_args(argv)
    check_out(parser, args.out, args.overwrite)
    out = Path(args.out)
    try:
        return _collect(out, args.seed, args.quiet)
    except Exception as err:
        return error_status(parser.prog, err, args.debug)


def _collect(out: Path, seed: int, quiet: bool) -> int:
    """``railgym collect-vehicle`` after the parse: collect, fit, write ``out``."""
    if not quiet:
        print(
            "collecting the whole-vehicle design, fitting the relaxation law and the degrees "
            "(a few minutes)",
            file=sys.stderr,
        )
    model, sel, _ = build_vehicle_surrogate(seed=seed)
    d = VEHICLE_DESIGN
    source = (
        "railgym whole-vehicle dynamic reference (manchester_whole), FRA classes "
        f"{list(d.track_classes)} at {[round(v * 3.6) for v in d.speeds]} km/h, "
        f"{d.duration:g} s each, passive and both actuators excited ({d.f_max:g} N peak, "
        f"{d.band:g} Hz), both bogies, {d.sample_rate:g} Hz; additive LPR on F_s - F_bump "
        "with the Maxwell state of a fitted two-slope relaxation law"
    )
    # the design's classes and speeds, at most each class's maximum speed (where it was
    # validated: docs/validation.md, *Validity flags*)
    envelope = design_envelope(d)._replace(speed_factor=(0.0, 1.0))
    command = f"railgym collect-vehicle -o {out.name}" + (f" --seed {seed}" if seed else "")
    save_vertical_surrogate(model, sel, out, source, command, envelope=envelope)
    print(sel.format())
    print(f"written to {out}")
    return 0
