"""Baseline and surrogate-error tables of ``railgym/TrainCrash-v1`` over an impact envelope.

``railgym crash-report`` prints the markdown tables
of ``docs/envs/crash_baselines.md`` (``--matrix``: the surrogate-vs-reference matrix of
``docs/envs/crash.md``, :mod:`agents.evaluation.crash_matrix`): the crash criteria
(:mod:`railgym.vehicles.crash.criteria`) of the crash baselines
(:data:`agents.controllers.registry.BASELINES`: the passive train, the best constant setting,
the speed-adaptive rule) on the reference backend at the envelope speeds, the constant-setting
search, and the surrogate's error against the reference with constant actions −1 / 0 / +1.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agents.controllers.crash_baselines import FixedActions, rollout
from agents.controllers.registry import BASELINES, CRASH_ID, crash_factories
from railgym.envs.crash.env import TrainCrashVectorEnv, default_surrogate, env_surrogate
from railgym.progress import bar
from railgym.vehicles.crash.scenario import CrashScenario, load_scenario

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
    actions = np.repeat(np.array(ERROR_ACTIONS)[:, None], sc.n_cars, axis=1)  # every zone
    rows = []
    for kmh in bar(list(speeds_kmh), desc=f"surrogate fitted {fit}"):
        if fit == "nominal":
            sur = default_surrogate(sc)
        elif fit == "per-speed":
            sur = default_surrogate(sc.with_overrides(speed=kmh / 3.6))
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


#: the held-out evaluation of issue 11 (the cases :func:`envelope_cases` draws from the
#: ``envelope`` scenario): speeds (km/h) and payloads (t: lead, passenger car)
EVAL_SPEEDS_KMH = (25.0, 30.0, 35.0, 40.0, 45.0, 50.0)
EVAL_PAYLOADS_T = ((0.0, 0.0), (2.0, 8.0))
#: held-out speeds per impact envelope
EVAL_N_SPEEDS = len(EVAL_SPEEDS_KMH)


def envelope_cases(scenario: Any) -> tuple[list[float], list[tuple[float, float]]]:
    """The held-out cases of a scenario's impact envelope (``crash.envelope``):
    :data:`EVAL_N_SPEEDS` speeds (km/h) evenly over its speed range and its lightest and
    heaviest payloads ((lead, passenger car) t); the ``envelope`` scenario gives
    :data:`EVAL_SPEEDS_KMH` × :data:`EVAL_PAYLOADS_T`. ``ValueError`` for a scenario without
    an envelope."""
    sc = scenario if isinstance(scenario, CrashScenario) else load_scenario(scenario)
    env = sc.envelope
    if env is None:
        raise ValueError(
            f"scenario {sc.name!r} has no impact envelope (its crash.envelope field: speed_kmh "
            "[low, high], payload_t), which the held-out evaluation (--envelope, --gap, "
            "crash-report --envelope, crash-limits) runs over"
        )
    lo, hi = (3.6 * v for v in env.speed)
    speeds = [round(float(v), 6) for v in np.linspace(lo, hi, EVAL_N_SPEEDS if hi > lo else 1)]
    payloads = [(env.payload_lead[end] / 1e3, env.payload_passenger[end] / 1e3) for end in (0, 1)]
    return speeds, list(dict.fromkeys(payloads))


def envelope_rows(
    policies: dict[str, Any],
    env_kwargs: dict[str, Any] | None = None,
    speeds_kmh: Any = None,
    payloads_t: Any = None,
) -> list[dict[str, Any]]:
    """Criteria on the **reference** of each policy (name → factory of an env → object with
    ``predict``) at each speed (km/h) × payload ((lead, passenger car) t), fixed by
    ``reset(options=...)``; ``env_kwargs`` as the policy was trained with (default: the
    ``envelope`` scenario); speeds and payloads ``None``: the scenario's
    :func:`envelope_cases`; ``diverged``: the env cut the run as diverged."""
    kwargs = {"scenario": "envelope", **(env_kwargs or {}), "backend": "reference"}
    if speeds_kmh is None or payloads_t is None:
        speeds, payloads = envelope_cases(kwargs["scenario"])
        speeds_kmh = speeds if speeds_kmh is None else speeds_kmh
        payloads_t = payloads if payloads_t is None else payloads_t
    rows = []
    cases = [(kmh, payload) for kmh in speeds_kmh for payload in payloads_t]
    for kmh, payload in bar(cases, desc="envelope cases"):
        lead, passenger = payload
        options = {"speed_kmh": kmh, "payload_t": {"lead": lead, "passenger": passenger}}
        for name, factory in policies.items():
            env = TrainCrashVectorEnv(num_envs=1, **kwargs)
            run = rollout(env, factory(env), options=options)[0]
            rows.append(
                {
                    "scenario": env.cfg.scenario,
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


def _zone_names(n_zones: int) -> list[str]:
    """``wall, interface_1, …`` of a train of ``n_zones`` zones."""
    return ["wall"] + [f"interface_{k}" for k in range(1, n_zones)]


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
        "| speed km/h | controller | peak g (per car) | 10 ms peak g | pulse mean g "
        "| intrusion m (per zone) | criteria (5 g mean, no intrusion) |",
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
    """Markdown table of :func:`surrogate_error_rows` (relative errors in %): one crush column
    per zone (wall, then each interface)."""
    n_zones = rows[0]["reference"].crush.shape[1] if rows else 2
    zones = ["wall", "interface"] if n_zones == 2 else _zone_names(n_zones)
    crush = "".join(f" max crush m {z} ref → sur (error) |" for z in zones)
    lines = [
        f"| speed km/h | action | lead peak g ref → sur (error) |{crush} intrusion m ref → sur "
        f"({' / '.join(zones)}) |",
        "|---|---|---|" + "---|" * (n_zones + 1),
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


def train_text(sc: CrashScenario) -> str:
    """``scenario NAME (N cars, m1 / m2 / … t, speed_kmh V)``: the train a crash table ran."""
    masses = " / ".join(f"{m / 1e3:g}" for m in sc.car_masses)
    return f"scenario {sc.name} ({sc.n_cars} cars, {masses} t, speed_kmh {3.6 * sc.speed:g})"


def trains_of(rows: list[dict[str, Any]]) -> str:
    """:func:`train_text` of each train of ``rows`` (their ``scenario``), ``; ``-joined."""
    return "; ".join(dict.fromkeys(train_text(r["scenario"]) for r in rows))


def train_line(scenario: Any, cases: str) -> str:
    """The line over a crash table of ``scenario`` (a name, path or scenario) and ``cases``."""
    sc = scenario if isinstance(scenario, CrashScenario) else load_scenario(scenario)
    return f"TrainCrash-v1, {train_text(sc)}: {cases}"


def envelope_header(rows: list[dict[str, Any]], speed_flag: bool = False) -> str:
    """The line over :func:`envelope_table`: the train(s) and, where ``--speed-kmh`` was given
    (``speed_flag``), that its speeds override the envelope's."""
    speeds = ", speeds from --speed-kmh (override the envelope's)" if speed_flag else ""
    names = {r["scenario"].name for r in rows}
    best = (
        ""
        if names <= {"envelope", "paper"}
        else "; best-constant: the paper train's setting (wall 0, interfaces −1), not one "
        "searched for this train"
    )
    return (
        f"TrainCrash-v1, {trains_of(rows)}: held-out cases of its impact envelope on the "
        f"reference backend{speeds}{best}"
    )
