"""Deprecated path of :mod:`railgym.envs.crash.batch`; kept for one version."""

from railgym.envs.crash.batch import *  # noqa: F403
from railgym.envs.crash.batch import __all__  # noqa: F401
