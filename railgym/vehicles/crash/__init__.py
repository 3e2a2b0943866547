"""Longitudinal train-crash models: a fine reference model and the paper's surrogate model.

Pure physics (no gymnasium), one module per concept:

* :mod:`~railgym.vehicles.crash.scenario` — validated scenarios (SI) from the YAML files;
* :mod:`~railgym.vehicles.crash.zone` — the hysteretic crush-zone law;
* :mod:`~railgym.vehicles.crash.outputs` — what both models share (kernel outputs, records,
  :class:`CrashResult`);
* :mod:`~railgym.vehicles.crash.reference` — the lumped-mass reference model;
* :mod:`~railgym.vehicles.crash.surrogate` — the surrogate elements of paper eq. (4), fitted;
* :mod:`~railgym.vehicles.crash.surrogate_model` — the compiled surrogate model;
* :mod:`~railgym.vehicles.crash.model` — a scenario's model, stepping many trains (the envs);
* :mod:`~railgym.vehicles.crash.criteria` — crash criteria (decelerations, pulses, intrusion);
* :mod:`~railgym.vehicles.crash.energy` — energy consistency of the elements;
* :mod:`~railgym.vehicles.crash.fe` — elements from a user's LS-DYNA run, their JSON files
  (``python -m railgym.vehicles.crash.fe``);
* :mod:`~railgym.vehicles.crash.elements` — the packaged element sets and their validation
  matrix (``python -m railgym.vehicles.crash.elements``).

Every public name is re-exported here, except those of the two command-line modules ``fe`` and
``elements``: importing them here would load them before ``python -m`` runs them. Import those
from their modules.
"""

from railgym.vehicles.crash.criteria import (
    ONSET_G,
    WINDOW,
    CrashCriteria,
    CriteriaLimits,
    G,
    Pulse,
    crash_criteria,
    crash_pulse,
    intrusion,
    moving_average_peak,
    peak_deceleration,
    zero_crossing,
)
from railgym.vehicles.crash.energy import (
    CycleWork,
    element_force_history,
    element_work,
    is_passive,
    rebound_energy_ratio,
    repaired_paper_history,
)
from railgym.vehicles.crash.model import MODEL_BACKENDS, CrashModel, crash_model
from railgym.vehicles.crash.outputs import (
    PARALLEL_MIN,
    V_EPS,
    CrashOutputs,
    CrashResult,
    Record,
    StopRule,
    result_criteria,
    zone_absorber_strokes,
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
    "MODEL_BACKENDS",
    "LIMITS",
    "MAX_SPEED",
    "PARALLEL_MIN",
    "MIN_REFERENCE_DT",
    "ONSET_G",
    "VARIANTS",
    "V_EPS",
    "WINDOW",
    "CrashOutputs",
    "CarSpec",
    "Coupler",
    "CrashModel",
    "CrashCriteria",
    "CrashElement",
    "CrashResult",
    "CrashScenario",
    "CrashSurrogate",
    "CriteriaLimits",
    "CrushZone",
    "CycleWork",
    "ElementTypes",
    "G",
    "LprModels",
    "Obstacle",
    "Pulse",
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
    "crash_model",
    "crash_criteria",
    "crash_errors",
    "crash_pulse",
    "crash_training_data",
    "element_force_history",
    "element_work",
    "intrusion",
    "is_passive",
    "load_scenario",
    "moving_average_peak",
    "parse_scenario",
    "peak_deceleration",
    "rebound_energy_ratio",
    "reference_batch_step",
    "reference_time_step",
    "repaired_paper_history",
    "result_criteria",
    "scenario_names",
    "simulate_reference",
    "simulate_surrogate",
    "surrogate_batch_step",
    "surrogate_batch_step_parallel",
    "virgin_loading",
    "zero_crossing",
    "zone_absorber_strokes",
    "zone_force",
]
