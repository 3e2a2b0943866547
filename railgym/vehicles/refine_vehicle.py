"""Deprecated path of :mod:`railgym.vehicles.vehicle.refine`; kept for one version."""

from railgym.vehicles.vehicle.refine import (
    RAW_VEHICLE_OBSERVATION,
    refine_vehicle,
    run_vehicle_policy,
)

__all__ = [
    "RAW_VEHICLE_OBSERVATION",
    "refine_vehicle",
    "run_vehicle_policy",
]
