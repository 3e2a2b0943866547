"""Runs and indices of the paper report: surrogate vs reference on our models.

Vertical case (paper sections 4.1–4.2): training data from the dynamic reference model
(:mod:`railgym.vehicles.vertical`, FRA class 5 at 144 km/h, 20 s at 50 Hz, track seed
``seed``), M space-filling samples (GA), LPR (degrees by out-of-bag error) and Kriging
(kernel by out-of-bag error) built by :func:`surrogates.builder.build`. Each element (LPR and
Kriging alike) replaces the secondary suspension in the compiled kernel
(:func:`railgym.vehicles.vertical.simulate`, variant ``"surrogate"``) over an unseen track
realisation (seed ``seed + 1``) and is compared with the reference (eq. 9 on the carbody
displacement, velocity and acceleration, recorded at :data:`SAMPLE_RATE`); a run that leaves
the finite range is flagged ``diverged`` (the paper's Kriging diverged on class 4).

Crash case (section 4.3): :mod:`railgym.vehicles.crash`, paper scenario (two cars into a rigid
wall at 40 km/h); surrogate elements of each variant; LPR degrees by 10-fold CV.

Everything returned is plain data (dicts of numbers) except :class:`Artifacts`, the models and
records the figures need.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from importlib.resources import files
from typing import Any, NamedTuple

import numpy as np

from railgym.report.published import PAPER
from railgym.report.validation import CLASSES
from railgym.track import track_time_input
from railgym.vehicles.collect import TRAINING_CASE, collect_vertical
from railgym.vehicles.crash.reference import simulate_reference
from railgym.vehicles.crash.scenario import CrashScenario, load_scenario
from railgym.vehicles.crash.surrogate import build_crash_surrogate, crash_errors
from railgym.vehicles.crash.surrogate_model import simulate_surrogate
from railgym.vehicles.vertical.kernels import DEFAULT_DT
from railgym.vehicles.vertical.params import VerticalVehicle, load_vehicle
from railgym.vehicles.vertical.simulate import simulate
from surrogates.builder import BuildReport, build
from surrogates.metrics import average_absolute_error
from surrogates.selection import candidate_label

__all__ = [
    "CRASH_MAX_DEGREE",
    "FULL",
    "QUICK",
    "SAMPLE_RATE",
    "TOLERANCE_CASES",
    "Artifacts",
    "Plan",
    "TrackCase",
    "compute",
    "n_steps",
    "paper_scenario",
    "run_element",
    "track_case",
]

#: recording rate of the vertical simulations compared by eq. 9, Hz
SAMPLE_RATE = 200.0
#: paper table 7: tolerance cases (FRA class → speed, km/h)
TOLERANCE_CASES = {3: 96.0, 4: 128.0, 6: 176.0}
#: the two surrogate elements of the vertical case
KINDS = ("lpr", "kriging")
#: largest LPR degree tried by the crash elements' 10-fold CV
CRASH_MAX_DEGREE = 30

Step = Callable[[str], None]


@dataclass(frozen=True)
class Plan:
    """Sizes of one report run.

    Attributes
    ----------
    sizes : training-sample sizes M of both models (tables 3, 5, 6).
    table3_m : M of the out-of-bag comparison (table 3).
    tolerance_m : M of both elements in the track-class tolerance test (table 8).
    duration : length of each vertical simulation, s.
    crash_variants : surrogate crash element variants (tables 10–11).
    validation_seeds : unseen tracks per class of the validation matrix.
    """

    sizes: tuple[int, ...]
    table3_m: int
    tolerance_m: int
    duration: float
    crash_variants: tuple[str, ...]
    validation_seeds: int = 20


FULL = Plan((51, 101, 201), 101, 101, 20.0, ("paper", "hysteretic"))
QUICK = Plan((51, 101), 101, 51, 5.0, ("paper",), validation_seeds=2)


class TrackCase(NamedTuple):
    """One vertical test case: track input (m, m/s at the reference step) and reference run."""

    track_class: int
    speed_kmh: float
    z: np.ndarray
    zdot: np.ndarray
    reference: dict[str, Any]
    reference_s: float


class Artifacts(NamedTuple):
    """What the figures need beyond the tables."""

    data: dict[str, Any]
    models: dict[tuple[str, int], Any]
    reports: dict[tuple[str, int], BuildReport]
    case5: TrackCase
    records: dict[str, dict[str, Any]]
    crash: dict[str, Any]


def n_steps(plan: Plan) -> int:
    """Number of progress steps of :func:`compute` (one per build, run or crash variant)."""
    vertical = 1 + 2 * len(plan.sizes) + 1 + 2 * len(plan.sizes) + 3 * len(TOLERANCE_CASES)
    return vertical + 1 + len(plan.crash_variants) + len(CLASSES)


# ========================================================================= vertical case
def _carbody_errors(sim: dict[str, Any], ref: dict[str, Any]) -> dict[str, float]:
    """Eq. 9 errors of the carbody displacement (m), velocity (m/s), acceleration (m/s²)."""
    n = min(sim["t"].size, ref["t"].size)
    return {
        key: average_absolute_error(sim[ch][:n], ref[ch][:n])
        for key, ch in (("x", "x2"), ("v", "v2"), ("a", "a2"))
    }


def _reference_scale(ref: dict[str, Any]) -> dict[str, float]:
    """Mean |x2| (m), |ẋ2| (m/s), |ẍ2| (m/s²) of a reference run: the scale of eq. 9."""
    return {k: float(np.mean(np.abs(ref[ch]))) for k, ch in (("x", "x2"), ("v", "v2"), ("a", "a2"))}


def _every(dt: float) -> int:
    return round(1.0 / (SAMPLE_RATE * dt))


def track_case(
    vehicle: VerticalVehicle, track_class: int, speed_kmh: float, duration: float, seed: int
) -> TrackCase:
    """Track input of ``duration`` s and the dynamic reference run over it (timed, s)."""
    dt = DEFAULT_DT["dynamic"]
    _, z, zdot = track_time_input(track_class, speed_kmh / 3.6, duration, dt, seed)
    t0 = time.perf_counter()
    ref = simulate("dynamic", vehicle, z, zdot, dt, sample_every=_every(dt))
    return TrackCase(track_class, speed_kmh, z, zdot, ref, time.perf_counter() - t0)


def run_element(
    vehicle: VerticalVehicle, model: Any, case: TrackCase
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Simulate an LPR or Kriging element on ``case`` in the compiled kernel; (plain-data
    entry, record).

    The entry holds the eq. 9 errors ``x, v, a`` against the reference, the out-of-domain
    stage evaluations of ``evaluations``, ``diverged``, ``t_end_s`` and ``sim_time_s``.
    """
    dt = DEFAULT_DT["surrogate"]
    t0 = time.perf_counter()
    rec = simulate(
        "surrogate", vehicle, case.z, case.zdot, dt, surrogate=model, sample_every=_every(dt)
    )
    wall = time.perf_counter() - t0
    entry = {
        **_carbody_errors(rec, case.reference),
        "out_of_domain": int(rec["out_of_domain"]),
        "evaluations": 4 * (case.z.size - 1),
        "diverged": bool(rec["diverged"]),
        "t_end_s": float(rec["t"][-1]),
        "sim_time_s": float(wall),
    }
    return entry, rec


def _warm_up(vehicle: VerticalVehicle, lpr: Any) -> None:
    """Load the compiled kernels before anything is timed."""
    z = np.zeros(11)
    simulate("dynamic", vehicle, z, z, 1e-3)
    simulate("surrogate", vehicle, z, z, 1e-3, surrogate=lpr)


def _predict_cost(model: Any, U: np.ndarray) -> dict[str, float]:
    """``predict`` wall time, best of repeats: µs per call with one point, µs per point in a
    batch of 10⁴."""
    one = U[:1].copy()
    batch = U[np.arange(10_000) % U.shape[0]]
    call = point = math.inf
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(100):
            model.predict(one)
        call = min(call, (time.perf_counter() - t0) / 100)
    for _ in range(3):
        t0 = time.perf_counter()
        model.predict(batch)
        point = min(point, (time.perf_counter() - t0) / batch.shape[0])
    return {"predict_call_us": call * 1e6, "predict_point_us": point * 1e6}


def _oob_entry(rep: BuildReport, V: np.ndarray) -> dict[str, Any]:
    scale = float(np.mean(np.abs(V[rep.oob_idx])))
    return {
        "chosen": candidate_label(rep.chosen),
        "oob_error": float(rep.oob_error),
        "oob_error_kind": rep.oob_error_kind,
        "oob_error_normalised": float(rep.oob_error / scale),
        "oob_nrms": float(rep.oob_nrms),
        "T_t_build_s": float(rep.training_time_s),
        "T_t_fit_s": float(rep.fit_time_s),
    }


def _fit(plan: Plan, seed: int, step: Step) -> tuple[dict[str, Any], dict, dict]:
    """Training data and both models at every M of the plan."""
    data = collect_vertical(
        track_class=TRAINING_CASE["track_class"],
        speed=TRAINING_CASE["speed_kmh"] / 3.6,
        duration=TRAINING_CASE["duration"],
        sample_rate=TRAINING_CASE["sample_rate"],
        seed=seed,
    )
    step("training data")
    models: dict[tuple[str, int], Any] = {}
    reports: dict[tuple[str, int], BuildReport] = {}
    for kind in KINDS:
        for m in plan.sizes:
            models[kind, m], reports[kind, m] = build(
                data["U"], data["V"], kind=kind, m=m, seed=seed
            )
            step(f"build {kind} M={m}")
    return data, models, reports


def _table3(plan: Plan, V: np.ndarray, reports: dict[tuple[str, int], BuildReport]) -> dict:
    m = plan.table3_m
    return {
        "m": m,
        "n": int(V.shape[0]),
        "lpr": _oob_entry(reports["lpr", m], V),
        "kriging": _oob_entry(reports["kriging", m], V),
        "all_sizes": {k: {s: _oob_entry(reports[k, s], V) for s in plan.sizes} for k in KINDS},
        "published": PAPER["table3"],
    }


def _table6(
    plan: Plan, case5: TrackCase, runs5: dict, models: dict, reports: dict, U: np.ndarray
) -> dict:
    """T_t of every fit, T_s of the compiled runs and the reference, ``predict`` cost."""

    def entry(kind: str, m: int) -> dict[str, float]:
        rep = reports[kind, m]
        return {
            "T_t_fit_s": rep.fit_time_s,
            "T_t_build_s": rep.training_time_s,
            "T_s_numba_s": runs5[kind][m]["sim_time_s"],
            **_predict_cost(models[kind, m], U),
        }

    return {
        "duration_s": plan.duration,
        "reference_s": case5.reference_s,
        **{kind: {m: entry(kind, m) for m in plan.sizes} for kind in KINDS},
        "published": PAPER["table6"],
    }


def _table8(vehicle: VerticalVehicle, plan: Plan, models: dict, seed: int, step: Step) -> dict:
    classes = {}
    for cls, speed in TOLERANCE_CASES.items():
        case = track_case(vehicle, cls, speed, plan.duration, seed + 1)
        step(f"reference class {cls}")
        classes[cls] = {
            "speed_kmh": speed,
            "reference_contacts": int(case.reference["contacts"]),
            "reference_mean_abs": _reference_scale(case.reference),
        }
        for kind in KINDS:
            classes[cls][kind] = run_element(vehicle, models[kind, plan.tolerance_m], case)[0]
            step(f"{kind} class {cls}")
    return {
        "m": plan.tolerance_m,
        "duration_s": plan.duration,
        "track_seed": seed + 1,
        "classes": classes,
        "published": PAPER["table8"],
    }


def _vertical(plan: Plan, seed: int, step: Step) -> tuple[dict[str, Any], Artifacts]:
    vehicle = load_vehicle("manchester")
    data, models, reports = _fit(plan, seed, step)
    _warm_up(vehicle, models["lpr", plan.sizes[0]])
    case5 = track_case(vehicle, 5, TRAINING_CASE["speed_kmh"], plan.duration, seed + 1)
    step("reference class 5")
    runs5: dict[str, dict[int, dict[str, Any]]] = {kind: {} for kind in KINDS}
    records: dict[str, dict[str, Any]] = {"reference": case5.reference}
    for kind in KINDS:
        for m in plan.sizes:
            runs5[kind][m], records[f"{kind}_{m}"] = run_element(vehicle, models[kind, m], case5)
            step(f"{kind} M={m}")
    tables = {
        "table3": _table3(plan, data["V"], reports),
        "table5": {
            "track_class": 5,
            "speed_kmh": TRAINING_CASE["speed_kmh"],
            "duration_s": plan.duration,
            "track_seed": seed + 1,
            "sample_rate_hz": SAMPLE_RATE,
            "reference_mean_abs": _reference_scale(case5.reference),
            **runs5,
            "published": PAPER["table5"],
        },
        "table6": _table6(plan, case5, runs5, models, reports, data["U"]),
        "table8": _table8(vehicle, plan, models, seed, step),
    }
    return tables, Artifacts(data, models, reports, case5, records, {})


# ============================================================================ crash case
def _degrees(sur: Any) -> dict[str, dict[str, Any]]:
    """Table 10 row of one crash surrogate: degree, samples and CV RMS (N) per branch."""
    return {
        f"{name}_{branch}": {
            "degree": deg,
            "n_samples": el.n_samples[branch],
            "cv_rms_N": float(
                min(r["rms"] for r in el.selection[branch].table if np.isfinite(r["rms"]))
            ),
        }
        for name, el in sur.elements.items()
        for branch, deg in el.degrees.items()
    }


def paper_scenario() -> CrashScenario:
    """The packaged ``paper`` crash scenario, read from its file path: a file or folder named
    ``paper`` in the working directory cannot stand in for it."""
    return load_scenario(str(files("railgym").joinpath("configs", "crash", "paper.yaml")))


def _crash(plan: Plan, seed: int, step: Step) -> tuple[dict[str, Any], dict[str, Any]]:
    """Tables 10, 11 and the crash runs ``{"reference": result, variant: (model, result)}``."""
    scenario = paper_scenario()
    simulate_reference(scenario, duration=2e-3)  # load the compiled kernel
    ref = simulate_reference(scenario)
    step("crash reference")
    table10: dict[str, Any] = {"max_degree": CRASH_MAX_DEGREE, "variants": {}, "published": None}
    table11: dict[str, Any] = {
        "reference_s": float(ref.wall_time),
        "variants": {},
        "published": PAPER["table11"],
    }
    runs: dict[str, Any] = {"reference": ref}
    for variant in plan.crash_variants:
        sur = build_crash_surrogate(ref, variant=variant, seed=seed, max_degree=CRASH_MAX_DEGREE)
        simulate_surrogate(scenario, sur, duration=2e-3)  # load the compiled kernel
        res = simulate_surrogate(scenario, sur, duration=float(ref.t[-1]), stop_when_over=False)
        runs[variant] = (sur, res)
        table10["variants"][variant] = _degrees(sur)
        err = crash_errors(res, ref)
        cars = {
            car: {k: float(err[k][i]) for k in ("x", "v", "a")}
            for i, car in enumerate(("lead", "passenger"))
        }
        table11["variants"][variant] = {
            **cars,
            "build_s": float(sur.build_time),
            "sim_s": float(res.wall_time),
        }
        step(f"crash {variant}")
    return {"table10": table10, "table11": table11}, runs


# ============================================================================ everything
def compute(
    plan: Plan, seed: int = 0, step: Step | None = None
) -> tuple[dict[str, Any], Artifacts]:
    """Every run of the report; returns (tables as plain data, artifacts for the figures).

    Parameters
    ----------
    plan : sizes (:data:`FULL` or :data:`QUICK`).
    seed : seed of the training track, the sampling and the CV folds; the vertical test
        simulations run on track seed ``seed + 1``.
    step : called with a label after each of the :func:`n_steps` runs (progress display).

    Returns
    -------
    ``({"plan", "table3", "table5", "table6", "table8", "table10", "table11"}, artifacts)``;
    each table carries the paper's numbers under ``"published"`` where the text has them.
    """
    step = step or (lambda label: None)
    vertical, art = _vertical(plan, seed, step)
    crash, runs = _crash(plan, seed, step)
    result = {
        "plan": {
            "seed": seed,
            "sizes": list(plan.sizes),
            "duration_s": plan.duration,
            "crash_variants": list(plan.crash_variants),
        },
        **vertical,
        **crash,
    }
    return result, art._replace(crash=runs)
