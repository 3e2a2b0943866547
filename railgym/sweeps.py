"""Vertical-model sweeps as independent tasks for :func:`railgym.parallel.run_tasks`.

Each function takes ``workers`` and ``address`` and passes them to
:func:`~railgym.parallel.run_tasks`, so a command gains ``--workers N --address ADDR`` with one
line: ``collect_sweep(design, ..., workers=args.workers, address=args.address)``. Every task
carries its own seed; the results are the same for any number of workers.

* :func:`collect_sweep` — the training-data collection of a
  :class:`~railgym.vehicles.collect_design.CollectionDesign`, one task per run (passive or
  excited); returns what :func:`~railgym.vehicles.collect_design.collect_design` returns.
* :func:`vertical_sweep` — comfort indices of recorded runs over track classes × speeds ×
  seeds, the seeds spawned from one root seed.

Controller evaluations (they need the Gymnasium envs) are in :mod:`agents.evaluation.sweeps`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from railgym import _checks as val
from railgym.comfort import weighted_rms
from railgym.parallel import run_tasks, spawn_seeds
from railgym.track import class_speed, track_time_input
from railgym.vehicles.collect_design import (
    CollectionDesign,
    band_limited_force,
    design_named,
    run_record,
)
from railgym.vehicles.vertical.kernels import DEFAULT_DT, VARIANTS
from railgym.vehicles.vertical.params import load_vehicle
from railgym.vehicles.vertical.simulate import simulate


class CollectionTask(NamedTuple):
    """One run of a collection design: ``case`` is the index of its track in
    ``design.cases()`` (it seeds the actuator signal of the excited run)."""

    case: int
    track_class: int
    speed: float  #: m/s
    seed: int  #: track seed
    excited: bool
    design: CollectionDesign
    vehicle: str
    variant: str
    dt: float  #: s
    every: int  #: integration steps per training sample


def collection_tasks(
    design: str | CollectionDesign = "envelope",
    vehicle: str = "manchester",
    variant: str = "dynamic",
    dt: float | None = None,
) -> list[CollectionTask]:
    """The runs of ``design`` in the order of ``collect_design``: per track case, the passive
    run, then the excited one (when ``design.f_max > 0``)."""
    design = design_named(design)
    variant = val.choice(variant, "variant", VARIANTS)
    dt = DEFAULT_DT[variant] if dt is None else val.positive(dt, "dt")
    every = round(1.0 / (design.sample_rate * dt))
    if every < 1 or not np.isclose(every * dt * design.sample_rate, 1.0):
        raise ValueError(
            f"design.sample_rate {design.sample_rate} Hz is not a whole number of steps of {dt} s"
        )
    excitations = (False, True) if design.f_max > 0 else (False,)
    return [
        CollectionTask(case, c, v, s, excited, design, vehicle, variant, dt, every)
        for case, (c, v, s) in enumerate(design.cases())
        for excited in excitations
    ]


def collection_run(task: CollectionTask) -> dict[str, Any]:
    """One run of :func:`collection_tasks`: the run dict of ``collect_design``."""
    d = task.design
    _, z, zdot = track_time_input(task.track_class, task.speed, d.duration, task.dt, task.seed)
    n = z.size - 1
    fa = (
        band_limited_force(n, task.dt, d.band, d.f_max, [task.seed, task.case])
        if task.excited
        else np.zeros(n)
    )
    rec = simulate(task.variant, load_vehicle(task.vehicle), z, zdot, task.dt, force_a=fa)
    case = (task.track_class, task.speed, task.seed)
    return run_record(case, task.excited, rec, fa, task.every)


def collect_sweep(
    design: str | CollectionDesign = "envelope",
    vehicle: str = "manchester",
    variant: str = "dynamic",
    dt: float | None = None,
    workers: int = 1,
    address: str | None = None,
) -> dict[str, Any]:
    """``collect_design`` with its runs as parallel tasks (same arguments and result, plus
    ``workers`` and ``address`` of :func:`~railgym.parallel.run_tasks`)."""
    tasks = collection_tasks(design, vehicle, variant, dt)
    runs = run_tasks(collection_run, tasks, workers, address)
    U = np.concatenate([np.column_stack([r["delta"], r["delta_dot"]])[r["rows"]] for r in runs])
    V = np.concatenate([r["force"][r["rows"]] for r in runs])
    return {"runs": runs, "U": U, "V": V, "design": tasks[0].design}


class VerticalRunTask(NamedTuple):
    """One recorded run of the vertical model on a seeded FRA track."""

    track_class: int
    speed: float  #: m/s
    seed: int  #: track seed
    duration: float  #: s
    variant: str
    vehicle: str
    dt: float  #: s


def vertical_run(task: VerticalRunTask) -> dict[str, Any]:
    """Comfort indices of one passive run: ``rms_acc`` and the ISO 2631 Wk-weighted ``a_w``
    of the carbody acceleration (m/s², first 2 s discarded from ``a_w``), ``max_defl``
    (largest |δ|, m), ``contacts`` (substeps in bump-stop contact), with the task's fields."""
    _, z, zdot = track_time_input(task.track_class, task.speed, task.duration, task.dt, task.seed)
    rec = simulate(task.variant, load_vehicle(task.vehicle), z, zdot, task.dt)
    a2 = rec["a2"]
    return {
        **task._asdict(),
        "rms_acc": float(np.sqrt(np.mean(a2**2))),
        "a_w": weighted_rms(a2, 1.0 / task.dt, discard=2.0, lowpass=False),
        "max_defl": float(np.max(np.abs(rec["x1"] - rec["x2"]))),
        "contacts": rec["contacts"],
        "diverged": rec["diverged"],
    }


def vertical_tasks(
    track_classes: Sequence[int] = (4, 5, 6),
    speed_factors: Sequence[float] = (1.0,),
    n_seeds: int = 4,
    root_seed: int = 0,
    duration: float = 20.0,
    variant: str = "dynamic",
    vehicle: str = "manchester",
    dt: float | None = None,
) -> list[VerticalRunTask]:
    """Tasks over classes × speed factors (of each class's maximum speed) × ``n_seeds`` track
    seeds; the seeds are :func:`~railgym.parallel.spawn_seeds` of ``root_seed``, the same for
    every class and speed (common random numbers)."""
    variant = val.choice(variant, "variant", VARIANTS)
    dt = DEFAULT_DT[variant] if dt is None else val.positive(dt, "dt")
    duration = val.positive(duration, "duration")
    classes = [val.integer(c, "track_classes", min=1, max=6) for c in track_classes]
    factors = [val.positive(f, "speed_factors") for f in speed_factors]
    seeds = spawn_seeds(root_seed, n_seeds)
    return [
        VerticalRunTask(c, f * class_speed(c), s, duration, variant, vehicle, dt)
        for c in classes
        for f in factors
        for s in seeds
    ]


def vertical_sweep(
    track_classes: Sequence[int] = (4, 5, 6),
    speed_factors: Sequence[float] = (1.0,),
    n_seeds: int = 4,
    root_seed: int = 0,
    duration: float = 20.0,
    variant: str = "dynamic",
    vehicle: str = "manchester",
    dt: float | None = None,
    workers: int = 1,
    address: str | None = None,
) -> list[dict[str, Any]]:
    """:func:`vertical_run` over :func:`vertical_tasks` (same arguments), one dict per run in
    task order."""
    tasks = vertical_tasks(
        track_classes, speed_factors, n_seeds, root_seed, duration, variant, vehicle, dt
    )
    return run_tasks(vertical_run, tasks, workers, address)


__all__ = [
    "CollectionTask",
    "VerticalRunTask",
    "collect_sweep",
    "collection_run",
    "collection_tasks",
    "vertical_run",
    "vertical_sweep",
    "vertical_tasks",
]
