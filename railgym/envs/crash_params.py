"""Deprecated path of :mod:`railgym.envs.crash.params`; kept for one version."""

from railgym.envs.crash.params import (
    A_SCALE_G,
    BACKENDS,
    DEFAULT_WEIGHTS,
    MAX_CONTROL_DT,
    MAX_DURATION,
    MAX_WEIGHT,
    MIN_CONTROL_DT,
    X_SCALE,
    CrashParams,
    nominal_force,
)

__all__ = [
    "A_SCALE_G",
    "BACKENDS",
    "CrashParams",
    "DEFAULT_WEIGHTS",
    "MAX_CONTROL_DT",
    "MAX_DURATION",
    "MAX_WEIGHT",
    "MIN_CONTROL_DT",
    "X_SCALE",
    "nominal_force",
]
