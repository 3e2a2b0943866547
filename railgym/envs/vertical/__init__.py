"""``railgym/VerticalSuspension-v1``: the env (:mod:`.env`), its batch of compiled kernels
(:mod:`.batch`), its FMU batch (:mod:`.fmu_batch`) and its frame (:mod:`.render`).

The package re-exports the env's public names, and those of the track shell
(:mod:`railgym.envs.track_shell`) that ``railgym.envs.vertical`` held before it was a package.
"""

from railgym.envs import track_shell
from railgym.envs.track_shell import *  # noqa: F403
from railgym.envs.vertical import env
from railgym.envs.vertical.env import *  # noqa: F403

__all__ = list(dict.fromkeys([*track_shell.__all__, *env.__all__]))
