"""``railgym/TrainCrash-v1``: the env (:mod:`.env`), its declared arguments (:mod:`.params`),
its batch (:mod:`.batch`) with the compiled step (:mod:`.step`) and the buffer layout
(:mod:`.layout`), and its frame (:mod:`.render`).

The package re-exports the env's public names (``railgym.envs.crash`` was one module).
"""

from railgym.envs.crash.env import (
    BACKENDS,
    DEFAULT_WEIGHTS,
    INFO_FIELDS,
    MAX_NUM_ENVS,
    OPTIONS,
    REWARD_TERMS,
    CrashBatch,
    CrashParams,
    TrainCrashEnv,
    TrainCrashEnvV0,
    TrainCrashVectorEnv,
    TrainCrashVectorEnvV0,
    default_surrogate,
    env_surrogate,
    make_model,
    nominal_force,
)

__all__ = [
    "BACKENDS",
    "CrashBatch",
    "CrashParams",
    "DEFAULT_WEIGHTS",
    "INFO_FIELDS",
    "MAX_NUM_ENVS",
    "OPTIONS",
    "REWARD_TERMS",
    "TrainCrashEnv",
    "TrainCrashEnvV0",
    "TrainCrashVectorEnv",
    "TrainCrashVectorEnvV0",
    "default_surrogate",
    "env_surrogate",
    "make_model",
    "nominal_force",
]
