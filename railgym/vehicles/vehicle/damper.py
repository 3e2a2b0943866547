"""Controllable dampers of the whole vehicle: one per bogie, at the actuator's place.

Each damper (the law of :mod:`railgym.vehicles.semi_active`, chosen by its law kind through
:func:`~railgym.vehicles.vertical.elements.controlled_damper`) sits between bogie ``i`` and
the carbody at that bogie's secondary suspension point. Its compression rate is the
secondary deflection rate of :mod:`railgym.vehicles.vehicle`,
``v_i = ż_b,i − (ż_c + x_i·θ̇_c + φ(x_i)·q̇)`` (m/s, pitch and bending included), and its force
``F_d,i`` (N) takes the place of the actuator force ``F_a,i``: on the carbody in the direction
of ``v_i``, on the bogie opposite. Its states ``(u_i, w_i)`` (filtered command, hysteresis
state) are the last four columns of the vehicle's state, ``[u_0, w_0, u_1, w_1]``
(:data:`DAMPER_COLUMNS`), integrated in the RK4 stages with the vehicle while the commands
are held over the control step.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from railgym.vehicles.semi_active import DAMPER_STATES
from railgym.vehicles.vertical.elements import DamperLaw, controlled_damper

__all__ = ["DAMPER_COLUMNS", "VehicleDampers", "damper_stage"]

#: states the two dampers append to the vehicle's state (``u_0, w_0, u_1, w_1``)
DAMPER_COLUMNS = 2 * DAMPER_STATES


class VehicleDampers(NamedTuple):
    """The dampers of a batch of vehicles as the kernel reads them: the law (the same at both
    bogies) and the commands in [0, 1] held over the control step."""

    law: DamperLaw  #: law kind and parameters (``damper_law``)
    command: np.ndarray  #: (n, 2) command of the front and rear damper of each vehicle


@njit(cache=True, error_model="numpy", _nrt=False)
def damper_stage(state, params, law, command, force, rates):
    """Forces of the two dampers (N, on the carbody) into ``force`` (2,) and their state rates
    (1/s) into the last four entries of ``rates``, for the vehicle state ``state`` (its last
    four entries the dampers' ``u, w``), the kernel ``params``
    (:class:`~railgym.vehicles.vehicle.model.Params`), the damper ``law`` and ``command`` (2,)."""
    s = state.shape[0]
    for b in range(2):
        xb = params.a if b == 0 else -params.a
        v = state[10 + 2 * b] - (state[7] + xb * state[8] + params.phi_a * state[9])
        j = s - DAMPER_COLUMNS + DAMPER_STATES * b
        f, du, dw = controlled_damper(v, state[j], state[j + 1], command[b], law)
        force[b] = f
        rates[j] = du
        rates[j + 1] = dw
