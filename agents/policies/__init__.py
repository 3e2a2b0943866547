"""The policies room: trained policies as files — loading one by name or path
(:mod:`~agents.policies.loading`), the manifest and weights-only reading
(:mod:`~agents.policies.policy_io`, :mod:`~agents.policies.policy_zip`), the pretrained ones
(:mod:`~agents.policies.pretrained`) and the export as an FMU or ONNX
(:mod:`~agents.policies.policy_fmu`, :mod:`~agents.policies.residual_export`).

The names of the former module ``agents.policies`` are re-exported here; those that run
policies (:mod:`agents.evaluation.runs`) on first use.
"""

from typing import Any

from agents._args import MAX_EPISODES
from agents.controllers.registry import (
    CONTROLLERS,
    CONTROLLERS_OF,
    CRASH_ID,
    ENV_ID,
    VEHICLE_CONTROLLERS,
    VEHICLE_ID,
)
from agents.policies.loading import load_policy, trained_actuator
from agents.policies.policy_io import RLLIB_MODULE_PATH

#: names of the former module that :mod:`agents.evaluation.runs` defines
RUNS = ("VEHICLE_COMFORT", "VehicleTask", "evaluate_vehicle", "run_policy", "run_vehicle_policy")

#: the public names of the former module
__all__ = [
    "CONTROLLERS",
    "CONTROLLERS_OF",
    "CRASH_ID",
    "ENV_ID",
    "MAX_EPISODES",
    "RLLIB_MODULE_PATH",
    "VEHICLE_CONTROLLERS",
    "VEHICLE_ID",
    "load_policy",
    "trained_actuator",
    *RUNS,
]


def __getattr__(name: str) -> Any:
    """A name of :data:`RUNS`, from :mod:`agents.evaluation.runs` (imported here on first
    use: that module loads its policies from this package)."""
    if name in RUNS:
        from agents.evaluation import runs

        return getattr(runs, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
