"""The controllers room: classical baselines of every env (:mod:`~agents.controllers.classical`,
:mod:`~agents.controllers.lqg`, :mod:`~agents.controllers.preview`,
:mod:`~agents.controllers.semi_active_control`, :mod:`~agents.controllers.crash_baselines`),
their parts (:mod:`~agents.controllers.control_base`, :mod:`~agents.controllers.feedback`), the
wrappers of a trained policy (:mod:`~agents.controllers.residual`,
:mod:`~agents.controllers.action_hold`) and the one table of names and baselines
(:mod:`~agents.controllers.registry`).

The names of the former module ``agents.controllers`` are re-exported here.
"""

from agents.controllers.classical import (
    DEFAULT_C_GND,
    DEFAULT_C_SKY,
    LQR,
    BogieSkyhook,
    Groundhook,
    ModalSkyhook,
    Passive,
    Skyhook,
    VehicleLQR,
    default_c_gnd,
    default_c_sky,
    linear_model,
    vehicle_lqr_gain,
    vertical_lqr_gain,
)
from agents.controllers.crash_baselines import (
    BEST_CONSTANT_ACTION,
    ConstantAbsorber,
    CrashPassive,
    SpeedAdaptive,
)
from agents.controllers.lqg import LQG, VehicleLQG
from agents.controllers.preview import LQGPreview, LQRPreview
from agents.controllers.registry import (
    CONTROLLERS,
    CONTROLLERS_OF,
    CRASH_ID,
    ENV_ID,
    FORCE_CONTROLLERS,
    VEHICLE_CONTROLLERS,
    VEHICLE_FORCE_CONTROLLERS,
    VEHICLE_ID,
    ByActuator,
    Entry,
    build_controller,
)
from agents.controllers.semi_active_control import SEMI_ACTIVE_CONTROLLERS

__all__ = [
    "BEST_CONSTANT_ACTION",
    "ByActuator",
    "CONTROLLERS",
    "CONTROLLERS_OF",
    "CRASH_ID",
    "ConstantAbsorber",
    "CrashPassive",
    "DEFAULT_C_GND",
    "DEFAULT_C_SKY",
    "ENV_ID",
    "Entry",
    "FORCE_CONTROLLERS",
    "LQG",
    "LQGPreview",
    "LQR",
    "LQRPreview",
    "BogieSkyhook",
    "Groundhook",
    "ModalSkyhook",
    "Passive",
    "SEMI_ACTIVE_CONTROLLERS",
    "Skyhook",
    "SpeedAdaptive",
    "VEHICLE_CONTROLLERS",
    "VEHICLE_FORCE_CONTROLLERS",
    "VEHICLE_ID",
    "VehicleLQG",
    "VehicleLQR",
    "build_controller",
    "default_c_gnd",
    "default_c_sky",
    "linear_model",
    "vehicle_lqr_gain",
    "vertical_lqr_gain",
]
