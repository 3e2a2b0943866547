"""Deprecated path of :mod:`railgym.envs.vehicle.batch`; kept for one version."""

from railgym.envs.compiled import (
    DIVERGENCE_PENALTY,
)
from railgym.envs.vehicle.batch import (
    ACC_REF,
    INFO_COLUMNS,
    INFO_KEYS,
    INFO_LAYOUT,
    INFO_ROW,
    MIN_COMFORT_SAMPLES,
    REWARD_TERMS,
    SEMI_ACTIVE_INFO_LAYOUT,
    SEMI_ACTIVE_INFO_ROW,
    Book,
    StepCfg,
    VehicleBatch,
    book_step,
    check_band_speed,
    control_step,
    episode_comfort,
)

__all__ = [
    "ACC_REF",
    "Book",
    "DIVERGENCE_PENALTY",
    "INFO_COLUMNS",
    "INFO_KEYS",
    "INFO_LAYOUT",
    "INFO_ROW",
    "MIN_COMFORT_SAMPLES",
    "REWARD_TERMS",
    "SEMI_ACTIVE_INFO_LAYOUT",
    "SEMI_ACTIVE_INFO_ROW",
    "StepCfg",
    "VehicleBatch",
    "book_step",
    "check_band_speed",
    "control_step",
    "episode_comfort",
]
