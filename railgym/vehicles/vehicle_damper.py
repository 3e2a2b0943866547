"""Deprecated path of :mod:`railgym.vehicles.vehicle.damper`; kept for one version."""

from railgym.vehicles.vehicle.damper import *  # noqa: F403
from railgym.vehicles.vehicle.damper import __all__  # noqa: F401
