"""Run every benchmark: ``python -m benchmarks [NAME ...]`` (names: the bench_* modules)."""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
import time

import benchmarks


def _modules() -> list[str]:
    return sorted(
        m.name[len("bench_") :]
        for m in pkgutil.iter_modules(benchmarks.__path__)
        if m.name.startswith("bench_")
    )


def main() -> int:
    """Print one table row per measurement: name, value, unit, target, context."""
    names = _modules()
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__)
    parser.add_argument("only", nargs="*", help=f"subset of: {', '.join(names)}")
    args = parser.parse_args()
    chosen = args.only or names
    unknown = sorted(set(chosen) - set(names))
    if unknown:
        parser.error(f"unknown benchmark(s) {unknown}; choose from {names}")
    print(f"{'benchmark':<46} {'value':>12} {'unit':<10} {'target':<18} context")
    for name in chosen:
        t0 = time.perf_counter()
        rows = importlib.import_module(f"benchmarks.bench_{name}").run()
        for r in rows:
            print(
                f"{r['name']:<46} {r['value']:>12.4g} {r['unit']:<10} "
                f"{r.get('target', ''):<18} {r.get('context', '')}"
            )
        print(f"  [{name}: {time.perf_counter() - t0:.1f} s]", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
