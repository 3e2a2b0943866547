"""Deprecated path of :mod:`railgym.vehicles.vehicle.refine`; kept for one version."""

from railgym.vehicles.vehicle.refine import *  # noqa: F403
from railgym.vehicles.vehicle.refine import __all__  # noqa: F401
