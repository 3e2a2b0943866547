"""Deprecated path of :mod:`railgym.vehicles.vehicle.lanes`; kept for one version."""

from railgym.vehicles.vehicle.lanes import *  # noqa: F403
from railgym.vehicles.vehicle.lanes import __all__  # noqa: F401
