"""Run every benchmark: ``python -m benchmarks [NAME ...]`` (names: the bench_* modules).

Each timed figure is the median of ``--repeats`` windows of at least ``--window`` seconds;
``IQR`` is the interquartile range of those samples relative to the median, and ``verdict``
says whether a figure with a numeric target meets it, misses it, or is ``unresolved`` (its
spread exceeds the margin by which it meets or misses; :mod:`benchmarks._timing`).
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
import time

import benchmarks
from benchmarks import _timing


def _modules() -> list[str]:
    return sorted(
        m.name[len("bench_") :]
        for m in pkgutil.iter_modules(benchmarks.__path__)
        if m.name.startswith("bench_")
    )


def format_row(r: dict) -> str:
    """One printed line of a row: name, value, unit, spread, target, verdict, context."""
    spread = r.get("spread")
    iqr = "—" if spread is None else f"{100 * spread:.1f} %"
    target = r.get("target", "") or ""
    verdict = _timing.verdict(r["value"], spread, target)
    return (
        f"{r['name']:<46} {r['value']:>12.4g} {r['unit']:<10} {iqr:>8} "
        f"{target:<18} {verdict:<10} {r.get('context', '')}"
    )


def main() -> int:
    """Print one table row per measurement (see the module docstring)."""
    names = _modules()
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks",
        description=__doc__.split("\n\n")[0],
        epilog=__doc__.split("\n\n")[1],
    )
    parser.add_argument("only", nargs="*", help=f"subset of: {', '.join(names)}")
    parser.add_argument(
        "--repeats",
        type=int,
        default=_timing.REPEATS,
        help=f"timed windows per figure (default {_timing.REPEATS}; a spread and a verdict "
        f"need at least {_timing.MIN_SAMPLES})",
    )
    parser.add_argument(
        "--window",
        type=float,
        default=_timing.WINDOW_S,
        help=f"minimum length of a timed window, s (default {_timing.WINDOW_S})",
    )
    args = parser.parse_args()
    chosen = args.only or names
    unknown = sorted(set(chosen) - set(names))
    if unknown:
        parser.error(f"unknown benchmark(s) {unknown}; choose from {names}")
    if args.repeats < 1:
        parser.error(f"--repeats must be at least 1, got {args.repeats}")
    if not args.window > 0:
        parser.error(f"--window must be positive, got {args.window}")
    _timing.REPEATS, _timing.WINDOW_S = args.repeats, args.window
    print(
        f"{'benchmark':<46} {'value':>12} {'unit':<10} {'IQR':>8} {'target':<18} "
        f"{'verdict':<10} context"
    )
    print(
        f"  [median of {args.repeats} windows of ≥ {args.window:g} s per timed figure; "
        "IQR relative to the median]",
        file=sys.stderr,
    )
    for name in chosen:
        t0 = time.perf_counter()
        rows = importlib.import_module(f"benchmarks.bench_{name}").run()
        for r in rows:
            print(format_row(r))
        print(f"  [{name}: {time.perf_counter() - t0:.1f} s]", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
