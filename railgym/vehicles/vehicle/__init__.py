"""Whole railway vehicle in the vertical plane: carbody bounce, pitch and first bending on
two bogies, four wheelsets following the track (the equations: :mod:`.model`).

Modules: :mod:`~railgym.vehicles.vehicle.params` (vehicle data, YAML loading),
:mod:`~railgym.vehicles.vehicle.model` (RK4 step kernels, recorded runs, linear model),
:mod:`~railgym.vehicles.vehicle.lanes` (the SIMD lane kernel of the surrogate variant),
:mod:`~railgym.vehicles.vehicle.damper` (controllable dampers in place of the actuators),
:mod:`~railgym.vehicles.vehicle.collect` (the design and the packaged element) and
:mod:`~railgym.vehicles.vehicle.refine` (policy-aware refinement); import each name
from its module.
"""
