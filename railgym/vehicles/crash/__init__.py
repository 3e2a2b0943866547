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
  (``railgym crash-fe``);
* :mod:`~railgym.vehicles.crash.elements` — the packaged element sets and their validation
  matrix (``railgym crash-elements``).

Import each name from its module.
"""
