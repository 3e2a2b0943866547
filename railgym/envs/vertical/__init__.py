"""``railgym/VerticalSuspension-v1``: the env (:mod:`.env`), its batch of compiled kernels
(:mod:`.batch`), its FMU batch (:mod:`.fmu_batch`) and its frame (:mod:`.render`).

The package re-exports the env's public names, and those of the track shell
(:mod:`railgym.envs.track_shell`) that ``railgym.envs.vertical`` held before it was a package.
"""

from railgym.envs.track_shell import (
    ELEMENT_OUTPUT_UNIT,
    ELEMENT_UNITS,
    TrackEnvShell,
    TrackVectorShell,
    check_element_vehicle,
    element_arrays,
)
from railgym.envs.vertical.env import (
    ACC_REF,
    ACC_WEIGHTINGS,
    ACTUATORS,
    BACKENDS,
    DAMPER_CHANNEL,
    DEFAULT_WEIGHTS,
    ENV_BACKENDS,
    INFO_KEYS,
    LIMITS,
    OBSERVATIONS,
    VerticalBatch,
    VerticalParams,
    VerticalSuspensionEnv,
    VerticalSuspensionEnvV0,
    VerticalSuspensionEnvV2,
    VerticalSuspensionVectorEnv,
    VerticalSuspensionVectorEnvV0,
    VerticalSuspensionVectorEnvV2,
    check_speed,
    check_speed_limit,
)

__all__ = [
    "ACC_REF",
    "ACC_WEIGHTINGS",
    "ACTUATORS",
    "BACKENDS",
    "DAMPER_CHANNEL",
    "DEFAULT_WEIGHTS",
    "ELEMENT_OUTPUT_UNIT",
    "ELEMENT_UNITS",
    "ENV_BACKENDS",
    "INFO_KEYS",
    "LIMITS",
    "OBSERVATIONS",
    "TrackEnvShell",
    "TrackVectorShell",
    "VerticalBatch",
    "VerticalParams",
    "VerticalSuspensionEnv",
    "VerticalSuspensionEnvV0",
    "VerticalSuspensionEnvV2",
    "VerticalSuspensionVectorEnv",
    "VerticalSuspensionVectorEnvV0",
    "VerticalSuspensionVectorEnvV2",
    "check_element_vehicle",
    "check_speed",
    "check_speed_limit",
    "element_arrays",
]
