"""Training data for the whole vehicle's element from an FMU (``env: vehicle`` mappings).

:func:`collect_vehicle_fmu` runs a data-collection design
(:mod:`railgym.vehicles.collect_design`: ``"paper"``, ``"envelope"`` or a
:class:`~railgym.vehicles.collect_design.CollectionDesign`) on the whole-vehicle FMU of a
mapping file: each case's track under the four wheelsets (the env's cubic Hermite
interpolation at each wheelset's offset), passive and, in the excited runs, both actuators
driven by independent band-limited random forces. Each bogie of each run is one run of the
:func:`~railgym.vehicles.collect_design.collect_design` format (``delta``, ``delta_dot``,
``force`` of that bogie), so :func:`railgym.vehicles.collect.build_memory_surrogate` and
:func:`~railgym.vehicles.collect.build_vertical_surrogate` fit the element that
``VerticalVehicle`` puts at both bogies.

The secondary force of each bogie is the FMU's ``secondary_force_front`` /
``secondary_force_rear`` output when the mapping names both, else the carbody's equations
inverted (:func:`railgym.vehicles.vehicle.reconstruct.bogie_forces`: the floor
accelerations ``acc_front``, ``acc_centre``, ``acc_rear`` with the carbody mass, pitch
inertia, bogie spacing and length of the whole-vehicle file) less the actuator force.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from railgym.fmu.mapping import FMUError, Mapping, fmu_vehicle, load_mapping
from railgym.fmu.runner import FMURunner
from railgym.track import fra_profile_with_slope
from railgym.vehicles.collect_design import CollectionDesign, band_limited_force, design_named
from railgym.vehicles.vehicle.lanes import hermite
from railgym.vehicles.vehicle.model import wheelset_offsets
from railgym.vehicles.vehicle.params import WholeVehicle, load_whole_vehicle
from railgym.vehicles.vehicle.reconstruct import bogie_forces

__all__ = ["BOGIES", "collect_vehicle_fmu", "simulate_vehicle_fmu", "wheelset_inputs"]

#: the bogies, in the order of the mapping's ``_front`` / ``_rear`` outputs
BOGIES = ("front", "rear")
_FLOOR = ("acc_front", "acc_centre", "acc_rear")
#: collection step without the mapping's ``step:``, s (200 Hz samples are 5 steps)
COLLECT_DT = 1e-3


def wheelset_inputs(
    z: np.ndarray, zdot: np.ndarray, offsets: np.ndarray, n: int, dt: float, half: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Track height and rate (m, m/s) under the four wheelsets, ``(4, n)``, at the sample
    indices ``k + offsets[j]`` (``+ 0.5`` with ``half``) of the rear wheelset's time grid
    ``z, zdot`` (the env's cubic Hermite interpolation)."""
    w, wd = np.empty((4, n)), np.empty((4, n))
    shift = 0.5 if half else 0.0
    for j in range(4):
        for k in range(n):
            w[j, k], wd[j, k] = hermite(z, zdot, k + shift + float(offsets[j]), dt)
    return w, wd


def simulate_vehicle_fmu(
    runner: FMURunner,
    z: np.ndarray,
    zdot: np.ndarray,
    offsets: np.ndarray,
    force_a: np.ndarray,
    vehicle: WholeVehicle,
    n: int,
) -> dict[str, Any]:
    """``n`` steps of the whole-vehicle FMU from rest over the track ``z, zdot`` (rear
    wheelset's time grid, m, m/s; ``offsets`` of the wheelsets in samples) with the actuator
    forces ``force_a`` (2, n) N, held over each step.

    Returns ``t`` (n + 1,) s and, ``(n + 1, 2)`` per bogie (front, rear), ``delta`` (m),
    ``delta_dot`` (m/s), ``force`` (secondary force F_s, N), ``floor`` (n + 1, 3) floor
    accelerations (m/s²) and ``contacts`` (2,) steps beyond the free travel of the
    vehicle's suspension."""
    dt = runner.dt
    cols = {k: j for j, k in enumerate(runner.out_keys)}
    w, wd = wheelset_inputs(z, zdot, offsets, n + 1, dt)
    wm, wdm = wheelset_inputs(z, zdot, offsets, n, dt, half=True)
    out = np.zeros((n + 1, len(cols)))
    runner.reset()
    out[0] = runner.outputs_at(w[:, 0], wd[:, 0], force_a[:, 0])
    for k in range(n):
        y = runner.advance(
            w[:, k : k + 2],
            wd[:, k : k + 2],
            force_a[:, k],
            mid=(wm[:, k : k + 1], wdm[:, k : k + 1]),
        )
        out[k + 1] = y[-1]
    fa = np.concatenate([force_a[:, :1], force_a], axis=1).T  # the force of the step ending at t_k
    floor = out[:, [cols[key] for key in _FLOOR]]
    given = [f"secondary_force_{b}" for b in BOGIES]
    if given[0] in cols:
        force = out[:, [cols[key] for key in given]]
    else:
        force = bogie_forces(floor, vehicle) - fa
    delta = out[:, [cols[f"deflection_{b}"] for b in BOGIES]]
    e = vehicle.suspension.kernel_params()
    beyond = (delta[1:] > e.free_c) | (delta[1:] < -e.free_r)
    return {
        "t": np.arange(n + 1) * dt,
        "delta": delta,
        "delta_dot": out[:, [cols[f"deflection_rate_{b}"] for b in BOGIES]],
        "force": force,
        "floor": floor,
        "contacts": beyond.sum(axis=0),
    }


def _track(
    vehicle: WholeVehicle, case: tuple[int, float, int], n: int, dt: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(z, zdot, offsets)``: the seeded FRA track of ``case`` ``(class, speed m/s, seed)``
    on the rear wheelset's time grid, long enough for the front wheelset over ``n`` steps."""
    track_class, v, seed = case
    offsets = wheelset_offsets(vehicle, v, dt)
    m = n + math.ceil(float(offsets.max())) + 3
    dx = v * dt
    _, z, slope = fra_profile_with_slope(track_class, (m - 1) * dx, dx, seed)
    return z[:m], v * slope[:m], offsets


def _check_forces(mapping: Mapping) -> None:
    """Both bogies' ``secondary_force_*`` outputs or neither (then the floor accelerations
    give them): one alone is an :class:`FMUError` naming the other."""
    given = [f"secondary_force_{b}" for b in BOGIES if f"secondary_force_{b}" in mapping.outputs]
    if len(given) == 1:
        other = f"secondary_force_{'rear' if given[0].endswith('front') else 'front'}"
        raise FMUError(
            f"outputs.{other}",
            f"{mapping.source}: outputs.{other} is missing: map both bogies' secondary forces "
            f"or neither (then they come from the floor accelerations {', '.join(_FLOOR)})",
            full=True,
        )


def _steps(design: CollectionDesign, dt: float, source: str) -> tuple[int, int]:
    """Steps of ``dt`` per run and between training samples of ``design``."""
    every = round(1.0 / (design.sample_rate * dt))
    if every < 1 or not np.isclose(every * dt * design.sample_rate, 1.0):
        raise FMUError(
            "step",
            f"{source}: design.sample_rate {design.sample_rate} Hz is not a whole number of "
            f"steps of {dt} s (the mapping's step:)",
            full=True,
        )
    return round(design.duration / dt), every


def collect_vehicle_fmu(
    fmu_map: str | Path,
    design: str | CollectionDesign = "envelope",
    fmu: str | Path | None = None,
    vehicle: Any = None,
    dt: float | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """Run ``design`` on the whole-vehicle FMU of the mapping file ``fmu_map`` (``fmu``: the
    FMU file, default the mapping's ``fmu:``) with the whole-vehicle file ``vehicle`` (a
    :class:`~railgym.vehicles.vehicle.WholeVehicle`, a name or a YAML path; default the
    mapping's ``vehicle:``, one of them required: :func:`~railgym.fmu.mapping.fmu_vehicle`),
    stepped at ``dt`` (s; default the mapping's ``step:``, else :data:`COLLECT_DT`).
    ``progress(i, total)`` after each track case.

    Returns the :func:`~railgym.vehicles.collect_design.collect_design` result: ``runs``,
    one per bogie of each run (front first, ``bogie`` 0 or 1, ``a2`` the floor acceleration
    over that bogie), ``U``, ``V`` of their samples, ``design``."""
    design = design_named(design)
    if not isinstance(vehicle, WholeVehicle):
        vehicle = load_whole_vehicle(fmu_vehicle(fmu_map, vehicle, env="vehicle"))
    veh = vehicle
    mapping = load_mapping(fmu_map, fmu, "vehicle")
    _check_forces(mapping)
    if dt is None:
        dt = COLLECT_DT if mapping.step is None else mapping.step
    n, every = _steps(design, dt, mapping.source)
    runner = FMURunner(mapping, dt, 1)
    cases = design.cases()
    runs = []
    try:
        for i, case in enumerate(cases):
            z, zdot, offsets = _track(veh, case, n, dt)
            for excited in (False, True) if design.f_max > 0 else (False,):
                fa = np.zeros((2, n))
                if excited:
                    for b in range(2):
                        fa[b] = band_limited_force(
                            n, dt, design.band, design.f_max, [case[2], i, b]
                        )
                rec = simulate_vehicle_fmu(runner, z, zdot, offsets, fa, veh, n)
                if not all(np.isfinite(rec[k]).all() for k in ("delta", "delta_dot", "force")):
                    raise FMUError(
                        "fmu",
                        f"{mapping.fmu}: non-finite outputs in the run of class {case[0]}, "
                        f"{case[1] * 3.6:g} km/h, seed {case[2]}"
                        + (", actuators excited" if excited else ""),
                        full=True,
                    )
                runs += _bogie_runs(case, excited, rec, fa, every)
            if progress is not None:
                progress(i + 1, len(cases))
    finally:
        runner.close()
    U = np.concatenate([np.column_stack([r["delta"], r["delta_dot"]])[r["rows"]] for r in runs])
    V = np.concatenate([r["force"][r["rows"]] for r in runs])
    return {"runs": runs, "U": U, "V": V, "design": design}


def _bogie_runs(
    case: tuple[int, float, int], excited: bool, rec: dict[str, Any], fa: np.ndarray, every: int
) -> list[dict[str, Any]]:
    """The two runs (front, rear bogie) of one FMU run ``rec`` in the
    :func:`~railgym.vehicles.collect_design.run_record` format."""
    m = rec["t"].size
    floor_at = (0, 2)  # the floor points over the front and the rear bogie
    return [
        {
            "track_class": case[0],
            "speed": case[1],
            "seed": case[2],
            "excited": excited,
            "bogie": b,
            "t": rec["t"],
            "delta": rec["delta"][:, b],
            "delta_dot": rec["delta_dot"][:, b],
            "force": rec["force"][:, b],
            "force_a": fa[b, : m - 1],
            "a2": rec["floor"][:, floor_at[b]],
            "contacts": int(rec["contacts"][b]),
            "rows": np.arange(0, m, every),
        }
        for b in range(2)
    ]
