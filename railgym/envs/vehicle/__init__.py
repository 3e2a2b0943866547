"""``railgym/VerticalVehicle-v1``: the env (:mod:`.env`), its batch of compiled kernels
(:mod:`.batch`), its FMU batch (:mod:`.fmu_batch`) and its frame (:mod:`.render`).

The package re-exports the env's public names (``railgym.envs.vehicle`` was one module).
"""

from railgym.envs.vehicle.env import (
    ACC_REF,
    ACC_WEIGHTINGS,
    DEFAULT_WEIGHTS,
    DIVERGENCE_PENALTY,
    INFO_KEYS,
    LIMITS,
    MIN_COMFORT_SAMPLES,
    OBSERVATIONS,
    PREVIEW_SCALE,
    PREVIEW_SPACING,
    REWARD_TERMS,
    SIZING_SPEED,
    VehicleParams,
    VerticalVehicleEnv,
    VerticalVehicleEnvV0,
    VerticalVehicleEnvV2,
    VerticalVehicleVectorEnv,
    VerticalVehicleVectorEnvV0,
    VerticalVehicleVectorEnvV2,
    episode_comfort,
    preview_points,
)

__all__ = [
    "ACC_REF",
    "ACC_WEIGHTINGS",
    "DEFAULT_WEIGHTS",
    "DIVERGENCE_PENALTY",
    "INFO_KEYS",
    "LIMITS",
    "MIN_COMFORT_SAMPLES",
    "OBSERVATIONS",
    "PREVIEW_SCALE",
    "PREVIEW_SPACING",
    "REWARD_TERMS",
    "SIZING_SPEED",
    "VehicleParams",
    "VerticalVehicleEnv",
    "VerticalVehicleEnvV0",
    "VerticalVehicleEnvV2",
    "VerticalVehicleVectorEnv",
    "VerticalVehicleVectorEnvV0",
    "VerticalVehicleVectorEnvV2",
    "episode_comfort",
    "preview_points",
]
