"""Baseline and surrogate-error tables of ``railgym/TrainCrash-v0`` over an impact envelope.

``python -m agents.crash_report`` prints the markdown tables of
``docs/envs/crash_baselines.md``: the crash criteria (:mod:`railgym.vehicles.crash_criteria`)
of the passive train, the best constant setting and the speed-adaptive rule on the reference
backend at the envelope speeds, the constant-setting search, and the surrogate's error against
the reference with constant actions −1 / 0 / +1.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

import numpy as np

from agents.crash_baselines import (
    BEST_CONSTANT_ACTION,
    ConstantAbsorber,
    CrashPassive,
    SpeedAdaptive,
    _Fixed,
    rollout,
    search_constant,
)
from railgym.envs.crash import TrainCrashVectorEnv, default_surrogate
from railgym.vehicles.crash import load_scenario

#: envelope speeds of the tables, km/h
SPEEDS_KMH = (25.0, 30.0, 35.0, 40.0, 45.0, 50.0)
#: constant actions of the surrogate-error table (every zone)
ERROR_ACTIONS = (-1.0, 0.0, 1.0)


def baseline_rows(speeds_kmh: Any = SPEEDS_KMH, scenario: str = "paper") -> list[dict[str, Any]]:
    """Criteria of each baseline at each speed on the reference backend (one row each)."""
    rows = []
    for kmh in speeds_kmh:
        env = TrainCrashVectorEnv(
            num_envs=1, backend="reference", scenario=scenario, speed=kmh / 3.6
        )
        controllers = {
            "passive": CrashPassive(env),
            "best constant": ConstantAbsorber(env, BEST_CONSTANT_ACTION),
            "speed-adaptive": SpeedAdaptive(env),
        }
        for name, ctl in controllers.items():
            c = rollout(env, ctl)[0].criteria()
            rows.append({"controller": name, "speed_kmh": kmh, "criteria": c})
    return rows


def surrogate_error_rows(
    speeds_kmh: Any = SPEEDS_KMH, scenario: str = "paper", fit: str = "nominal"
) -> list[dict[str, Any]]:
    """Surrogate against reference with constant actions :data:`ERROR_ACTIONS`.

    ``fit="nominal"``: one set of elements fitted on the scenario's nominal-speed reference
    run (what an env over an envelope gets from one fit); ``"per-speed"``: elements fitted at
    each speed (what ``gym.make(..., speed=v)`` fits today).
    """
    if fit not in ("nominal", "per-speed"):
        raise ValueError(f"fit must be 'nominal' or 'per-speed', got {fit!r}")
    sc = load_scenario(scenario)
    actions = np.array([[a, a] for a in ERROR_ACTIONS])
    rows = []
    for kmh in speeds_kmh:
        sur = default_surrogate(sc) if fit == "nominal" else None
        out = {}
        for backend in ("reference", "surrogate"):
            env = TrainCrashVectorEnv(
                num_envs=len(actions),
                backend=backend,
                scenario=scenario,
                speed=kmh / 3.6,
                surrogate=sur if backend == "surrogate" else None,
            )
            out[backend] = rollout(env, _Fixed(actions))
        for a, ref, srg in zip(ERROR_ACTIONS, out["reference"], out["surrogate"], strict=True):
            rows.append({"speed_kmh": kmh, "action": a, "reference": ref, "surrogate": srg})
    return rows


def _passed(c: Any) -> str:
    """Criteria passed, e.g. ``mean ✓ intrusion ✗``."""
    mean = "✓" if c.passed["mean_decel"].all() else "✗"
    intr = "✓" if c.passed["intrusion"].all() else "✗"
    return f"mean {mean} intrusion {intr}"


def _pair(x: np.ndarray, fmt: str = "{:.2f}") -> str:
    return " / ".join(fmt.format(v) for v in x)


def baseline_table(rows: list[dict[str, Any]]) -> str:
    """Markdown table of :func:`baseline_rows`."""
    lines = [
        "| speed km/h | controller | peak g (lead / car2) | 10 ms peak g | pulse mean g "
        "| intrusion m (wall / interface) | criteria (5 g mean, no intrusion) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        c = r["criteria"]
        lines.append(
            f"| {r['speed_kmh']:.0f} | {r['controller']} | {_pair(c.peak_decel_g)} "
            f"| {_pair(c.moving_average_g)} | {_pair(c.pulse.mean_g)} "
            f"| {_pair(c.intrusion_m, '{:.3f}')} | {_passed(c)} |"
        )
    summary = [
        "",
        "| controller | mean worst-car peak g | mean worst-car 10 ms peak g "
        "| max intrusion m ≤ 45 km/h | max intrusion m > 45 km/h |",
        "|---|---|---|---|---|",
    ]
    for name in dict.fromkeys(r["controller"] for r in rows):
        mine = [r for r in rows if r["controller"] == name]
        peak = np.mean([r["criteria"].peak_decel_g.max() for r in mine])
        moving = np.mean([r["criteria"].moving_average_g.max() for r in mine])
        intr = [(r["speed_kmh"] <= 45, r["criteria"].intrusion_m.max()) for r in mine]
        low = max((x for ok, x in intr if ok), default=math.nan)
        high = max((x for ok, x in intr if not ok), default=math.nan)
        summary.append(f"| {name} | {peak:.2f} | {moving:.2f} | {low:.3f} | {high:.3f} |")
    return "\n".join(lines + summary)


def error_table(rows: list[dict[str, Any]]) -> str:
    """Markdown table of :func:`surrogate_error_rows` (relative errors in %)."""
    lines = [
        "| speed km/h | action | lead peak g ref → sur (error) | max crush m wall ref → sur "
        "(error) | max crush m interface ref → sur (error) | intrusion m ref → sur "
        "(wall / interface) |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        ref, sur = r["reference"], r["surrogate"]
        c_ref, c_sur = ref.criteria(), sur.criteria()
        pairs = [(c_ref.peak_decel_g[0], c_sur.peak_decel_g[0], "{:.2f}")]
        pairs += [(a, b, "{:.3f}") for a, b in zip(ref.crush.max(0), sur.crush.max(0), strict=True)]
        cells = [f"{f.format(a)} → {f.format(b)} ({100 * (b - a) / a:+.0f} %)" for a, b, f in pairs]
        intr = f"{_pair(c_ref.intrusion_m, '{:.3f}')} → {_pair(c_sur.intrusion_m, '{:.3f}')}"
        row = " | ".join([f"{r['speed_kmh']:.0f}", f"{r['action']:+.0f}", *cells, intr])
        lines.append(f"| {row} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Print the markdown tables of ``docs/envs/crash_baselines.md``."""
    parser = argparse.ArgumentParser(prog="python -m agents.crash_report", description=__doc__)
    parser.add_argument("--scenario", default="paper", help="crash scenario (default: paper)")
    args = parser.parse_args(argv)
    speeds = np.array(SPEEDS_KMH) / 3.6
    levels = np.linspace(-1, 1, 9)
    res = search_constant(speeds, levels=levels, backend="reference", scenario=args.scenario)
    print(f"best constant action {res.best.tolist()}, mean worst-car peak {res.score:.3f} g\n")
    print(baseline_table(baseline_rows(scenario=args.scenario)))
    for fit in ("nominal", "per-speed"):
        print(f"\nsurrogate fitted {fit}\n")
        print(error_table(surrogate_error_rows(scenario=args.scenario, fit=fit)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
