"""Deprecated path of :mod:`railgym.envs.crash.batch`; kept for one version."""

from railgym.envs.crash.batch import (
    CrashBatch,
)

__all__ = [
    "CrashBatch",
]
