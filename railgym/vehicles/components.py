"""An element of one bench-tested component combined with the vehicle file's other ones.

The element of ``VerticalSuspension`` (and of each bogie of ``VerticalVehicle``) is the whole
secondary force of one bogie, ``F_s(δ, δ̇)`` at the deflection ``δ = x1 − x2`` (m,
compression positive) and its rate (m/s), in N, compression positive. A damper measured on
a test bench gives one part of it; the vehicle file gives the others, as the static reference
model composes them (:func:`railgym.vehicles.vertical.elements.rhs`)::

    F_s(δ, δ̇) = k2·δ·(1 + progression·δ²) + n·F_bench(δ, δ̇)   [+ bump stops, in the kernel]

with ``k2`` of the ``vehicle`` block, ``progression`` of its ``static_spring`` section (0
without one: a linear spring) and ``n`` dampers per bogie, each along the secondary
deflection (stroke = δ). The bump-stop law of the vehicle's ``bump_stop`` section is not
fitted: the element declares it as known physics and the kernel adds it. The element is
fitted in the static form (:func:`surrogates.build`) on the bench samples with the spring
added, and saved with the vehicle it was combined with (``metadata.vehicle``), so that it
runs on that vehicle only (:mod:`railgym.vehicles.element_vehicle`).

The table's columns are read with their units (``du [mm]``, ``dv [mm/s]``, ``F [kN]``, or
``--units``) and converted to SI (:func:`surrogates.tables.to_si`); units are required.

    railgym combine bench.csv --vehicle my_car.yaml --dampers 2 -o element.json
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from railgym import _checks as val
from railgym.vehicles.vertical.params import VerticalVehicle, load_vehicle
from surrogates import build, io
from surrogates.builder import BuildReport
from surrogates.models import SurrogateModel
from surrogates.tables import to_si

__all__ = ["combine_damper", "read_bench_table", "spring_force"]

#: the SI units of the bench table's stroke, velocity and force
SI_UNITS = ("m", "m/s", "N")


def spring_force(delta: Any, vehicle: VerticalVehicle) -> np.ndarray:
    """The vehicle file's secondary spring ``k2·δ·(1 + progression·δ²)`` (N) at ``delta``
    (m, compression positive)."""
    d = np.asarray(delta, dtype=float)
    progression = 0.0 if vehicle.static_spring is None else vehicle.static_spring.progression
    return vehicle.k2 * d * (1.0 + progression * d * d)


def read_bench_table(
    path: str | Path,
    columns: Sequence[str] = ("du", "dv", "F"),
    units: dict[str, str] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Stroke and velocity (n, 2) in m and m/s and force (n,) in N of one damper, from the
    CSV ``path``: its ``columns`` (stroke, velocity, force), their units from the header
    (``du [mm]``) or ``units`` (a header unit that ``units`` contradicts is an error),
    converted to SI. Raises ``ValueError`` naming the file and the column."""
    cols, header = io.read_csv_units(path, columns=list(columns))
    given = dict(header)
    for name, unit in (units or {}).items():
        if name not in columns:
            raise ValueError(f"units: {name!r} is not one of the columns {list(columns)}")
        if given.get(name, unit) != unit:
            raise ValueError(
                f"units: {name}={unit} contradicts the header of {path} ({name} [{given[name]}])"
            )
        given[name] = unit
    missing = [c for c in columns if c not in given]
    if missing:
        raise ValueError(
            f"{path}: no unit for column(s) {missing}: give them in the header ('du [mm]') or "
            "with --units (the vehicle's spring is added in SI, so the table's units must be "
            "known)"
        )
    si, si_units, _ = to_si(cols, given, str(path))
    for name, want in zip(columns, SI_UNITS, strict=True):
        if si_units[name] != want:
            raise ValueError(
                f"{path}: column {name!r} is in {given[name]!r}, which is not a unit of "
                f"{want} (stroke: length, velocity: length/time, force: force)"
            )
    u = np.column_stack([si[columns[0]], si[columns[1]]])
    return u, np.asarray(si[columns[2]], dtype=float)


def combine_damper(
    u: Any,
    force: Any,
    vehicle: Any,
    dampers: int = 2,
    m: int = 101,
    seed: int = 0,
    candidates: Sequence[Any] | None = None,
) -> tuple[SurrogateModel, BuildReport, VerticalVehicle]:
    """The element of the vehicle's secondary suspension with the bench-tested damper.

    Parameters
    ----------
    u : stroke and velocity of one damper (n, 2), m and m/s, compression positive.
    force : its force (n,), N, compression positive.
    vehicle : the vehicle (name, YAML path or :class:`VerticalVehicle`) whose spring (and
        bump stops, as known physics) the element adds.
    dampers : dampers per bogie (each along the secondary deflection).
    m, seed, candidates : as :func:`surrogates.build` (training samples, their seed, degrees).

    Returns
    -------
    model, report, vehicle
        the static element ``F_s(δ, δ̇)`` (module docstring; ``features_`` with the bump-stop
        law as known physics where the vehicle has bump stops), its build report, and the
        loaded vehicle.
    """
    veh = load_vehicle(vehicle)
    n = val.integer(dampers, "dampers", min=1, max=64)
    u = val.numeric_array(u, "u")
    if u.ndim != 2 or u.shape[1] != 2:
        raise val.FieldError("u", f"must be (n, 2): stroke and velocity, got shape {u.shape}")
    force = val.numeric_array(force, "force", shape=(u.shape[0],))
    total = spring_force(u[:, 0], veh) + n * force
    model, report = build(u, total, m=min(m, u.shape[0]), seed=seed, candidates=candidates)
    known = ["bump_stop"] if veh.bump_stop is not None else []
    model.features_ = {"form": "static", "tau": None, "known_physics": known}
    return model, report, veh


if __name__ == "__main__":
    from surrogates.cli_flags import moved_command

    raise SystemExit(moved_command("railgym.vehicles.components", "railgym combine"))
