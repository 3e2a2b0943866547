"""Deprecated path of :mod:`railgym.vehicles.vehicle.params`; kept for one version."""

from railgym.vehicles.vehicle.params import *  # noqa: F403
from railgym.vehicles.vehicle.params import __all__  # noqa: F401
