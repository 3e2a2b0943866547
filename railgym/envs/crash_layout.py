"""Deprecated path of :mod:`railgym.envs.crash.layout`; kept for one version."""

from railgym.envs.crash.layout import *  # noqa: F403
from railgym.envs.crash.layout import __all__  # noqa: F401
