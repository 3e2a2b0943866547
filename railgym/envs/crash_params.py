"""Deprecated path of :mod:`railgym.envs.crash.params`; kept for one version."""

from railgym.envs.crash.params import *  # noqa: F403
from railgym.envs.crash.params import __all__  # noqa: F401
