"""Deprecated path of :mod:`railgym.vehicles.vehicle.damper`; kept for one version."""

from railgym.vehicles.vehicle.damper import (
    DAMPER_COLUMNS,
    VehicleDampers,
    damper_stage,
)

__all__ = [
    "DAMPER_COLUMNS",
    "VehicleDampers",
    "damper_stage",
]
