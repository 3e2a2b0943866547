"""Registration of the railgym environments with Gymnasium (``gym.make("railgym/...")``)."""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

ENVS = {
    # v0: the memory element of railgym 0.2; v1: the envelope-fitted one (docs: Version history)
    "railgym/VerticalSuspension-v0": (
        "railgym.envs.vertical.env:VerticalSuspensionEnvV0",
        "railgym.envs.vertical.env:VerticalSuspensionVectorEnvV0",
    ),
    "railgym/VerticalSuspension-v1": (
        "railgym.envs.vertical.env:VerticalSuspensionEnv",
        "railgym.envs.vertical.env:VerticalSuspensionVectorEnv",
    ),
    # v2: the same element evaluated by Hermite tables inside its box (docs: Version history)
    "railgym/VerticalSuspension-v2": (
        "railgym.envs.vertical.env:VerticalSuspensionEnvV2",
        "railgym.envs.vertical.env:VerticalSuspensionVectorEnvV2",
    ),
    # v3: the track streamed inside the compiled step (docs: Version history)
    "railgym/VerticalSuspension-v3": (
        "railgym.envs.vertical.env:VerticalSuspensionEnvV3",
        "railgym.envs.vertical.env:VerticalSuspensionVectorEnvV3",
    ),
    # v0: the static packaged element by default; v1: the memory element (docs: Version history)
    "railgym/VerticalVehicle-v0": (
        "railgym.envs.vehicle.env:VerticalVehicleEnvV0",
        "railgym.envs.vehicle.env:VerticalVehicleVectorEnvV0",
    ),
    "railgym/VerticalVehicle-v1": (
        "railgym.envs.vehicle.env:VerticalVehicleEnv",
        "railgym.envs.vehicle.env:VerticalVehicleVectorEnv",
    ),
    # v2: the same element evaluated by Hermite tables inside its box (docs: Version history)
    "railgym/VerticalVehicle-v2": (
        "railgym.envs.vehicle.env:VerticalVehicleEnvV2",
        "railgym.envs.vehicle.env:VerticalVehicleVectorEnvV2",
    ),
    # v3: the track streamed, the comfort figures online (docs: Version history)
    "railgym/VerticalVehicle-v3": (
        "railgym.envs.vehicle.env:VerticalVehicleEnvV3",
        "railgym.envs.vehicle.env:VerticalVehicleVectorEnvV3",
    ),
    # v0: one mass per car, global LPR elements; v1: elastic cars, piecewise elements
    "railgym/TrainCrash-v0": (
        "railgym.envs.crash.env:TrainCrashEnvV0",
        "railgym.envs.crash.env:TrainCrashVectorEnvV0",
    ),
    "railgym/TrainCrash-v1": (
        "railgym.envs.crash.env:TrainCrashEnv",
        "railgym.envs.crash.env:TrainCrashVectorEnv",
    ),
}


def env_family(env_id: str) -> str:
    """``env_id`` without its version (``railgym/TrainCrash-v1`` → ``railgym/TrainCrash``):
    the versions of an env share its spaces and reference model, so a policy trained on one
    runs on the others."""
    return env_id.rsplit("-v", 1)[0]


def register_envs() -> None:
    """Register every railgym environment once (idempotent)."""
    for env_id, (entry, vector_entry) in ENVS.items():
        if env_id not in registry:
            # no OrderEnforcing wrapper: the envs refuse a step before reset themselves
            # (railgym.envs.base.ResetNeeded, a gymnasium ResetNeeded)
            register(
                id=env_id,
                entry_point=entry,
                vector_entry_point=vector_entry,
                order_enforce=False,
            )
