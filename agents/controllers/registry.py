"""The controllers of every env by their ``railgym evaluate`` name, and the baselines each
command compares a policy against: one table per env, one spelling per name (hyphens).

* :data:`CONTROLLERS_OF` — env id → name → :data:`Entry` of the vertical env and the whole
  vehicle, either actuator (:func:`build_controller`); :data:`CRASH_CONTROLLERS` — those of
  ``railgym/TrainCrash`` (:func:`crash_factories`);
* :data:`BASELINES` — env id → the baselines of ``railgym benchmark`` and of the crash report
  (the crash envelope of ``railgym evaluate --envelope``), :func:`baselines_of` for a config
  (the damper's, the preview's); :data:`COMPARISON` — env id → the rows ``railgym evaluate``
  always adds.

The old spelling ``best constant`` is read as ``best-constant`` with a
:class:`DeprecationWarning` (:func:`canonical_name`).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable
from functools import partial
from typing import Any

from agents.controllers.classical import (
    LQR,
    BogieSkyhook,
    Groundhook,
    ModalSkyhook,
    Passive,
    Skyhook,
    VehicleLQR,
)
from agents.controllers.crash_baselines import (
    BEST_CONSTANT_ACTION,
    ConstantAbsorber,
    CrashPassive,
    SpeedAdaptive,
)
from agents.controllers.lqg import LQG, VehicleLQG
from agents.controllers.preview import LQGPreview, LQRPreview
from agents.controllers.semi_active_control import SEMI_ACTIVE_CONTROLLERS
from railgym import _checks as val
from railgym.registration import env_family, newest

__all__ = [
    "BASELINES",
    "COMPARISON",
    "CONTROLLERS",
    "CONTROLLERS_OF",
    "CRASH_CONTROLLERS",
    "CRASH_ID",
    "ENV_ID",
    "FORCE_CONTROLLERS",
    "PREVIEW_BASELINES",
    "SEMI_ACTIVE_BASELINES",
    "VEHICLE_CONTROLLERS",
    "VEHICLE_FORCE_CONTROLLERS",
    "VEHICLE_ID",
    "ByActuator",
    "Entry",
    "baselines_of",
    "build_controller",
    "canonical_name",
    "controllers_of",
    "crash_factories",
]

#: the newest registered version of each env (:func:`railgym.registration.newest`): the
#: default of every command and function that takes an env id; the tables below hold for
#: every version of an env (looked up by its family, :func:`controllers_of`, :func:`baselines_of`)
ENV_ID = newest("railgym/VerticalSuspension")
VEHICLE_ID = newest("railgym/VerticalVehicle")
CRASH_ID = newest("railgym/TrainCrash")
#: an entry of the controller tables: (class, its arguments, the env arguments it needs)
Entry = tuple[Any, dict[str, Any], dict[str, Any]]
#: force-actuator controllers of ``railgym/VerticalSuspension`` by ``railgym evaluate`` name
FORCE_CONTROLLERS: dict[str, Entry] = {
    "passive": (Passive, {}, {}),
    "skyhook": (Skyhook, {"mode": "active"}, {}),
    "semi-active": (Skyhook, {"mode": "semi-active"}, {}),
    "groundhook": (Groundhook, {}, {}),
    "lqr": (LQR, {}, {"observation": "full"}),
    "lqg": (LQG, {}, {"observation": "sensors"}),
}


class ByActuator:
    """The controller of a name that both actuators of an env have (``passive``,
    ``skyhook``, ``groundhook``), called like a class: ``force``'s (class,
    arguments), or ``semi``'s on an env with ``actuator="semi-active"``."""

    def __init__(self, force: tuple[Any, dict[str, Any]], semi: tuple[Any, dict[str, Any]]) -> None:
        self.force, self.semi = force, semi

    def __call__(self, env: Any) -> Any:
        actuator = getattr(getattr(env, "unwrapped", env).cfg, "actuator", "force")
        cls, kwargs = self.semi if actuator == "semi-active" else self.force
        return cls(env, **kwargs)


def _both_actuators(force_controllers: dict[str, Entry]) -> dict[str, Entry]:
    """The force-actuator controllers ``force_controllers`` of an env and
    :data:`~agents.controllers.semi_active_control.SEMI_ACTIVE_CONTROLLERS` (a name of both:
    :class:`ByActuator`)."""
    table = dict(force_controllers)
    for name, (cls, kwargs, env_kwargs) in SEMI_ACTIVE_CONTROLLERS.items():
        force = force_controllers.get(name)
        if force is None:
            table[name] = (cls, kwargs, env_kwargs)
        else:  # both sides need the same env arguments (none)
            table[name] = (ByActuator(force[:2], (cls, kwargs)), {}, env_kwargs)
    return table


#: controllers of ``railgym/VerticalSuspension`` by ``railgym evaluate`` name, of either
#: actuator: each refuses an env of the other (the env argument ``actuator``); a name of both
#: builds the one of the env's actuator
CONTROLLERS = _both_actuators(FORCE_CONTROLLERS)
#: force-actuator controllers of ``railgym/VerticalVehicle`` (two actuators)
VEHICLE_FORCE_CONTROLLERS: dict[str, Entry] = {
    "passive": (Passive, {}, {}),
    "skyhook": (BogieSkyhook, {}, {}),
    "modal-skyhook": (ModalSkyhook, {}, {}),
    "lqr": (VehicleLQR, {}, {"observation": "full"}),
    "lqg": (VehicleLQG, {}, {"observation": "sensors"}),
    "lqr-preview": (LQRPreview, {}, {"observation": "full"}),
    "lq-preview": (LQGPreview, {}, {"observation": "sensors"}),
}
#: controllers of ``railgym/VerticalVehicle`` of either actuator, as :data:`CONTROLLERS`
#: (the semi-active ones per bogie)
VEHICLE_CONTROLLERS = _both_actuators(VEHICLE_FORCE_CONTROLLERS)
#: controllers of each env id that ``railgym evaluate`` loads by name (the crash env's:
#: :data:`CRASH_CONTROLLERS`, its baselines); every version of an env shares them
CONTROLLERS_OF = {ENV_ID: CONTROLLERS, VEHICLE_ID: VEHICLE_CONTROLLERS}


_BY_FAMILY = {env_family(key): table for key, table in CONTROLLERS_OF.items()}


def controllers_of(env_id: str) -> dict[str, Entry]:
    """The controllers of :data:`CONTROLLERS_OF` for any version of ``env_id`` (empty: none)."""
    return _BY_FAMILY.get(env_family(env_id), {})


def build_controller(env_id: str, name: str, env: Any) -> Any:
    """The classical controller ``name`` of ``env_id`` built on ``env`` (a single or native
    vector env); the error of an env it cannot run on (e.g. ``lqg`` on the full observation)
    names ``residual``."""
    cls, kwargs, _ = controllers_of(env_id)[name]
    try:
        return cls(env, **kwargs)
    except ValueError as err:
        raise val.FieldError("residual", f"{name}: {err}") from None


#: controllers of ``railgym/TrainCrash`` (one absorber action per crush zone)
CRASH_CONTROLLERS: dict[str, Entry] = {
    "passive": (CrashPassive, {}, {}),
    "best-constant": (ConstantAbsorber, {"action": BEST_CONSTANT_ACTION}, {}),
    "speed-adaptive": (SpeedAdaptive, {}, {}),
}
#: old spellings of a name → its one spelling (read with a DeprecationWarning)
DEPRECATED_NAMES = {"best constant": "best-constant"}

#: classical baselines evaluated beside the agents by ``railgym benchmark``; the crash ones
#: are also those of the held-out envelope (``railgym evaluate --envelope``, the crash report)
BASELINES: dict[str, tuple[str, ...]] = {
    ENV_ID: ("passive", "skyhook", "lqg", "lqr"),
    VEHICLE_ID: ("passive", "modal-skyhook", "lqg", "lqr"),
    CRASH_ID: tuple(CRASH_CONTROLLERS),
}
#: the baselines of a vertical config with ``actuator: semi-active`` (passive: command 0)
SEMI_ACTIVE_BASELINES = ("passive", "clipped-lqg", "skyhook-onoff", "skyhook", "groundhook")
#: the baselines of a vehicle config with ``preview`` (the LQG without it, the LQ preview)
PREVIEW_BASELINES = ("passive", "lqg", "lq-preview")
#: the rows ``railgym evaluate`` always adds, first (Δ columns: against the first)
COMPARISON: dict[str, tuple[str, ...]] = {
    ENV_ID: ("passive", "skyhook"),
    VEHICLE_ID: ("passive", "skyhook"),
    CRASH_ID: ("passive",),
}


def canonical_name(name: str) -> str:
    """``name`` in its one spelling: an old one (:data:`DEPRECATED_NAMES`) with a
    :class:`DeprecationWarning`."""
    new = DEPRECATED_NAMES.get(name)
    if new is None:
        return name
    warnings.warn(
        f"the baseline name {name!r} is deprecated, use {new!r}", DeprecationWarning, stacklevel=3
    )
    return new


def baselines_of(env_id: str, env_kwargs: dict[str, Any]) -> tuple[str, ...]:
    """The baseline names of a config of ``env_id`` (any version) with ``env_kwargs``:
    :data:`BASELINES`, :data:`SEMI_ACTIVE_BASELINES` for ``actuator: semi-active``,
    :data:`PREVIEW_BASELINES` for a vehicle with ``preview``."""
    family = env_family(env_id)  # any version of the env
    if family == env_family(ENV_ID) and env_kwargs.get("actuator") == "semi-active":
        return SEMI_ACTIVE_BASELINES
    if family == env_family(VEHICLE_ID) and env_kwargs.get("preview"):
        return PREVIEW_BASELINES
    return next(names for e, names in BASELINES.items() if env_family(e) == family)


def crash_factories(names: Iterable[str] | None = None) -> dict[str, Callable[[Any], Any]]:
    """``name → factory(env)`` of the crash controllers ``names`` (default all; an old
    spelling read by :func:`canonical_name`), picklable; a name of none is left out."""
    out = {}
    for name in CRASH_CONTROLLERS if names is None else names:
        name = canonical_name(name)
        if name in CRASH_CONTROLLERS:
            cls, kwargs, _ = CRASH_CONTROLLERS[name]
            out[name] = partial(cls, **kwargs)
    return out
