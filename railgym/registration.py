"""Registration of the railgym environments with Gymnasium (``gym.make("railgym/...")``)."""

from __future__ import annotations

import re
import warnings

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


def newest(env_id: str) -> str:
    """The id of the newest registered version of the env of ``env_id`` (an id or a family,
    ``railgym/VerticalSuspension-v1`` or ``railgym/VerticalSuspension``); ValueError for an
    env that railgym does not register."""
    family = env_family(env_id) if re.search(r"-v\d+$", env_id) else env_id
    versions = [int(e.rsplit("-v", 1)[1]) for e in ENVS if env_family(e) == family]
    if not versions:
        raise ValueError(f"{env_id} is no railgym env; railgym registers {', '.join(ENVS)}")
    return f"{family}-v{max(versions)}"


class _SeenOutdated:
    """The message pattern of a warnings filter that lets gymnasium's notice "The environment
    railgym/X-vN is out of date" through the first time for each id and matches it (so that
    the filter's ``ignore`` drops it) every later time. Gymnasium's own ``once`` filter repeats
    the notice whenever any filter changes between two ``gym.make`` calls (Python then clears
    its once-registry; a lazy import of scipy does so on the first make)."""

    pattern = re.compile(r".*The environment (railgym/\S+) is out of date")

    def __init__(self) -> None:
        self.seen: set[str] = set()

    def match(self, text: str) -> bool:
        m = self.pattern.match(text)
        if m is None:
            return False
        if m.group(1) in self.seen:
            return True
        self.seen.add(m.group(1))
        return False


def _notice_once() -> None:
    """Gymnasium's out-of-date notice of a railgym id at most once per process (a filter in
    front of gymnasium's; a filter the user adds later still goes first)."""
    if not any(isinstance(f[1], _SeenOutdated) for f in warnings.filters):
        entry = ("ignore", _SeenOutdated(), DeprecationWarning, None, 0)
        warnings.filters.insert(0, entry)  # type: ignore[attr-defined]  # a list at run time


def register_envs() -> None:
    """Register every railgym environment once (idempotent); gymnasium's notice that an id is
    out of date is shown at most once per id and process."""
    _notice_once()
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
