"""The force each bogie's suspension puts on the carbody, from the carbody's floor
accelerations: the carbody equations of :mod:`railgym.vehicles.vehicle.model` inverted.

The env reports the floor acceleration over the front bogie, at the centre and over the rear
bogie (:data:`~railgym.vehicles.vehicle.params.FLOOR_POINTS`)::

    A_f = z̈_c + a·θ̈_c + φ(a)·q̈      A_c = z̈_c + q̈      A_r = z̈_c − a·θ̈_c + φ(a)·q̈

Three points give the three carbody accelerations (the centre separates bounce from
bending: ``φ(a) ≠ 1``), and bounce and pitch give the two bogie forces::

    θ̈_c = (A_f − A_r)/(2a)      q̈ = (A_c − S)/(1 − φ(a))      z̈_c = A_c − q̈,  S = (A_f + A_r)/2
    F_0 + F_1 = m_c·z̈_c           F_0 − F_1 = J_c·θ̈_c / a

``F_i`` is the secondary plus actuator force at bogie ``i`` (0 front), upward on the carbody.
The bending equation ``m_q·(q̈ + 2ζω_b·q̇ + ω_b²·q) = φ(a)·(F_0 + F_1)`` is not needed (it
would need the modal state ``q, q̇``), so the modal mass and damping do not enter.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from railgym import _checks as val
from railgym.vehicles.vehicle.model import kernel_params
from railgym.vehicles.vehicle.params import WholeVehicle

__all__ = ["body_accelerations", "bogie_forces"]


def body_accelerations(acc_floor: Any, vehicle: WholeVehicle) -> np.ndarray:
    """Carbody bounce (m/s²), pitch (rad/s²) and bending (m/s², centre deflection)
    accelerations ``(..., 3)`` from the floor accelerations ``acc_floor`` ``(..., 3)``
    front, centre, rear (m/s²) of ``vehicle``."""
    p = kernel_params(vehicle)
    if p.a <= 0.0:
        raise val.FieldError(
            "whole_vehicle.bogie_semi_spacing",
            f"vehicle {vehicle.name}: the bogie forces need the bogies apart "
            f"(bogie_semi_spacing > 0), got {p.a!r}",
        )
    acc = np.asarray(acc_floor, dtype=float)
    if acc.shape[-1:] != (3,):
        raise ValueError(f"acc_floor must end with the 3 floor points, got shape {acc.shape}")
    front, centre, rear = acc[..., 0], acc[..., 1], acc[..., 2]
    pitch = (front - rear) / (2.0 * p.a)
    bend = (centre - 0.5 * (front + rear)) / (1.0 - p.phi_a)
    return np.stack([centre - bend, pitch, bend], axis=-1)


def bogie_forces(acc_floor: Any, vehicle: WholeVehicle) -> np.ndarray:
    """Force of each bogie's suspension on the carbody ``(..., 2)`` (N, front first, upward:
    secondary plus actuator) from the floor accelerations ``acc_floor`` ``(..., 3)`` front,
    centre, rear (m/s²) of ``vehicle`` (module docstring: the equations)."""
    body = body_accelerations(acc_floor, vehicle)
    total = vehicle.carbody_mass * body[..., 0]
    diff = vehicle.carbody_pitch_inertia * body[..., 1] / vehicle.bogie_semi_spacing
    return np.stack([0.5 * (total + diff), 0.5 * (total - diff)], axis=-1)
