"""Registration of the railgym environments with Gymnasium (``gym.make("railgym/...")``)."""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

ENVS = {
    "railgym/VerticalSuspension-v0": (
        "railgym.envs.vertical:VerticalSuspensionEnv",
        "railgym.envs.vertical:VerticalSuspensionVectorEnv",
    ),
    "railgym/VerticalVehicle-v0": (
        "railgym.envs.vehicle:VerticalVehicleEnv",
        "railgym.envs.vehicle:VerticalVehicleVectorEnv",
    ),
    "railgym/TrainCrash-v0": (
        "railgym.envs.crash:TrainCrashEnv",
        "railgym.envs.crash:TrainCrashVectorEnv",
    ),
}


def register_envs() -> None:
    """Register every railgym environment once (idempotent)."""
    for env_id, (entry, vector_entry) in ENVS.items():
        if env_id not in registry:
            register(id=env_id, entry_point=entry, vector_entry_point=vector_entry)
