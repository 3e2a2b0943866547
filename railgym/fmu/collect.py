"""Training data for the surrogate element from an FMU (stage 1 of the method on your model).

:func:`collect_fmu` runs a data-collection design (:mod:`railgym.vehicles.collect_design`:
the paper's passive run, or the envelope of classes, speeds and actuator excitation) on the
FMU of a mapping file instead of the built-in reference; the result feeds
:func:`railgym.vehicles.memory_element.build_memory_surrogate` (``data=``) like the built-in one::

    data = collect_fmu("vehicle.yaml")
    model, selection, _ = build_memory_surrogate(data=data)

The secondary-suspension force ``F_s`` is the FMU's ``secondary_force`` output when the
mapping names one, else ``m2·ẍ2 − F_a`` with the carbody mass ``m2`` of the FMU's vehicle
description (``vehicle=``, else the mapping's ``vehicle:``; one of them is required: railgym's
own vehicle is never assumed for a user's model).

:func:`refine_fmu` is the policy-aware refinement of :func:`railgym.vehicles.collect.refine`
with the FMU as the reference; :func:`fmu_design_runs` is what ``railgym collect --fmu-map``
runs (:mod:`agents.commands.collect`): the physics of :mod:`railgym.vehicles` imports nothing
of :mod:`railgym.fmu`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from railgym.fmu.collect_vehicle import collect_vehicle_fmu
from railgym.fmu.mapping import fmu_vehicle, load_mapping, mapping_env
from railgym.fmu.runner import FMURunner
from railgym.vehicles.collect import OtherReference, refine
from railgym.vehicles.collect_design import MEMORY_SAMPLE_RATE, CollectionDesign, collect_design
from railgym.vehicles.memory_element import MEMORY_DESIGN, build_memory_surrogate, design_with
from railgym.vehicles.vehicle.params import load_whole_vehicle
from railgym.vehicles.vertical.params import load_vehicle
from surrogates.models import SurrogateModel
from surrogates.tau_search import memory_states as check_states
from surrogates.tau_search import tau_search

__all__ = [
    "build_fmu_element",
    "collect_fmu",
    "fmu_design_runs",
    "fmu_reference",
    "refine_fmu",
    "run_policy_fmu",
    "simulate_fmu",
]


def simulate_fmu(
    runner: FMURunner, z: np.ndarray, zdot: np.ndarray, force_a: np.ndarray, vehicle: Any
) -> dict[str, Any]:
    """One run of the FMU over the track ``z, zdot`` (m, m/s on ``k·dt``) with the actuator
    force ``force_a`` (N, (n,) held over each step): the record of
    :func:`railgym.vehicles.vertical.simulate` at every step (``t, x1, v1, x2, v2, a1, a2,
    F_s`` SI, ``contacts``: steps with the deflection beyond the free travel of the
    :class:`~railgym.vehicles.vertical.params.VerticalVehicle` ``vehicle``, whose ``m2`` gives
    ``F_s`` when the FMU has no ``secondary_force``)."""
    p = vehicle.kernel_params()
    n = z.size - 1
    cols = {k: j for j, k in enumerate(runner.out_keys)}
    out = np.zeros((n + 1, len(cols)))
    runner.reset()
    zz, zd = z[None, :], zdot[None, :]
    out[0] = runner.outputs_at(zz[:, 0], zd[:, 0], force_a[:1])
    for k in range(n):
        out[k + 1] = runner.advance(zz[:, k : k + 2], zd[:, k : k + 2], force_a[k : k + 1])[-1]
    x2 = out[:, cols["carbody_disp"]] if "carbody_disp" in cols else np.zeros(n + 1)
    v2 = out[:, cols["carbody_vel"]]
    a2 = out[:, cols["carbody_acc"]]
    fa = np.concatenate([force_a[:1], force_a[:n]])  # the force of the step ending at t_k
    fs = out[:, cols["secondary_force"]] if "secondary_force" in cols else p.m2 * a2 - fa
    defl = out[1:, cols["deflection"]]
    return {
        "t": np.arange(n + 1) * runner.dt,
        "x1": x2 + out[:, cols["deflection"]],
        "v1": v2 + out[:, cols["deflection_rate"]],
        "x2": x2,
        "v2": v2,
        "a1": out[:, cols["bogie_acc"]],
        "a2": a2,
        "F_s": fs,
        "contacts": int(np.count_nonzero((defl > p.free_c) | (defl < -p.free_r))),
    }


def collect_fmu(
    fmu_map: str | Path,
    design: str | CollectionDesign = "paper",
    fmu: str | Path | None = None,
    vehicle: Any = None,
    dt: float | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """:func:`~railgym.vehicles.collect_design.collect_design` of ``design`` on the FMU of
    the mapping file ``fmu_map`` (``fmu``: the FMU file, default the mapping's ``fmu:``),
    stepped at ``dt`` (s; default 1 ms, or a whole vehicle's mapping's ``step:``);
    ``vehicle`` (default the mapping's ``vehicle:``, :func:`fmu_vehicle`) gives ``m2`` when
    the FMU has no ``secondary_force``, and the free travel of the contact counts.
    ``progress(i, total)`` after each case of the design.

    An ``env: vehicle`` mapping (the whole vehicle, ``vehicle`` its whole-vehicle file) is
    collected by :func:`railgym.fmu.collect_vehicle.collect_vehicle_fmu`: one run per bogie."""
    vehicle = fmu_vehicle(fmu_map, vehicle)
    if mapping_env(fmu_map) == "vehicle":
        return collect_vehicle_fmu(fmu_map, design, fmu, vehicle, dt, progress)
    veh = load_vehicle(vehicle)
    mapping = load_mapping(fmu_map, fmu, "vertical")
    runner = FMURunner(mapping, 1e-3 if dt is None else dt, 1)
    try:
        return collect_design(
            design,
            veh,
            dt=runner.dt,
            progress=progress,
            run=lambda z, zdot, step, fa: simulate_fmu(runner, z, zdot, fa, veh),
        )
    finally:
        runner.close()


def run_policy_fmu(
    runner: FMURunner,
    vehicle: Any,
    z: np.ndarray,
    zdot: np.ndarray,
    law: Any,
    n_sub: int,
) -> dict[str, Any]:
    """A closed-loop run of the FMU as :func:`railgym.vehicles.collect.refine` records the
    built-in reference: ``law(raw)`` (raw observation ``[x1, v1, x2, v2, ẍ1, ẍ2, z, ż]``, SI)
    gives the actuator force (N) every ``n_sub`` steps; recorded at every step ``t, delta,
    delta_dot, force`` (F_s), per control step ``a2``."""
    m2 = vehicle.kernel_params().m2
    cols = {k: j for j, k in enumerate(runner.out_keys)}
    n = (z.size - 1) // n_sub * n_sub
    rec = np.full((n + 1, 4), np.nan)
    rec[0] = 0.0
    runner.reset()
    last = np.zeros(len(cols))
    diverged = False
    for k in range(0, n, n_sub):
        x2 = last[cols["carbody_disp"]] if "carbody_disp" in cols else 0.0
        v2 = last[cols["carbody_vel"]]
        raw = np.array(
            [
                x2 + last[cols["deflection"]],
                v2 + last[cols["deflection_rate"]],
                x2,
                v2,
                last[cols["bogie_acc"]],
                last[cols["carbody_acc"]],
                z[k],
                zdot[k],
            ]
        )
        fa = float(law(raw))
        y = runner.advance(z[None, k : k + n_sub + 1], zdot[None, k : k + n_sub + 1], [fa])
        if not np.all(np.isfinite(y)):
            diverged = True
            break
        a2 = y[:, cols["carbody_acc"]]
        fs = y[:, cols["secondary_force"]] if "secondary_force" in cols else m2 * a2 - fa
        rec[k + 1 : k + n_sub + 1] = np.column_stack(
            [y[:, cols["deflection"]], y[:, cols["deflection_rate"]], fs, a2]
        )
        last = y[-1]
    return {
        "t": np.arange(n + 1) * runner.dt,
        "delta": rec[:, 0],
        "delta_dot": rec[:, 1],
        "force": rec[:, 2],
        "a2": rec[n_sub::n_sub, 3],
        "ood": 0,
        "diverged": diverged,
    }


def fmu_reference(fmu_map: str | Path, fmu: str | Path | None, vehicle: Any) -> OtherReference:
    """The FMU of the mapping file ``fmu_map`` as the reference of
    :func:`railgym.vehicles.collect.refine`: its design runs (:func:`collect_fmu`) and its
    closed-loop runs (:func:`run_policy_fmu`)."""
    return OtherReference(
        collect=lambda design: collect_fmu(fmu_map, design, fmu, vehicle),
        runs=lambda veh, law, dt, n_sub: _policy_runs(
            FMURunner(load_mapping(fmu_map, fmu, "vertical"), dt, n_sub), veh, law, n_sub
        ),
    )


def _policy_runs(
    runner: FMURunner, vehicle: Any, law: Any, n_sub: int
) -> Callable[[np.ndarray, np.ndarray], dict[str, Any]]:
    """``(z, ż) → run`` of :func:`run_policy_fmu` on ``runner``."""
    return lambda z, zdot: run_policy_fmu(runner, vehicle, z, zdot, law, n_sub)


def refine_fmu(
    model: SurrogateModel,
    policy: Any,
    rounds: int = 3,
    *,
    fmu_map: str | Path | None,
    fmu: str | Path | None = None,
    vehicle: Any = None,
    **kwargs: Any,
) -> tuple[SurrogateModel, list[dict[str, Any]]]:
    """:func:`railgym.vehicles.collect.refine` with the FMU of the mapping file ``fmu_map``
    as the reference (``fmu``: the FMU file, default the mapping's ``fmu:``; ``vehicle``:
    default the mapping's ``vehicle:``); ``kwargs`` are ``refine``'s."""
    if fmu_map is None:
        raise ValueError("fmu: an FMU reference needs its mapping file fmu_map")
    vehicle = fmu_vehicle(fmu_map, vehicle)
    other = fmu_reference(fmu_map, fmu, vehicle)
    return refine(model, policy, rounds, vehicle=vehicle, other=other, **kwargs)


def fmu_design_runs(
    fmu_map: str,
    fmu: str | None,
    vehicle: Any,
    design: str | CollectionDesign,
    progress: Callable[[int, int], None] | None,
) -> tuple[Any, dict[str, Any]]:
    """The vehicle of ``railgym collect --fmu-map`` (``--vehicle``, else the mapping's) and
    the runs of ``design`` on the FMU (:func:`collect_fmu`). For an ``env: vehicle`` mapping
    the vehicle is the whole vehicle's one-bogie suspension (its bump stops are the
    element's known physics), named after the whole-vehicle file."""
    vehicle = fmu_vehicle(fmu_map, vehicle, "--vehicle ")
    if mapping_env(fmu_map) == "vehicle":
        whole = load_whole_vehicle(vehicle)
        data = collect_vehicle_fmu(fmu_map, design, fmu, whole, progress=progress)
        return dataclasses.replace(whole.suspension, name=whole.name), data
    return vehicle, collect_fmu(fmu_map, design, fmu, vehicle, progress=progress)


def build_fmu_element(
    fmu_map: str | Path,
    *,
    fmu: str | Path | None = None,
    vehicle: Any = None,
    tau: Any = None,
    memory_states: int | None = None,
    **kwargs: Any,
) -> tuple[SurrogateModel, Any, dict[str, Any]]:
    """``railgym collect --fmu-map`` in Python: the envelope design's runs on the FMU
    (:func:`collect_fmu`, at the memory element's sample rate) and
    :func:`~railgym.vehicles.memory_element.build_memory_surrogate` on them, ``tau`` (the
    ``--tau`` values: ``None``, one value, ``(lo, hi)`` or three or more values, s) and
    ``memory_states`` (0, 1, ``None``: from the data) checked as the flags are; ``kwargs``
    go to ``build_memory_surrogate`` (``degrees``, ``seed``, ``progress``, ``coupled``,
    ``product``, ...; ``product`` defaults to ``False`` for an ``env: vehicle`` mapping,
    whose kernels take the ``"maxwell"`` form). Returns ``(model, selection, data)``."""
    search, states = tau_search(tau, "tau"), check_states(memory_states, "memory_states")
    if mapping_env(fmu_map) == "vehicle":
        kwargs.setdefault("product", False)
    vehicle = fmu_vehicle(fmu_map, vehicle)
    data = collect_fmu(fmu_map, design_with(MEMORY_DESIGN, None, MEMORY_SAMPLE_RATE), fmu, vehicle)
    return build_memory_surrogate(
        data=data, vehicle=vehicle, tau=search, memory_states=states, **kwargs
    )


if __name__ == "__main__":
    from surrogates.cli_flags import moved_command

    raise SystemExit(moved_command("railgym.fmu.collect", "railgym collect"))
