"""railgym — Gymnasium environments for railway vehicle dynamics with surrogate elements.

Importing the package registers the environments: ``gym.make("railgym/VerticalSuspension-v1")``.
The physics (:mod:`railgym.track`, :mod:`railgym.vehicles`) does not use gymnasium.
"""

from importlib.metadata import PackageNotFoundError, version

from railgym.registration import register_envs

try:
    #: the version of the installed distribution ``railgym`` (``pyproject.toml``)
    __version__ = version("railgym")
except PackageNotFoundError:  # a source tree on ``sys.path``, not installed
    __version__ = "0+unknown"

register_envs()
