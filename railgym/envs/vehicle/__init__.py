"""``railgym/VerticalVehicle-v1``: the env (:mod:`.env`), its batch of compiled kernels
(:mod:`.batch`), its FMU batch (:mod:`.fmu_batch`) and its frame (:mod:`.render`).

The package re-exports the env's public names (``railgym.envs.vehicle`` was one module).
"""

from railgym.envs.vehicle.env import *  # noqa: F403
from railgym.envs.vehicle.env import __all__  # noqa: F401
