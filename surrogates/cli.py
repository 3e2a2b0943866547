"""Command line: ``surrogates build data.csv --inputs du dv --target F -o model.json`` and
``surrogates export-fmu model.json -o element.fmu`` (also ``railgym surrogates ...``)."""

from __future__ import annotations

import argparse
import itertools
import json
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from surrogates import io
from surrogates.builder import build
from surrogates.checks import MAX_SEED
from surrogates.cli_flags import Parser, add_common, add_out
from surrogates.models.checks import MAX_DEGREE
from surrogates.tables import to_si
from surrogates.units import KNOWN_UNITS, check_units


def _progress_bar() -> Callable[[str, int, int], None]:
    """A tqdm bar per pipeline stage on stderr, as a ``build(progress=...)`` callback; off
    when stderr is not a terminal."""
    from tqdm import tqdm

    bars: dict[str, tqdm] = {}

    def update(stage: str, i: int, total: int) -> None:
        bar = bars.get(stage)
        if bar is None:
            bar = bars[stage] = tqdm(
                total=total, desc=stage, leave=False, file=sys.stderr, disable=None
            )
        bar.update(i - bar.n)
        if i >= total:
            bar.close()

    return update


class UsageError(ValueError):
    """A bad command-line argument or path (exit code 2, one line on stderr)."""


def check_output(path: str, flag: str, overwrite: bool) -> None:
    """Fail before the build when ``path`` cannot be written or would be overwritten."""
    p = Path(path)
    if p.is_dir():
        raise UsageError(f"{flag} {path}: is a folder, expected a file name")
    if not p.parent.is_dir():
        raise UsageError(f"{flag} {path}: folder {str(p.parent)!r} does not exist")
    if not os.access(p.parent, os.W_OK):
        raise UsageError(f"{flag} {path}: folder {str(p.parent)!r} is not writable")
    if p.exists() and not overwrite:
        raise UsageError(f"{flag} {path}: exists; pass --overwrite to replace it")


BUILD_DESCRIPTION = (
    "Build a surrogate element from the columns of a CSV file. stdout: the summary, the "
    "candidate table of the degree (or kernel) selection and where the model went; stderr: "
    "progress bars (on a terminal), the number of training rows and notes. --quiet prints "
    "the summary alone (with a warning of a winner at the search cap). Units: give one for "
    "every input and the output (--units, or 'name [unit]' in the header), or none; the "
    "data are converted to SI (du [mm] to m, F [kN] to N, as read_table converts, a note on "
    "stderr) and the element carries the SI units; railgym's vertical envs take an element "
    "with inputs in m and m/s and output in N, e.g. --units du=m dv=m/s F=N."
)


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``surrogates`` (also ``railgym surrogates``)."""
    parser = Parser(prog="surrogates", description=__doc__)
    parser.add_argument("--debug", action="store_true", help="show tracebacks of errors")
    sub = parser.add_subparsers(dest="command", required=True)
    _add_build(
        sub.add_parser(
            "build", help="build a surrogate element from a CSV file", description=BUILD_DESCRIPTION
        )
    )
    _add_export(
        sub.add_parser(
            "export-fmu",
            help="export a saved Legendre element as an FMI 2.0 FMU",
            description="Export a saved Legendre element (model JSON) as a standalone FMI 2.0 "
            "FMU: model exchange, co-simulation or both, with a binary for this platform or "
            "sources only.",
        )
    )
    return parser


def _add_build(b: argparse.ArgumentParser) -> None:
    """Arguments of ``surrogates build``."""
    b.add_argument("data", help="CSV file with a header row ('du' or 'du [m]' per column)")
    b.add_argument("--inputs", nargs="+", required=True, help="input column names")
    b.add_argument("--target", required=True, help="output (target) column name")
    add_out(
        b,
        "where to write the model JSON",
        required=True,
        overwrite="replace existing output files",
        type=str,
    )
    b.add_argument(
        "--kind", choices=["lpr", "kriging"], default="lpr", help="Legendre regression or Kriging"
    )
    b.add_argument(
        "--m", type=int, default=101, help="number of training rows; the other rows are out-of-bag"
    )
    b.add_argument(
        "--sampling",
        choices=["ga", "greedy", "random"],
        default="ga",
        help="how the training rows are picked",
    )
    b.add_argument(
        "--selection",
        choices=["oob", "kfold"],
        default="oob",
        help="how the degree or kernel is chosen",
    )
    b.add_argument(  # checked in the build: a bad seed is one line and status 2 as any other
        "--seed", type=int, default=0, help=f"seed of the sampling, 0..{MAX_SEED}"
    )
    b.add_argument(
        "--units",
        nargs="*",
        default=[],
        metavar="NAME=UNIT",
        help="the unit of every input and the output in the data, e.g. du=mm dv=mm/s F=kN, "
        "or none (also read from a header 'du [mm]'); converted to SI; known units: "
        + ", ".join(sorted(KNOWN_UNITS)),
    )
    b.add_argument("--report", help="also write the build report as JSON here")
    add_degree_arguments(b)
    add_common(
        b,
        debug_default=argparse.SUPPRESS,
        quiet_help="print the summary alone: no candidate table, progress bars or notes",
    )


def _add_export(e: argparse.ArgumentParser) -> None:
    """Arguments of ``surrogates export-fmu``."""
    e.add_argument("model", help="model JSON written by 'surrogates build'")
    add_out(
        e,
        "where to write the .fmu",
        required=True,
        overwrite="replace an existing FMU",
        type=str,
    )
    e.add_argument(
        "--fmu-kind",
        choices=["me", "cs", "both"],
        default="both",
        help="FMI interfaces: model exchange, co-simulation or both",
    )
    e.add_argument("--sources-only", action="store_true", help="do not compile a binary")
    add_common(e, debug_default=argparse.SUPPRESS)


def add_degree_arguments(parser: argparse.ArgumentParser, note: str = "") -> None:
    """``--degree`` / ``--max-degree`` (LPR), mutually exclusive, one value or one per input."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--degree",
        type=int,
        nargs="+",
        metavar="D",
        help="LPR: fit this degree, no search (one value for every input, or one per input)",
    )
    group.add_argument(
        "--max-degree",
        type=int,
        nargs="+",
        metavar="N",
        help="LPR: search degrees up to N (one value for every input, or one per input)"
        + (note or "; default 16 per input for one or two inputs, 10 for more"),
    )


class _TauAction(argparse.Action):
    """``--tau``: the values checked by :func:`surrogates.tau_search.tau_search` when parsed
    (a bad one exits 2 naming ``--tau``); stored as a ``TauSearch``."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        from surrogates.tau_search import tau_search

        try:
            setattr(namespace, self.dest, tau_search(list(values), "--tau"))
        except ValueError as err:
            parser.error(str(err))


def _memory_states(text: str) -> int:
    """``--memory-states``: checked by :func:`surrogates.tau_search.memory_states`."""
    from surrogates.tau_search import memory_states

    try:
        number = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be 0 or 1, got {text!r}") from None
    try:
        return memory_states(number, "--memory-states")  # type: ignore[return-value]
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err).removeprefix("--memory-states ")) from None


def add_memory_arguments(parser: argparse.ArgumentParser) -> None:
    """``--tau`` (one value, a range ``LO HI`` or three or more values, s),
    ``--memory-states N`` and ``--coupled`` of a memory element; each checked when parsed."""
    from surrogates.tau_search import DEFAULT_TAU_RANGE

    lo, hi = DEFAULT_TAU_RANGE
    parser.add_argument(
        "--tau",
        nargs="+",
        type=float,
        action=_TauAction,
        metavar="S",
        help="Maxwell time constant(s) searched, s: one value (that tau), two (a range LO HI, "
        "searched continuously from the linear fit's guess by k-fold CV) or three or more "
        f"(those values); default: the range {lo:g} {hi:g}",
    )
    parser.add_argument(
        "--memory-states",
        type=_memory_states,
        metavar="N",
        help="memory states of the element: 0 (memoryless) or 1 (one Maxwell state); "
        "default: from the data (1 when it lowers the k-fold error)",
    )
    parser.add_argument(
        "--coupled",
        action="store_true",
        help="also score the coupled map (LPR with interactions, unconstrained, its own tau "
        "search) and take it when it lowers the k-fold error by 5 %%; check it with railgym "
        "validate (it can diverge where the passive additive map does not)",
    )


def check_degrees(values: list[int] | None, flag: str, n_inputs: int) -> tuple[int, ...] | None:
    """The ``--degree``/``--max-degree`` values as one degree per input (or ``None``)."""
    if values is None:
        return None
    if len(values) not in (1, n_inputs):
        raise UsageError(f"{flag} takes 1 or {n_inputs} values (one per input), got {len(values)}")
    if any(v < 1 or v > MAX_DEGREE for v in values):
        raise UsageError(f"{flag} values must be in 1..{MAX_DEGREE}, got {values}")
    return tuple(values) * (n_inputs if len(values) == 1 else 1)


def _candidates(args: argparse.Namespace, n_inputs: int) -> list[Any] | None:
    """The LPR candidates of ``--degree`` / ``--max-degree`` (``None``: the default search)."""
    if (args.degree or args.max_degree) and args.kind != "lpr":
        raise UsageError("--degree and --max-degree apply to --kind lpr only")
    return degree_candidates(args.degree, args.max_degree, n_inputs)


def degree_candidates(
    degree: list[int] | None, max_degree: list[int] | None, n_inputs: int
) -> list[Any] | None:
    """The LPR candidates of the ``--degree`` / ``--max-degree`` values (``None``: the
    default search); :class:`UsageError` for bad values."""
    fixed = check_degrees(degree, "--degree", n_inputs)
    if fixed is not None:
        return [fixed]
    top = check_degrees(max_degree, "--max-degree", n_inputs)
    if top is None:
        return None
    if n_inputs > 2 and len(set(top)) == 1:  # equal degrees, as the default for d > 2
        return list(range(1, top[0] + 1))
    return list(itertools.product(*(range(1, t + 1) for t in top)))


def unit_pairs(pairs: Sequence[str]) -> dict[str, str]:
    """The ``--units NAME=UNIT`` values as ``{name: unit}``; :class:`UsageError` for a
    malformed pair or a name given twice."""
    units: dict[str, str] = {}
    for pair in pairs:
        name, sep, unit = pair.partition("=")
        if not sep or not name or not unit:
            raise UsageError(f"--units {pair!r}: expected NAME=UNIT, e.g. F=N")
        if name in units:
            raise UsageError(f"--units gives a unit for {name!r} twice")
        units[name] = unit
    return units


def _build(args: argparse.Namespace) -> int:
    """The ``build`` command; :class:`UsageError`, ``ValueError`` or ``OSError`` for bad input."""
    units = unit_pairs(args.units)
    names = [*args.inputs, args.target]
    dups = sorted({c for c in names if names.count(c) > 1})
    if dups:
        raise UsageError(f"--inputs/--target name the column(s) {dups} more than once")
    if args.m < 1:
        raise UsageError(f"--m must be >= 1, got {args.m}")
    if not 0 <= args.seed <= MAX_SEED:  # the bound of every command's --seed
        raise UsageError(f"--seed must be an integer in 0..{MAX_SEED}, got {args.seed}")
    candidates = _candidates(args, len(args.inputs))
    check_output(args.out, "-o", args.overwrite)
    if args.report:
        if Path(args.report).resolve() == Path(args.out).resolve():
            raise UsageError("--report and -o name the same file")
        check_output(args.report, "--report", args.overwrite)
    cols, header_units = io.read_csv_units(args.data, columns=names)
    given = _units(args, units, header_units)
    cols, units, factors = to_si(cols, given, str(args.data))
    if factors and not args.quiet:
        print(
            "converted to SI: "
            + ", ".join(f"{c} {given[c]} -> {units[c]} (x {f:g})" for c, f in factors.items()),
            file=sys.stderr,
        )
    U = np.column_stack([cols[c] for c in args.inputs])
    n = U.shape[0]
    if not args.quiet:
        if args.m < n:
            print(
                f"training on {args.m} of {n} rows ({100 * args.m / n:.3g} %); the rest are "
                "out-of-bag (--m sets the number)",
                file=sys.stderr,
            )
        if not units:
            print(
                "note: no units given (--units); railgym's envs refuse an element without "
                "them, e.g. --units " + " ".join(f"{c}=UNIT" for c in names),
                file=sys.stderr,
            )
    model, report = build(
        U,
        cols[args.target],
        kind=args.kind,
        m=args.m,
        sampling=args.sampling,
        selection=args.selection,
        seed=args.seed,
        progress=None if args.quiet else _progress_bar(),
        candidates=candidates,
        inputs=args.inputs,
        output=args.target,
        units=units,
    )
    if args.report:
        io.write_atomic(args.report, json.dumps(report.to_dict(), indent=1) + "\n")
    io.save(model, args.out, metadata={"source": str(args.data), "report": report.to_dict()})
    print(report.format(units.get(args.target), table=not args.quiet))
    print(f"model written to {args.out}")
    return 0


def _units(
    args: argparse.Namespace, given: dict[str, str], header: dict[str, str]
) -> dict[str, str]:
    """The element's units from ``--units`` and the CSV header (``du [m]``): known units,
    for every input and the output or none; a header unit that ``--units`` contradicts is
    an error."""
    for name, unit in header.items():
        if unit not in KNOWN_UNITS:
            raise UsageError(
                f"{args.data}: line 1: unit {unit!r} of column {name!r} is not a known unit; "
                f"known units: {sorted(KNOWN_UNITS)}"
            )
        if given.get(name, unit) != unit:
            raise UsageError(
                f"--units {name}={given[name]} contradicts the header of {args.data} "
                f"({name} [{unit}])"
            )
    flag = "--units" if not header else "--units and the CSV header"
    try:
        return check_units({**header, **given}, args.inputs, args.target, flag, cli=True)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def _export_fmu(args: argparse.Namespace) -> int:
    """``surrogates export-fmu``: :func:`surrogates.fmi.export_fmu` of a saved model."""
    from surrogates.fmi import FMUExportError, export_fmu

    try:
        check_output(args.out, "-o", args.overwrite)
        path = export_fmu(
            args.model,
            args.out,
            kind=args.fmu_kind,
            binary=not args.sources_only,
            overwrite=args.overwrite,
        )
    except (OSError, ValueError, FMUExportError) as exc:
        if args.debug:
            raise
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"FMU written to {path}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``surrogates`` command.

    Exit code 0 on success and 2 for a user error (bad argument, path, CSV file or data),
    reported as one line on stderr; ``--debug`` shows the traceback instead.
    """
    args = build_parser().parse_args(argv)
    if args.command == "export-fmu":
        return _export_fmu(args)
    try:
        return _build(args)
    except (ValueError, OSError) as exc:
        if args.debug:
            raise
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
