"""Whole railway vehicle in the vertical plane: carbody bounce, pitch and first bending on
two bogies, four wheelsets following the track (the equations: :mod:`.model`).

Modules: :mod:`~railgym.vehicles.vehicle.params` (vehicle data, YAML loading),
:mod:`~railgym.vehicles.vehicle.model` (RK4 step kernels, recorded runs, linear model),
:mod:`~railgym.vehicles.vehicle.lanes` (the SIMD lane kernel of the surrogate variant),
:mod:`~railgym.vehicles.vehicle.damper` (controllable dampers in place of the actuators),
:mod:`~railgym.vehicles.vehicle.collect` (the design and the packaged element) and
:mod:`~railgym.vehicles.vehicle.refine` (policy-aware refinement); the public names of the
first four are re-exported here (as the single module ``railgym.vehicles.vehicle`` had them).
"""

from __future__ import annotations

from railgym.vehicles.vehicle.damper import (
    DAMPER_COLUMNS,
    VehicleDampers,
    damper_stage,
)
from railgym.vehicles.vehicle.lanes import (
    LANES,
    LANES_MIN,
    hermite,
    lanes_block,
)
from railgym.vehicles.vehicle.model import (
    DEFAULT_DT,
    N_MECH,
    PARALLEL_CHUNKS,
    PARALLEL_MIN,
    STATE_SIZE,
    VARIANTS,
    Lpr,
    Out,
    Params,
    VehicleArrays,
    Work,
    advance,
    advance_parallel,
    advance_serial,
    check_variant,
    element_lpr,
    kernel_params,
    linear_state_space,
    lpr_arrays,
    new_arrays,
    state_size,
    wheelset_offsets,
)
from railgym.vehicles.vehicle.params import (
    BETA_L,
    FLOOR_POINTS,
    WholeVehicle,
    load_whole_vehicle,
    mode_shape,
)
from railgym.vehicles.vehicle.simulate import simulate

__all__ = [
    "BETA_L",
    "DAMPER_COLUMNS",
    "DEFAULT_DT",
    "FLOOR_POINTS",
    "LANES",
    "LANES_MIN",
    "Lpr",
    "N_MECH",
    "Out",
    "PARALLEL_CHUNKS",
    "PARALLEL_MIN",
    "Params",
    "STATE_SIZE",
    "VARIANTS",
    "VehicleArrays",
    "VehicleDampers",
    "WholeVehicle",
    "Work",
    "advance",
    "advance_parallel",
    "advance_serial",
    "check_variant",
    "damper_stage",
    "element_lpr",
    "hermite",
    "kernel_params",
    "lanes_block",
    "linear_state_space",
    "load_whole_vehicle",
    "lpr_arrays",
    "mode_shape",
    "new_arrays",
    "simulate",
    "state_size",
    "wheelset_offsets",
]
