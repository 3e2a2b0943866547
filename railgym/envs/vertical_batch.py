"""Deprecated path of :mod:`railgym.envs.vertical.batch` (the batch limits and the reward
weighting: :mod:`railgym.envs.track_shell`); kept for one version."""

from railgym.envs.compiled import (
    DIVERGENCE_PENALTY,
    OBS_LIMIT,
)
from railgym.envs.track_shell import (
    MAX_NUM_ENVS,
    TRACK_BYTES,
    reward_sections,
)
from railgym.envs.vertical.batch import (
    ACC_REF,
    INFO_COLUMN,
    INFO_KEYS,
    REWARD_TERMS,
    SEMI_ACTIVE_INFO_KEYS,
    Counters,
    StepCfg,
    StepResult,
    VerticalBatch,
    control_step,
    post_step,
)

__all__ = [
    "ACC_REF",
    "Counters",
    "DIVERGENCE_PENALTY",
    "INFO_COLUMN",
    "INFO_KEYS",
    "MAX_NUM_ENVS",
    "OBS_LIMIT",
    "REWARD_TERMS",
    "SEMI_ACTIVE_INFO_KEYS",
    "StepCfg",
    "StepResult",
    "TRACK_BYTES",
    "VerticalBatch",
    "control_step",
    "post_step",
    "reward_sections",
]
