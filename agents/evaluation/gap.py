"""``railgym evaluate POLICY... --gap``: the transfer gap of policies between surrogate and
reference.

Each policy (a controller name or a saved policy, as :func:`agents.policies.loading.load_policy`
takes) runs on the ``surrogate`` backend and on the reference backend over the same held-out
cases, and every task metric is reported on both with its relative gap
``(surrogate − reference) / |reference|``:

* ``vertical`` (``VerticalSuspension``, default its newest version): per track class, the
  ISO 2631 Wk-weighted RMS carbody acceleration ``a_w`` (m/s², mean over the episodes on the
  tracks of seeds ``seed + i``; :func:`agents.evaluation.sweeps.evaluate_sweep`);
* ``vehicle`` (``VerticalVehicle``, default its newest version): per track class and speed,
  ``a_w`` at the front, centre and rear floor points
  (:func:`agents.evaluation.runs.evaluate_vehicle`);
* beside ``a_w`` (vertical, vehicle) the bump-stop contacts (substeps) on both sides, and a
  line under the table for each policy whose ``a_w`` beats a classical controller's of its
  case on the reference side with more contacts there (:mod:`agents.evaluation.contacts`);
* ``crash`` (``TrainCrash-v1``): per impact speed × payload of the held-out envelope of the
  scenario (:func:`agents.evaluation.crash_report.envelope_cases`), each car's peak and 10 ms
  moving-average peak deceleration (g), each zone's maximum crush and survival-space intrusion (m)
  (:mod:`railgym.vehicles.crash.criteria`); a run the env cut as diverged (``info["diverged"]``) is
  marked in the column ``diverged`` (the backends cut) and named in a line under the table.

A policy trusted on the surrogate is one whose gaps are small: the surrogate does not flatter
it. Both sides run the same policy object on the same seeds, so the gap of a backend against
itself is exactly zero.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from agents.commands.flags import (
    VEHICLE_DURATION_S,
    backend_kwargs,
    with_policy_kwargs,
)
from agents.controllers.crash_baselines import rollout
from agents.controllers.registry import (
    CONTROLLERS,
    CRASH_ID,
    ENV_ID,
    VEHICLE_CONTROLLERS,
    VEHICLE_ID,
    crash_factories,
)
from agents.evaluation import crash_report
from agents.evaluation.contacts import Score, contact_note, more_contacts
from agents.evaluation.metrics import CRASH, VEHICLE, VERTICAL, metrics
from agents.evaluation.runs import evaluate_vehicle
from agents.evaluation.sweeps import evaluate_sweep
from agents.policies.loading import load_policy
from railgym import _checks as val
from railgym.envs.crash.env import TrainCrashVectorEnv

__all__ = ["format_gap", "gap_crash", "gap_vehicle", "gap_vertical", "relative_gap"]

#: the side whose numbers are checked against the reference
SURROGATE = "surrogate"
FLOOR_POINTS = ("front", "centre", "rear")
#: the crash metrics (:data:`agents.evaluation.metrics.CRASH`) per car and per zone
CAR_METRICS = ("peak_decel_g", "moving_average_g")
ZONE_METRICS = ("max_crush_m", "intrusion_m")


def relative_gap(surrogate: float, reference: float) -> float:
    """``(surrogate − reference) / |reference|``; 0 where both are equal (also both 0), ±inf
    where only the reference is 0."""
    if surrogate == reference:
        return 0.0
    if reference == 0.0:
        return math.copysign(math.inf, surrogate - reference)
    return (surrogate - reference) / abs(reference)


def _row(case: str, policy: str, metric: str, s: float, r: float) -> dict[str, Any]:
    return {
        "case": case,
        "policy": policy,
        "metric": metric,
        "surrogate": float(s),
        "reference": float(r),
        "gap": relative_gap(float(s), float(r)),
    }


def _contacts(s: dict[str, Any], r: dict[str, Any]) -> dict[str, float]:
    """The bump-stop contacts (substeps) of the evaluation rows ``s`` and ``r`` of both sides."""
    return {"contacts_surrogate": float(s["contacts"]), "contacts_reference": float(r["contacts"])}


def gap_vertical(
    policies: Sequence[str],
    track_classes: Sequence[int] = (4, 5, 6),
    episodes: int = 10,
    seed: int = 1000,
    trust: bool = False,
    workers: int = 1,
    address: str | None = None,
    backends: tuple[str, str] = (SURROGATE, "reference"),
    env_kwargs: dict[str, Any] | None = None,
    env_id: str = ENV_ID,
) -> list[dict[str, Any]]:
    """Gap rows of ``env_id`` (a version of ``railgym/VerticalSuspension``): one per (track
    class, policy), metric ``a_w``, with the bump-stop contacts of both sides
    (``contacts_surrogate``, ``contacts_reference``).

    ``backends``: the (surrogate, reference) pair compared; ``env_kwargs`` go to both
    (``fmu``, ``fmu_map`` to the ``"fmu"`` backend only); the other arguments as
    :func:`agents.evaluation.sweeps.evaluate_sweep`.
    """
    runs = [
        evaluate_sweep(
            policies,
            b,
            track_classes,
            episodes,
            seed,
            trust,
            workers,
            address,
            backend_kwargs(b, env_kwargs),
            env_id,
        )
        for b in backends
    ]
    (a_w,) = metrics(VERTICAL, "a_w")
    return [
        {
            **_row(f"class {s['track_class']}", s["policy"], a_w.label(), s["a_w"], r["a_w"]),
            **_contacts(s, r),
        }
        for s, r in zip(*runs, strict=True)
    ]


def gap_vehicle(
    policies: Sequence[str],
    track_classes: Sequence[int] = (5,),
    speeds_kmh: Sequence[float | None] = (None,),
    episodes: int = 10,
    seed: int = 1000,
    duration: float = VEHICLE_DURATION_S,
    trust: bool = False,
    workers: int = 1,
    address: str | None = None,
    backends: tuple[str, str] = (SURROGATE, "reference"),
    env_kwargs: dict[str, Any] | None = None,
    env_id: str = VEHICLE_ID,
) -> list[dict[str, Any]]:
    """Gap rows of ``env_id`` (a version of ``railgym/VerticalVehicle``): per (track class,
    speed, policy) the metric ``a_w`` at each floor point, each with the case's bump-stop
    contacts of both sides (as :func:`gap_vertical`); ``env_kwargs`` as
    :func:`gap_vertical`'s, the other arguments as
    :func:`agents.evaluation.runs.evaluate_vehicle`."""
    runs = [
        evaluate_vehicle(
            policies,
            b,
            track_classes,
            speeds_kmh,
            episodes,
            seed,
            duration,
            trust,
            workers,
            address,
            env_kwargs=backend_kwargs(b, env_kwargs),
            env_id=env_id,
        )
        for b in backends
    ]
    (a_w,) = metrics(VEHICLE, "a_w")
    rows = []
    for s, r in zip(*runs, strict=True):
        case = f"class {s['track_class']}, {s['speed_kmh']:.0f} km/h"
        for k, point in enumerate(FLOOR_POINTS):
            row = _row(case, s["policy"], a_w.label(point), s["a_w"][k], r["a_w"][k])
            rows.append({**row, **_contacts(s, r)})
    return rows


def _crash_metrics(rollout: Any) -> dict[str, float]:
    """Task metrics of one crash :class:`~agents.controllers.crash_baselines.Rollout`."""
    crit = rollout.criteria()
    values = {
        "peak_decel_g": crit.peak_decel_g,
        "moving_average_g": crit.moving_average_g,
        "max_crush_m": np.max(rollout.crush, axis=0),
        "intrusion_m": crit.intrusion_m,
    }
    out: dict[str, float] = {}
    for part, keys in (("car", CAR_METRICS), ("zone", ZONE_METRICS)):
        for i in range(len(values[keys[0]])):
            for m in metrics(CRASH, *keys):
                out[m.label(f"{part} {i + 1}", by_name=True)] = float(values[m.key][i])
    return out


def gap_crash(
    policies: Sequence[str],
    speeds_kmh: Sequence[float] | None = None,
    payloads_t: Sequence[tuple[float, float]] | None = None,
    trust: bool = False,
    backends: tuple[str, str] = (SURROGATE, "reference"),
    env_kwargs: dict[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """Gap rows of ``TrainCrash-v1`` per (speed km/h × payload t, policy) and metric;
    ``diverged``: the backends the env cut as diverged (``"surrogate"``, ``"reference"``,
    ``"surrogate and reference"``), else ``""``.

    ``policies``: the crash baselines (``passive``, ``best-constant``, ``speed-adaptive``) or
    trained policy ``.zip`` files, each on the ``envelope`` scenario with the env settings it
    was trained with; cases fixed by ``reset(options=...)`` (default the held-out envelope).
    ``env_kwargs``: e.g. the user's ``scenario`` and ``surrogate`` (to the surrogate side).
    """
    scenario = (env_kwargs or {}).get("scenario", "envelope")
    speeds, payloads = (
        crash_report.envelope_cases(scenario)
        if speeds_kmh is None or payloads_t is None
        else ([], [])
    )
    speeds = speeds if speeds_kmh is None else list(speeds_kmh)
    payloads = payloads if payloads_t is None else list(payloads_t)
    loaded: list[tuple[Any, dict[str, Any], str]] = []
    for p in val.sequence(policies, "policies"):
        if baseline := crash_factories([p]):
            name, factory = next(iter(baseline.items()))
            loaded.append((factory, {}, name))
        else:
            loaded.append(load_policy(p, CRASH_ID, trust))
    rows = []
    for kmh in speeds:
        for payload in payloads:
            case = f"{kmh:g} km/h, payload {payload[0]:g}/{payload[1]:g} t"
            lead, passenger = payload
            options = {"speed_kmh": kmh, "payload_t": {"lead": lead, "passenger": passenger}}
            for factory, trained, label in loaded:
                metrics, cut = [], []
                for b in backends:
                    extra = backend_kwargs(b, env_kwargs)
                    kwargs = {
                        "scenario": "envelope",
                        **with_policy_kwargs(trained, extra, label),
                        "backend": b,
                    }
                    env = TrainCrashVectorEnv(num_envs=1, **kwargs)
                    run = rollout(env, factory(env), options=options)[0]
                    metrics.append(_crash_metrics(run))
                    cut.append(run.diverged)
                    env.close()
                s, r = metrics
                sides = " and ".join(b for b, c in zip(backends, cut, strict=True) if c)
                rows += [{**_row(case, label, k, s[k], r[k]), "diverged": sides} for k in s]
    return rows


def format_gap(rows: list[dict[str, Any]], against: str = "reference") -> str:
    """Aligned text table of gap rows (``against``: the label of the reference column), then
    the largest |gap| of each policy. Rows with contacts (vertical, vehicle) get a column
    ``contacts`` (bump-stop substeps, surrogate / reference) and a line under the table per
    policy whose ``a_w`` beats a classical controller's of its case on the reference side with
    more contacts there (:func:`contact_lines`). Rows with a ``diverged`` key (the crash's) get
    a column ``diverged`` and the diverged runs are named in a line under the table."""
    wc = max([4, *(len(r["case"]) for r in rows)])
    wp = max([6, *(len(r["policy"]) for r in rows)])
    wm = max([6, *(len(r["metric"]) for r in rows)])
    marked = any("diverged" in r for r in rows)
    counted = any("contacts_reference" in r for r in rows)
    lines = [
        f"{'case':<{wc}}  {'policy':<{wp}}  {'metric':<{wm}}  {'surrogate':>10}  "
        f"{against:>10}  {'gap %':>8}"
        + ("  contacts" if counted else "")
        + ("  diverged" if marked else "")
    ]
    cut: dict[str, None] = {}
    for r in rows:
        sides = r.get("diverged") or ""
        if sides:
            cut[f"{r['policy']}, {r['case']} ({sides})"] = None
        lines.append(
            f"{r['case']:<{wc}}  {r['policy']:<{wp}}  {r['metric']:<{wm}}  "
            f"{r['surrogate']:10.4g}  {r['reference']:10.4g}  {100 * r['gap']:8.2f}"
            + (
                f"  {r['contacts_surrogate']:.0f} / {r['contacts_reference']:.0f}"
                if counted
                else ""
            )
            + (f"  {sides or 'no'}" if marked else "")
        )
    lines += crash_report.diverged_lines(list(cut))
    lines += contact_lines(rows, against)
    worst: dict[str, float] = {}
    for r in rows:
        worst[r["policy"]] = max(worst.get(r["policy"], 0.0), abs(r["gap"]))
    lines.append("")
    lines += [f"largest |gap| of {p}: {100 * g:.2f} %" for p, g in worst.items()]
    return "\n".join(lines)


def contact_lines(rows: list[dict[str, Any]], against: str = "reference") -> list[str]:
    """``"class 4, ppo: more contacts than lqg (reference)"`` for each (case, policy) of the
    gap ``rows`` whose reference ``a_w`` (a vehicle's: the mean over its floor points) beats a
    classical controller's of the same case with more bump-stop contacts on that side."""
    grouped: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in rows:
        if "contacts_reference" in r:
            grouped.setdefault((r["case"], r["policy"]), []).append(r)
    scores = [
        Score(
            case,
            policy,
            float(np.mean([r["reference"] for r in group])),
            group[0]["contacts_reference"],
        )
        for (case, policy), group in grouped.items()
    ]
    baselines = {*CONTROLLERS, *VEHICLE_CONTROLLERS}
    return [
        f"{s.case}, {s.policy}: {contact_note(names)} ({against})"
        for s, names in zip(scores, more_contacts(scores, baselines), strict=True)
        if names
    ]
