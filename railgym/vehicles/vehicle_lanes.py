"""Deprecated path of :mod:`railgym.vehicles.vehicle.lanes`; kept for one version."""

from railgym.vehicles.vehicle.lanes import (
    LANES,
    LANES_MIN,
    hermite,
    lanes_block,
)

__all__ = [
    "LANES",
    "LANES_MIN",
    "hermite",
    "lanes_block",
]
