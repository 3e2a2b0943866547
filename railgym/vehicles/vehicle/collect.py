"""Training data and the memory element of the whole vehicle (``VerticalVehicle-v1``).

The one-bogie element (:mod:`railgym.vehicles.collect`) is fitted on the one-bogie model,
whose secondary suspension never sees the carbody's pitch and bending. The whole-vehicle
design runs the whole vehicle's dynamic reference (:mod:`railgym.vehicles.vehicle`) over FRA
classes × speeds × seeds, each case once passive and once with both actuators driven by
independent band-limited random forces
(:func:`~railgym.vehicles.collect_design.band_limited_force`), and records each bogie's
secondary deflection, its rate and force at the integration step. Each bogie of each run is
one run of the :func:`~railgym.vehicles.collect_design.collect_design` format, so the memory
features (:func:`~railgym.vehicles.memory_element.memory_training_data`) and the fit are those of
the one-bogie element. The packaged element ``railgym/data/vehicle_lpr.json`` (the default of
``VerticalVehicle-v1``, :func:`default_vehicle_surrogate`) is rebuilt by::

    railgym collect-vehicle -o railgym/data/vehicle_lpr.json --overwrite

Its Maxwell state follows a fitted nonlinear relaxation law (:mod:`surrogates.memory`): the
reference's damper is a stiffness in series with a dashpot whose slope depends on the
direction and drops past a blow-off knee, and the linear law cannot follow it in the
8–12 Hz band of the carbody's bending mode (measured in ``docs/validation.md``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import Any

import numpy as np

from railgym.track import fra_profile_with_slope
from railgym.vehicles.collect_design import band_limited_force
from railgym.vehicles.memory_element import element_runs, select_memory_element
from railgym.vehicles.vehicle.model import (
    DEFAULT_DT,
    advance,
    check_variant,
    kernel_params,
    lpr_arrays,
    new_arrays,
    wheelset_offsets,
)
from railgym.vehicles.vehicle.params import load_whole_vehicle
from surrogates import io
from surrogates.memory import TauSelection, fit_relaxation, shortest_time_constant
from surrogates.models import SurrogateModel
from surrogates.models.lpr import LegendreRegression
from surrogates.passive import PassiveLegendreRegression

__all__ = [
    "VEHICLE_DEGREES",
    "VEHICLE_DESIGN",
    "VEHICLE_TAUS",
    "VehicleDesign",
    "VEHICLE_SURROGATE",
    "build_vehicle_surrogate",
    "collect_vehicle",
    "default_vehicle_surrogate",
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
#: packaged element of the whole vehicle (``railgym/data``), built by :func:`main`
VEHICLE_SURROGATE = "vehicle_lpr.json"


@lru_cache(maxsize=1)
def default_vehicle_surrogate() -> SurrogateModel:
    """The packaged whole-vehicle element (:data:`VEHICLE_SURROGATE`, loaded once): the
    default of ``VerticalVehicle-v1``."""
    with resources.as_file(resources.files("railgym") / "data" / VEHICLE_SURROGATE) as p:
        return io.load(p)


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
    relaxation: bool = True,
    passive: bool = False,
    data: dict[str, Any] | None = None,
) -> tuple[SurrogateModel, TauSelection, dict[str, Any]]:
    """The whole vehicle's memory element: an additive LPR ``F̂(δ, δ̇, ζ)`` (``passive``:
    with non-negative slopes, :mod:`surrogates.passive`) plus the bump-stop law, fitted on
    :func:`collect_vehicle` data (both bogies pooled), degrees by ``k``-fold CV.

    With ``relaxation`` the Maxwell state follows a nonlinear two-slope relaxation law
    ``ṡ = g(δ − s)`` (:func:`surrogates.memory.two_slope_relaxation`: direction-dependent
    time constants and a blow-off knee, the series stiffness and damper of the reference),
    fitted first (:func:`surrogates.memory.fit_relaxation`); otherwise the linear law, ``τ``
    chosen among ``taus`` by CV. ``data``: a :func:`collect_vehicle` result to reuse.

    Returns ``(model, selection, data)`` as
    :func:`~railgym.vehicles.memory_element.build_memory_surrogate` does (the selection's ``τ`` of a
    relaxation law is its shortest time constant).
    """
    if data is None:
        data = collect_vehicle(design, vehicle)
    base = load_whole_vehicle(vehicle).suspension.name
    if relaxation:
        law = fit_relaxation(element_runs(data, ("bump_stop",), base)).law
        laws: dict[float, Any] = {shortest_time_constant(law): law}
    else:
        laws = {float(tau): None for tau in taus}
    cls = PassiveLegendreRegression if passive else LegendreRegression
    model, sel = select_memory_element(
        data, list(laws), degrees, cls, ("bump_stop",), base, k, seed, laws=laws
    )
    return model, sel, data


if __name__ == "__main__":
    from surrogates.cli_flags import moved_command

    raise SystemExit(moved_command("railgym.vehicles.vehicle.collect", "railgym collect-vehicle"))
