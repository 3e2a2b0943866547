"""Training data and the memory element of the whole vehicle (``VerticalVehicle-v1``).

The one-bogie element (:mod:`railgym.vehicles.collect`) is fitted on the one-bogie model,
whose secondary suspension never sees the carbody's pitch and bending. The whole-vehicle
design runs the whole vehicle's dynamic reference (:mod:`railgym.vehicles.vehicle`) over FRA
classes × speeds × seeds, each case once passive and once with both actuators driven by
independent band-limited random forces
(:func:`~railgym.vehicles.collect_design.band_limited_force`), and records each bogie's
secondary deflection, its rate and force at the integration step. Each bogie of each run is
one run of the :func:`~railgym.vehicles.collect_design.collect_design` format, so the memory
features (:func:`~railgym.vehicles.collect.memory_training_data`) and the fit are those of
the one-bogie element. Build one with::

    python -m railgym.vehicles.collect_vehicle --output vehicle_lpr.json

Measured against the packaged one-bogie memory element in ``docs/validation.md``.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from railgym.track import fra_profile_with_slope
from railgym.vehicles.collect import memory_training_data, save_vertical_surrogate
from railgym.vehicles.collect_design import band_limited_force
from railgym.vehicles.vehicle import (
    DEFAULT_DT,
    advance,
    check_variant,
    kernel_params,
    load_whole_vehicle,
    lpr_arrays,
    new_arrays,
    wheelset_offsets,
)
from surrogates.memory import TauSelection
from surrogates.models import SurrogateModel
from surrogates.passive import PassiveLegendreRegression
from surrogates.selection import select_kfold

__all__ = [
    "VEHICLE_DEGREES",
    "VEHICLE_DESIGN",
    "VEHICLE_TAUS",
    "VehicleDesign",
    "build_vehicle_surrogate",
    "collect_vehicle",
    "main",
]

#: Maxwell time constants tried, s
VEHICLE_TAUS = (6e-3, 8e-3, 12e-3)
#: degree tuples (δ, δ̇, ζ) tried
VEHICLE_DEGREES = tuple((a, b, c) for a in (10, 14, 18) for b in (10, 14, 18) for c in (5, 9, 13))
_KMH = 1.0 / 3.6


@dataclass(frozen=True)
class VehicleDesign:
    """Runs of the whole-vehicle collection: every class × speed × seed, passive and excited.

    Attributes
    ----------
    track_classes : FRA classes. speeds : m/s. seeds : track seeds.
    duration : s per run. sample_rate : Hz of the training samples.
    f_max : peak force of each actuator in the excited runs, N (0: passive runs only).
    band : upper frequency of the random actuator forces, Hz.
    """

    track_classes: tuple[int, ...] = (3, 4, 5, 6)
    speeds: tuple[float, ...] = (60 * _KMH, 100 * _KMH, 150 * _KMH, 200 * _KMH)
    seeds: tuple[int, ...] = (0,)
    duration: float = 10.0
    sample_rate: float = 100.0
    f_max: float = 8000.0
    band: float = 15.0

    def __post_init__(self) -> None:
        for name in ("track_classes", "speeds", "seeds"):
            if not getattr(self, name):
                raise ValueError(f"design.{name} must not be empty")
        for name in ("duration", "sample_rate", "band", *(() if self.f_max == 0 else ("f_max",))):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"design.{name} must be a positive number, got {v!r}")
        if any(not v > 0 for v in self.speeds):
            raise ValueError(f"design.speeds must be positive (m/s), got {self.speeds!r}")

    def cases(self) -> list[tuple[int, float, int, bool]]:
        """``(track_class, speed m/s, seed, excited)`` of every run."""
        excited = (False, True) if self.f_max > 0 else (False,)
        return [
            (c, float(v), s, e)
            for c in self.track_classes
            for v in self.speeds
            for s in self.seeds
            for e in excited
        ]


#: the packaged element's design: classes 3–6 at 60, 100, 150, 200 km/h, 10 s each
VEHICLE_DESIGN = VehicleDesign()


def collect_vehicle(
    design: VehicleDesign = VEHICLE_DESIGN, vehicle: str = "manchester_whole"
) -> dict[str, Any]:
    """Run the whole vehicle's dynamic reference over ``design`` (all runs in one batch).

    Returns
    -------
    dict
        ``runs``: one dict per bogie of each run (front first) with ``track_class, speed,
        seed, excited, bogie`` and the full-rate histories ``t`` (s), ``delta`` (m),
        ``delta_dot`` (m/s), ``force`` (F_s, N), ``force_a`` (the bogie's actuator force, N,
        held from ``t[k]`` to ``t[k+1]``) and the indices ``rows`` of the samples at
        ``sample_rate``; ``design``.
    """
    veh = load_whole_vehicle(vehicle)
    dt = DEFAULT_DT
    every = round(1.0 / (design.sample_rate * dt))
    if every < 1 or not np.isclose(every * dt * design.sample_rate, 1.0):
        raise ValueError(f"design.sample_rate {design.sample_rate} Hz is not a multiple of {dt} s")
    cases = design.cases()
    n_steps = round(design.duration / dt)
    span = 2.0 * (veh.bogie_semi_spacing + veh.semi_wheelbase)
    m = n_steps + math.ceil(span / (min(design.speeds) * dt)) + 2
    kind = check_variant("dynamic")
    arrays, out = new_arrays(len(cases), "dynamic", m)
    forces = np.zeros((len(cases), 2, n_steps))
    for i, (track_class, v, seed, excited) in enumerate(cases):
        dx = v * dt
        _, z, slope = fra_profile_with_slope(track_class, (m - 1) * dx, dx, seed)
        arrays.z[i, : z.size], arrays.zdot[i, : z.size] = z[:m], v * slope[:m]
        arrays.off[i] = wheelset_offsets(veh, v, dt)
        if excited:
            for b in range(2):
                forces[i, b] = band_limited_force(
                    n_steps, dt, design.band, design.f_max, [seed, i, b]
                )
    p = kernel_params(veh)
    e = veh.suspension.kernel_params().record()
    lpr = lpr_arrays(None)
    x = np.zeros((n_steps + 1, *arrays.state.shape))
    fs = np.zeros((n_steps + 1, len(cases), 2))
    for k in range(n_steps):
        arrays.force[:] = forces[:, :, k]
        advance(kind, arrays, 1, dt, p, e, lpr, out)
        arrays.k[:] += 1
        x[k + 1], fs[k + 1] = arrays.state, out.fs
    if out.div.any():
        raise RuntimeError(f"the reference diverged in runs {np.flatnonzero(out.div)}")
    t = np.arange(n_steps + 1) * dt
    rows = np.arange(0, n_steps + 1, every)
    runs = []
    for i, (track_class, v, seed, excited) in enumerate(cases):
        xi = x[:, i]
        for b in range(2):
            s = p.a if b == 0 else -p.a
            body = xi[:, 0] + s * xi[:, 1] + p.phi_a * xi[:, 2]
            body_v = xi[:, 7] + s * xi[:, 8] + p.phi_a * xi[:, 9]
            runs.append(
                {
                    "track_class": track_class,
                    "speed": v,
                    "seed": seed,
                    "excited": excited,
                    "bogie": b,
                    "t": t,
                    "delta": xi[:, 3 + 2 * b] - body,
                    "delta_dot": xi[:, 10 + 2 * b] - body_v,
                    "force": fs[:, i, b],
                    "force_a": forces[i, b],
                    "rows": rows,
                }
            )
    return {"runs": runs, "design": design}


def build_vehicle_surrogate(
    design: VehicleDesign = VEHICLE_DESIGN,
    taus: Sequence[float] = VEHICLE_TAUS,
    degrees: Iterable[Any] = VEHICLE_DEGREES,
    k: int = 5,
    seed: int = 0,
    vehicle: str = "manchester_whole",
) -> tuple[SurrogateModel, TauSelection, dict[str, Any]]:
    """The whole vehicle's memory element: passive ``F̂(δ, δ̇, ζ)`` plus the bump-stop law,
    ``τ`` and degrees by ``k``-fold CV on :func:`collect_vehicle` data (both bogies pooled).

    Returns ``(model, selection, data)`` as
    :func:`~railgym.vehicles.collect.build_memory_surrogate` does.
    """
    data = collect_vehicle(design, vehicle)
    base = load_whole_vehicle(vehicle).suspension.name
    degrees = list(degrees)
    sel = TauSelection()
    pairs = {}
    for tau in taus:
        U, V = memory_training_data(data, tau, ("bump_stop",), base)
        res = select_kfold(
            lambda deg: PassiveLegendreRegression(degree=deg), degrees, U, V, k=k, seed=seed
        )
        row = next(r for r in res.table if r["candidate"] == res.best)
        sel.table.append({"tau": tau, "degree": res.best, "rms": row["rms"], "nrms": row["nrms"]})
        sel.results.append(res)
        pairs[tau] = (U, V)
    best = min(sel.table, key=lambda r: r["rms"])
    sel.best = (best["tau"], best["degree"])
    U, V = pairs[best["tau"]]
    model = PassiveLegendreRegression(degree=best["degree"]).fit(U, V)
    model.features_ = {"form": "maxwell", "tau": best["tau"], "known_physics": ["bump_stop"]}
    data["U_memory"], data["V_memory"] = U, V
    return model, sel, data


def main(argv: Sequence[str] | None = None) -> int:
    """Build the whole-vehicle element of :data:`VEHICLE_DESIGN` and write it to ``--output``."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", required=True, help="model JSON")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --output")
    args = parser.parse_args(argv)
    out = Path(args.output)
    if out.exists() and not args.overwrite:
        parser.error(f"{out} exists; pass --overwrite to replace it")
    model, sel, _ = build_vehicle_surrogate()
    d = VEHICLE_DESIGN
    source = (
        "railgym whole-vehicle dynamic reference (manchester_whole), FRA classes "
        f"{list(d.track_classes)} at {[round(v * 3.6) for v in d.speeds]} km/h, "
        f"{d.duration:g} s each, passive and both actuators excited ({d.f_max:g} N peak, "
        f"{d.band:g} Hz), both bogies, {d.sample_rate:g} Hz; passive LPR on F_s - F_bump "
        "with the Maxwell state"
    )
    save_vertical_surrogate(
        model, sel, out, source, f"python -m railgym.vehicles.collect_vehicle --output {out.name}"
    )
    print(sel.format())
    print(f"written to {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
