"""railgym — Gymnasium environments for railway vehicle dynamics with surrogate elements.

Importing the package registers the environments: ``gym.make("railgym/VerticalSuspension-v1")``.
The physics (:mod:`railgym.track`, :mod:`railgym.vehicles`) does not use gymnasium.
"""

from railgym.registration import register_envs

__version__ = "0.3.0"

register_envs()
