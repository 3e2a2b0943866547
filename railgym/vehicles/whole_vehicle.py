"""Deprecated path of :mod:`railgym.vehicles.vehicle.params`; kept for one version."""

from railgym.vehicles.vehicle.params import (
    BETA_L,
    FLOOR_POINTS,
    WholeVehicle,
    load_whole_vehicle,
    mode_shape,
)

__all__ = [
    "BETA_L",
    "FLOOR_POINTS",
    "WholeVehicle",
    "load_whole_vehicle",
    "mode_shape",
]
