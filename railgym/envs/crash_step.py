"""Deprecated path of :mod:`railgym.envs.crash.step`; kept for one version."""

from railgym.envs.crash.step import *  # noqa: F403
from railgym.envs.crash.step import __all__  # noqa: F401
