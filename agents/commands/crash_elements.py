"""``railgym crash-elements``: fit a scenario's crash elements
(:func:`railgym.vehicles.crash.elements.build_envelope_surrogate`) and write them."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from railgym.vehicles.crash import elements
from railgym.vehicles.crash.elements import (
    FIT_PAYLOADS_T,
    FIT_SCALES,
    FIT_SPEEDS_KMH,
    NODES_PER_CAR,
    build_envelope_surrogate,
    packaged_path,
    train_key,
)
from railgym.vehicles.crash.fe import save_crash_surrogate
from railgym.vehicles.crash.piecewise import PIECE_DEGREES
from railgym.vehicles.crash.scenario import load_scenario
from surrogates.cli_flags import Parser, add_common, add_out, add_seed, error_status


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym crash-elements``."""
    parser = Parser(prog="railgym crash-elements", description=elements.__doc__.split("\n")[0])
    parser.add_argument("--scenario", default="paper", help="packaged scenario")
    add_out(
        parser,
        "the elements JSON (default: the scenario's packaged file)",
        overwrite="replace an existing file",
        type=Path,
    )
    add_seed(
        parser,
        "seed of the fit (default: 0, the packaged files'; another needs -o/--out)",
        default=None,
    )
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Fit the envelope elements of a scenario and write its packaged file (or ``-o/--out``)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.seed is not None and args.out is None:
        parser.error("--seed needs -o/--out (the packaged elements are not replaced)")
    try:
        return _fit(parser, args)
    except Exception as err:
        return error_status(parser.prog, err, args.debug)


def _fit(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    """``railgym crash-elements`` after the parse: fit, write."""
    sc = load_scenario(args.scenario)
    out = args.out or packaged_path(sc.name)
    if out.exists() and not args.overwrite:
        parser.error(f"{out} exists; pass --overwrite to replace it")
    seed = 0 if args.seed is None else args.seed
    sur = build_envelope_surrogate(sc, seed=seed)
    meta = {
        "train_key": train_key(sc),
        "variant": sur.variant,
        "scenario": sc.name,
        "speeds_kmh": list(FIT_SPEEDS_KMH),
        "absorber_scales": [list(s) for s in FIT_SCALES],
        "payloads_t": [list(p) for p in FIT_PAYLOADS_T],
        "nodes_per_car": NODES_PER_CAR,
        "degrees": list(PIECE_DEGREES),
        "command": f"railgym crash-elements --scenario {sc.name} --overwrite"
        + (f" --seed {seed}" if seed else ""),
    }
    save_crash_surrogate(sur, out, overwrite=True, metadata=meta)
    print(f"wrote {out} (train key {meta['train_key']})")
    return 0
