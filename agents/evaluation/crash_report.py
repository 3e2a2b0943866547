"""Baseline and surrogate-error tables of ``railgym/TrainCrash-v1`` over an impact envelope.

``railgym crash-report`` (``python -m agents.evaluation.crash_report``) prints the markdown tables
of ``docs/envs/crash_baselines.md`` (``--matrix``: the surrogate-vs-reference matrix of
``docs/envs/crash.md``, :mod:`agents.evaluation.crash_matrix`): the crash criteria
(:mod:`railgym.vehicles.crash.criteria`) of the crash baselines
(:data:`agents.controllers.registry.BASELINES`: the passive train, the best constant setting,
the speed-adaptive rule) on the reference backend at the envelope speeds, the constant-setting
search, and the surrogate's error against the reference with constant actions −1 / 0 / +1.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

import numpy as np

from agents._args import error_status, one_line_warnings
from agents.controllers.crash_baselines import FixedActions, rollout, search_constant
from agents.controllers.registry import BASELINES, CRASH_ID, crash_factories
from agents.evaluation.crash_matrix import constant_action_cases, matrix_table, random_action_cases
from agents.policies.loading import load_policy
from railgym.envs.crash.env import TrainCrashVectorEnv, default_surrogate, env_surrogate
from railgym.progress import bar, quiet
from railgym.vehicles.crash.scenario import load_scenario
from surrogates.cli_flags import Parser, add_common

#: envelope speeds of the tables, km/h
SPEEDS_KMH = (25.0, 30.0, 35.0, 40.0, 45.0, 50.0)
#: constant actions of the surrogate-error table (every zone)
ERROR_ACTIONS = (-1.0, 0.0, 1.0)
#: element fits of :func:`surrogate_error_rows`
FITS = ("nominal", "per-speed", "envelope")


def baseline_rows(speeds_kmh: Any = SPEEDS_KMH, scenario: str = "paper") -> list[dict[str, Any]]:
    """Criteria of each baseline at each speed on the reference backend (one row each)."""
    rows = []
    for kmh in bar(list(speeds_kmh), desc="baselines"):
        env = TrainCrashVectorEnv(
            num_envs=1, backend="reference", scenario=scenario, speed=kmh / 3.6
        )
        for name, factory in crash_factories(BASELINES[CRASH_ID]).items():
            c = rollout(env, factory(env))[0].criteria()
            rows.append({"controller": name, "speed_kmh": kmh, "criteria": c})
    return rows


def surrogate_error_rows(
    speeds_kmh: Any = SPEEDS_KMH, scenario: str = "paper", fit: str = "nominal"
) -> list[dict[str, Any]]:
    """Surrogate against reference with constant actions :data:`ERROR_ACTIONS`.

    ``fit="nominal"``: one set of elements fitted on the scenario's nominal-speed reference
    run; ``"per-speed"``: elements fitted on a reference run at each speed; ``"envelope"``:
    the env's default, the packaged elements fitted over the envelope
    (:func:`railgym.envs.crash.env.env_surrogate`).
    """
    if fit not in FITS:
        raise ValueError(f"fit must be one of {FITS}, got {fit!r}")
    sc = load_scenario(scenario)
    actions = np.array([[a, a] for a in ERROR_ACTIONS])
    rows = []
    for kmh in bar(list(speeds_kmh), desc=f"surrogate fitted {fit}"):
        if fit == "nominal":
            sur = default_surrogate(sc)
        elif fit == "per-speed":
            sur = default_surrogate(sc.with_overrides(n_cars=2, speed=kmh / 3.6))
        else:
            sur = env_surrogate(sc)
        out = {}
        for backend in ("reference", "surrogate"):
            env = TrainCrashVectorEnv(
                num_envs=len(actions),
                backend=backend,
                scenario=scenario,
                speed=kmh / 3.6,
                surrogate=sur if backend == "surrogate" else None,
            )
            out[backend] = rollout(env, FixedActions(actions))
        for a, ref, srg in zip(ERROR_ACTIONS, out["reference"], out["surrogate"], strict=True):
            rows.append({"speed_kmh": kmh, "action": a, "reference": ref, "surrogate": srg})
    return rows


#: the line under a crash table that holds a diverged run
#: (:attr:`agents.controllers.crash_baselines.Rollout.diverged`)
DIVERGED_NOTE = (
    "the env cut the run where its state diverged (info['diverged']: a zone crushed through a "
    "car, or a state too violent to score), so its numbers are those at the cut, not a "
    "physical result; run it at a lower speed or on a scenario whose crush zones hold it"
)


def diverged_lines(runs: list[str]) -> list[str]:
    """The lines under a crash table naming its diverged ``runs`` (none: no line)."""
    if not runs:
        return []
    return ["", f"diverged: {'; '.join(runs)}: {DIVERGED_NOTE}"]


#: the held-out evaluation of issue 11: speeds (km/h) and payloads (t: lead, passenger car)
EVAL_SPEEDS_KMH = (25.0, 30.0, 35.0, 40.0, 45.0, 50.0)
EVAL_PAYLOADS_T = ((0.0, 0.0), (2.0, 8.0))


def envelope_rows(
    policies: dict[str, Any],
    env_kwargs: dict[str, Any] | None = None,
    speeds_kmh: Any = EVAL_SPEEDS_KMH,
    payloads_t: Any = EVAL_PAYLOADS_T,
) -> list[dict[str, Any]]:
    """Criteria on the **reference** of each policy (name → factory of an env → object with
    ``predict``) at each speed (km/h) × payload ((lead, passenger) t), fixed by
    ``reset(options=...)``; ``env_kwargs`` as the policy was trained with (default: the
    ``envelope`` scenario); ``diverged``: the env cut the run as diverged."""
    kwargs = {"scenario": "envelope", **(env_kwargs or {}), "backend": "reference"}
    rows = []
    cases = [(kmh, payload) for kmh in speeds_kmh for payload in payloads_t]
    for kmh, payload in bar(cases, desc="envelope cases"):
        options = {"speed_kmh": kmh, "payload_t": list(payload)}
        for name, factory in policies.items():
            env = TrainCrashVectorEnv(num_envs=1, **kwargs)
            run = rollout(env, factory(env), options=options)[0]
            rows.append(
                {
                    "controller": name,
                    "speed_kmh": kmh,
                    "payload_t": payload,
                    "criteria": run.criteria(),
                    "diverged": run.diverged,
                }
            )
    return rows


def envelope_summary(rows: list[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """Per controller: mean worst-car peak deceleration (g) over the cases, the largest
    intrusion (m) up to 45 km/h (NaN without such a case) and over all, its largest intrusion
    excess over passive in any case (m), the share of cases passing every criterion."""
    cases: dict[tuple[float, tuple[float, float]], float] = {
        (r["speed_kmh"], r["payload_t"]): r["criteria"].intrusion_m.max()
        for r in rows
        if r["controller"] == "passive"
    }
    out = {}
    for name in dict.fromkeys(r["controller"] for r in rows):
        mine = [r for r in rows if r["controller"] == name]
        intr = [(r["speed_kmh"], r["criteria"].intrusion_m.max()) for r in mine]
        excess = [
            r["criteria"].intrusion_m.max() - cases.get((r["speed_kmh"], r["payload_t"]), math.nan)
            for r in mine
        ]
        out[name] = {
            "peak_g": float(np.mean([r["criteria"].peak_decel_g.max() for r in mine])),
            "intrusion_le45_m": max((x for v, x in intr if v <= 45.0), default=math.nan),
            "intrusion_m": max(x for _, x in intr),
            "excess_over_passive_m": float(np.nanmax(excess)),
            "passed": float(np.mean([r["criteria"].all_passed for r in mine])),
        }
    return out


def envelope_table(rows: list[dict[str, Any]]) -> str:
    """Markdown tables of :func:`envelope_rows`: every case (a run the env cut as diverged
    marked in the column ``diverged`` and named in a line under the table), then
    :func:`envelope_summary` with the peak reduction against passive and against the
    speed-adaptive rule."""
    lines = [
        "| speed km/h | payload t | controller | peak g (per car) | pulse mean g "
        "| intrusion m (per zone) | all criteria | diverged |",
        "|---|---|---|---|---|---|---|---|",
    ]
    cut = []
    for r in rows:
        c = r["criteria"]
        payload = _pair(r["payload_t"], "{:g}")
        diverged = bool(r.get("diverged", False))
        if diverged:
            cut.append(f"{r['controller']} at {r['speed_kmh']:g} km/h, payload {payload} t")
        lines.append(
            f"| {r['speed_kmh']:g} | {payload} | {r['controller']} "
            f"| {_pair(c.peak_decel_g)} | {_pair(c.pulse.mean_g)} "
            f"| {_pair(c.intrusion_m, '{:.3f}')} | {'✓' if c.all_passed else '✗'} "
            f"| {'yes' if diverged else 'no'} |"
        )
    lines += diverged_lines(cut)
    summary = envelope_summary(rows)
    ref = {k: summary[k]["peak_g"] for k in ("passive", "speed-adaptive") if k in summary}
    lines += [
        "",
        "| controller | mean worst-car peak g | vs passive | vs speed-adaptive "
        "| max intrusion m ≤ 45 km/h | max intrusion m | max excess over passive m "
        "| cases passing |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, s in summary.items():
        rel = [f"{100 * (s['peak_g'] / ref[k] - 1):+.1f} %" if k in ref else "–" for k in ref]
        lines.append(
            f"| {name} | {s['peak_g']:.2f} | {' | '.join(rel)} | {s['intrusion_le45_m']:.3f} "
            f"| {s['intrusion_m']:.3f} | {s['excess_over_passive_m']:+.3f} "
            f"| {100 * s['passed']:.0f} % |"
        )
    return "\n".join(lines)


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


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym crash-report`` (``python -m agents.evaluation.crash_report``)."""
    parser = Parser(prog="railgym crash-report", description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "policy",
        nargs="*",
        metavar="POLICY_ZIP",
        help="--envelope: trained policies (SB3 .zip written by railgym train) beside the "
        "baselines",
    )
    parser.add_argument("--scenario", default="paper", help="crash scenario (name or YAML)")
    parser.add_argument(
        "--matrix",
        action="store_true",
        help="only the surrogate-vs-reference matrix of the env's default elements over speeds "
        "x payloads x constant actions and random action sequences (docs/envs/crash.md)",
    )
    parser.add_argument(
        "--envelope",
        action="store_true",
        help="only the held-out envelope evaluation on the reference (speeds × payloads) of "
        "the baselines and the POLICY_ZIP files",
    )
    parser.add_argument("--trust", action="store_true", help="as for railgym evaluate")
    add_common(parser)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Print the markdown tables of ``docs/envs/crash_baselines.md``."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.policy and not args.envelope:
        parser.error("POLICY_ZIP: only with --envelope")
    try:
        with quiet(args.quiet), one_line_warnings(parser.prog):
            return _report(args)
    except Exception as err:
        return error_status(parser.prog, err, args.debug)


def _report(args: argparse.Namespace) -> int:
    """The tables ``args`` ask for, printed."""
    if args.envelope:
        policies = crash_factories(BASELINES[CRASH_ID])
        env_kwargs: dict[str, Any] = {}
        for path in args.policy:
            factory, env_kwargs, label = load_policy(path, CRASH_ID, args.trust)
            policies[label] = factory
        print(envelope_table(envelope_rows(policies, env_kwargs)))
        return 0
    if args.matrix:
        print(matrix_table(constant_action_cases(), random_action_cases()))
        return 0
    speeds = np.array(SPEEDS_KMH) / 3.6
    levels = np.linspace(-1, 1, 9)
    res = search_constant(speeds, levels=levels, backend="reference", scenario=args.scenario)
    print(f"best constant action {res.best.tolist()}, mean worst-car peak {res.score:.3f} g\n")
    print(baseline_table(baseline_rows(scenario=args.scenario)))
    for fit in FITS:
        print(f"\nsurrogate fitted {fit}\n")
        print(error_table(surrogate_error_rows(scenario=args.scenario, fit=fit)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
