"""Longitudinal train-crash models: a fine reference model and the paper's surrogate model.

Pure physics (no gymnasium), one module per concept:

* :mod:`~railgym.vehicles.crash.scenario` — validated scenarios (SI) from the YAML files;
* :mod:`~railgym.vehicles.crash.zone` — the hysteretic crush-zone law;
* :mod:`~railgym.vehicles.crash.outputs` — what both models share (kernel outputs, records,
  :class:`CrashResult`);
* :mod:`~railgym.vehicles.crash.reference` — the lumped-mass reference model;
* :mod:`~railgym.vehicles.crash.surrogate` — the surrogate elements of paper eq. (4), fitted;
* :mod:`~railgym.vehicles.crash.surrogate_model` — the compiled surrogate model;
* :mod:`~railgym.vehicles.crash.batch` — batch stepping of many trains for the envs.

Every public name is re-exported here.
"""

from railgym.vehicles.crash.batch import BATCH_BACKENDS, CrashBatchModel, crash_batch_model
from railgym.vehicles.crash.outputs import (
    PARALLEL_MIN,
    V_EPS,
    BatchOutputs,
    CrashResult,
    Record,
    StopRule,
)
from railgym.vehicles.crash.reference import (
    MIN_REFERENCE_DT,
    ReferenceParams,
    ReferenceState,
    ZoneTypes,
    reference_batch_step,
    reference_time_step,
    simulate_reference,
)
from railgym.vehicles.crash.scenario import (
    LIMITS,
    MAX_SPEED,
    CarSpec,
    Coupler,
    CrashScenario,
    CrushZone,
    Obstacle,
    check_int,
    check_real,
    load_scenario,
    parse_scenario,
    scenario_names,
)
from railgym.vehicles.crash.surrogate import (
    VARIANTS,
    CrashElement,
    CrashSurrogate,
    TrainingSet,
    build_crash_surrogate,
    crash_errors,
    crash_training_data,
    virgin_loading,
)
from railgym.vehicles.crash.surrogate_model import (
    ElementTypes,
    LprModels,
    SurrogateParams,
    SurrogateState,
    simulate_surrogate,
    surrogate_batch_step,
    surrogate_batch_step_parallel,
)
from railgym.vehicles.crash.zone import absorber_zone_force, zone_force

__all__ = [
    "BATCH_BACKENDS",
    "LIMITS",
    "MAX_SPEED",
    "MIN_REFERENCE_DT",
    "PARALLEL_MIN",
    "VARIANTS",
    "V_EPS",
    "BatchOutputs",
    "CarSpec",
    "Coupler",
    "CrashBatchModel",
    "CrashElement",
    "CrashResult",
    "CrashScenario",
    "CrashSurrogate",
    "CrushZone",
    "ElementTypes",
    "LprModels",
    "Obstacle",
    "Record",
    "ReferenceParams",
    "ReferenceState",
    "StopRule",
    "SurrogateParams",
    "SurrogateState",
    "TrainingSet",
    "ZoneTypes",
    "absorber_zone_force",
    "build_crash_surrogate",
    "check_int",
    "check_real",
    "crash_batch_model",
    "crash_errors",
    "crash_training_data",
    "load_scenario",
    "parse_scenario",
    "reference_batch_step",
    "reference_time_step",
    "scenario_names",
    "simulate_reference",
    "simulate_surrogate",
    "surrogate_batch_step",
    "surrogate_batch_step_parallel",
    "virgin_loading",
    "zone_force",
]
