"""Command line: ``surrogates build data.csv --inputs du dv --output F -o model.json``."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence

import numpy as np

from surrogates import io
from surrogates.builder import build


def _progress_bar() -> Callable[[str, int, int], None]:
    """A tqdm bar per pipeline stage, as a ``build(progress=...)`` callback."""
    from tqdm import tqdm

    bars: dict[str, tqdm] = {}

    def update(stage: str, i: int, total: int) -> None:
        bar = bars.get(stage)
        if bar is None:
            bar = bars[stage] = tqdm(total=total, desc=stage, leave=False, file=sys.stderr)
        bar.update(i - bar.n)
        if i >= total:
            bar.close()

    return update


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``surrogates`` command."""
    parser = argparse.ArgumentParser(prog="surrogates", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build a surrogate element from a CSV file")
    b.add_argument("data", help="CSV file with a header row")
    b.add_argument("--inputs", nargs="+", required=True, help="input column names")
    b.add_argument("--output", required=True, help="output column name")
    b.add_argument("-o", "--model", required=True, help="where to write the model JSON")
    b.add_argument("--kind", choices=["lpr", "kriging"], default="lpr")
    b.add_argument("--m", type=int, default=101, help="number of training samples")
    b.add_argument("--sampling", choices=["ga", "greedy", "random"], default="ga")
    b.add_argument("--selection", choices=["oob", "kfold"], default="oob")
    b.add_argument("--seed", type=int, default=0)
    b.add_argument("--units", nargs="*", default=[], help="NAME=UNIT pairs, e.g. F=N")
    b.add_argument("--report", help="also write the build report as JSON here")
    b.add_argument("--quiet", action="store_true", help="no progress bar")
    e = sub.add_parser("export-fmu", help="export a saved Legendre element as an FMI 2.0 FMU")
    e.add_argument("model", help="model JSON written by 'surrogates build'")
    e.add_argument("-o", "--fmu", required=True, help="where to write the .fmu")
    e.add_argument("--kind", choices=["me", "cs", "both"], default="both")
    e.add_argument("--sources-only", action="store_true", help="do not compile a binary")
    e.add_argument("--overwrite", action="store_true", help="replace an existing FMU")
    args = parser.parse_args(argv)
    if args.command == "export-fmu":
        return _export_fmu(args)

    try:
        units = dict(u.split("=", 1) for u in args.units)
    except ValueError:
        parser.error("--units takes NAME=UNIT pairs")
    try:
        cols = io.read_csv(args.data, columns=[*args.inputs, args.output])
    except (OSError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    U = np.column_stack([cols[c] for c in args.inputs])
    V = cols[args.output]
    model, report = build(
        U,
        V,
        kind=args.kind,
        m=args.m,
        sampling=args.sampling,
        selection=args.selection,
        seed=args.seed,
        progress=None if args.quiet else _progress_bar(),
    )
    io.save(
        model,
        args.model,
        inputs=args.inputs,
        output=args.output,
        units=units,
        metadata={"source": str(args.data), "report": report.to_dict()},
    )
    print(report.format())
    print(f"model written to {args.model}")
    if args.report:
        with open(args.report, "w") as fh:
            json.dump(report.to_dict(), fh, indent=1)
    return 0


def _export_fmu(args: argparse.Namespace) -> int:
    """``surrogates export-fmu``: :func:`surrogates.fmi.export_fmu` of a saved model."""
    from surrogates.fmi import FMUExportError, export_fmu

    try:
        path = export_fmu(
            args.model,
            args.fmu,
            kind=args.kind,
            binary=not args.sources_only,
            overwrite=args.overwrite,
        )
    except (OSError, ValueError, FMUExportError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"FMU written to {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
