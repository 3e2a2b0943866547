"""Deprecated path of :mod:`railgym.envs.vehicle.render`; kept for one version."""

from railgym.envs.vehicle.render import (
    render_vehicle,
)

__all__ = [
    "render_vehicle",
]
