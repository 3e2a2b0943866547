"""Semi-active baselines of ``railgym/VerticalSuspension-v1`` and ``railgym/VerticalVehicle-v1``
with ``actuator="semi-active"``: the action is the command in [0, 1] of each controllable damper
in parallel with a secondary suspension (:mod:`railgym.vehicles.semi_active`; the whole
vehicle: one per bogie, front first), and each controller turns a force demand into the
command the damper can follow. On the whole vehicle every law runs per bogie: ``ẋ2`` is the
carbody's absolute velocity above that bogie, ``ẋ1`` the bogie's, ``v`` that bogie's
secondary deflection rate.

The damper's force ``F`` acts on the carbody in the direction of its extension rate
``v = ẋ1 − ẋ2`` (m/s, the deflection rate: ``F`` has the sign of the actuator force ``F_a`` of
the force env, :mod:`agents.controllers`), and ``F·v ≥ 0``: it can only dissipate. At steady
state (filtered command ``u`` = command, hysteresis ``w = sign(v)``) its force is affine in the
command, ``F(u) = (c_a + c_b·u)·v + (f_a + f_b·u)·sign(v)``; :func:`damper_command` inverts it.

By ``railgym evaluate`` name (:data:`SEMI_ACTIVE_CONTROLLERS`):

* ``passive``: command 0 (the damper at its softest, :class:`ConstantCommand`);
  ``constant-max``: command 1;
* ``skyhook-onoff``: command 1 where the skyhook force ``−c_sky·ẋ2`` has the sign the damper
  can give (``ẋ2·v < 0``), else 0 (:class:`OnOffSkyhook`);
* ``skyhook``: the skyhook demand ``−c_sky·ẋ2`` through :func:`damper_command`
  (:class:`DamperSkyhook`); ``groundhook``: the groundhook demand ``+c_gnd·ẋ1`` (force on
  the carbody of a damper from the bogie to the ground) likewise (:class:`DamperGroundhook`);
* ``clipped-lqg``: the LQG force demand of :class:`agents.controllers.lqg.LQG` (whole vehicle:
  :class:`agents.controllers.lqg.VehicleLQG`; same filter, same gain, on the env's sensor channels)
  through :func:`damper_command`; the filter is told the force the damper gives, not the
  demand (:class:`ClippedLQG`).

They read what the force-mode baselines read: the skyhook family the bogie and carbody
velocities (sensors: ``carbody_vel`` and ``ẋ1 = ẋ2 + deflection_rate``; full: ``v1``, ``v2``;
whole vehicle: ``carbody_vel_front``, ``deflection_rate_front`` …, or the full state), the LQG
the sensor channels, and all the deflection rate ``v``. Gains: those of the force-mode
skyhook and groundhook (:func:`agents.controllers.control_base.default_c_sky`,
:func:`~agents.controllers.control_base.default_c_gnd`), scaled to the vehicle.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agents.controllers.control_base import (
    Controller,
    body_velocities,
    checked_gain,
    default_c_gnd,
    default_c_sky,
)
from agents.controllers.lqg import LQG, LQGMixin, VehicleLQG
from railgym.envs.damper_params import damper_channels
from railgym.envs.vehicle.env import OBSERVATIONS as VEHICLE_OBSERVATIONS
from railgym.vehicles.semi_active import DamperParams

__all__ = [
    "ClippedLQG",
    "ConstantCommand",
    "DamperGroundhook",
    "DamperSkyhook",
    "OnOffSkyhook",
    "SEMI_ACTIVE_CONTROLLERS",
    "damper_command",
    "steady_force",
]


def steady_force(v: np.ndarray, command: np.ndarray, p: DamperParams) -> np.ndarray:
    """Steady-state damper force (N, on the carbody in the direction of ``v``) at extension
    rate ``v`` (m/s) and command ``command`` in [0, 1]: ``u`` = command, ``w = sign(v)``."""
    u = np.asarray(command, np.float64)
    return (p.c_a + p.c_b * u) * v + (p.f_a + p.f_b * u) * np.sign(v)


def damper_command(demand: np.ndarray, v: np.ndarray, p: DamperParams) -> np.ndarray:
    """The command in [0, 1] whose steady-state force (:func:`steady_force`) at extension rate
    ``v`` (m/s) is nearest the demanded force ``demand`` (N, on the carbody).

    ``F(u) = F(0) + u·(c_b·v + f_b·sign(v))`` is affine in ``u``: the exact inverse, clipped to
    [0, 1]. A demand that asks for power (``demand·v ≤ 0``) or below the softest force gets 0,
    one above the hardest 1; at ``v = 0`` the damper gives no force whatever the command: 0.
    """
    demand = np.asarray(demand, np.float64)
    v = np.asarray(v, np.float64)
    s = np.sign(v)
    slope = p.c_b * v + p.f_b * s
    excess = demand - (p.c_a * v + p.f_a * s)
    u = np.divide(excess, slope, out=np.zeros(np.broadcast(excess, slope).shape), where=slope != 0)
    return np.clip(u, 0.0, 1.0)


def _default_gain(name: str, value: float | None, params: Any) -> float:
    """The checked gain ``name`` (``"c_sky"`` or ``"c_gnd"``, N·s/m): ``value``, or
    the force-mode default scaled to the vehicle ``params``."""
    default = {"c_sky": default_c_sky, "c_gnd": default_c_gnd}[name](params)
    return checked_gain(value, default, name)


#: the sensor channels of the whole vehicle (its LQG's filter inputs)
VEHICLE_SENSORS = VEHICLE_OBSERVATIONS["sensors"][0]


class _SemiActive(Controller):
    """Semi-active baselines: a command in [0, 1] per damper from a force demand (N) and the
    deflection rate, through the damper's inverse (:func:`damper_command`); all arrays
    (n, n_act), one column per damper (one bogie: one; whole vehicle: front, rear)."""

    actuator = "semi-active"
    #: also the whole vehicle's (full, sensors)
    velocity_channels = (
        *Controller.velocity_channels,
        ("z_c_dot", "theta_c_dot", "q_dot", "z_b0_dot", "z_b1_dot"),
        ("carbody_vel_front", "carbody_vel_rear", "deflection_rate_front", "deflection_rate_rear"),
    )

    def __init__(self, env: Any) -> None:
        super().__init__(env)
        self.damper: DamperParams = self._base.cfg.damper_params
        self._commands = [self._index(name) for name in damper_channels(self.n_act)]

    def _rate(self, x: np.ndarray) -> np.ndarray:
        """Damper extension rates ``v = ẋ1 − ẋ2`` (n, n_act), m/s."""
        if self.n_act == 1:
            if "deflection_rate" in self.obs_names:
                return x[:, self._index("deflection_rate")][:, None]
            return (x[:, self._index("v1")] - x[:, self._index("v2")])[:, None]
        if "deflection_rate_front" in self.obs_names:
            return x[:, [self._index("deflection_rate_front"), self._index("deflection_rate_rear")]]
        bogies = x[:, [self._index("z_b0_dot"), self._index("z_b1_dot")]]
        return bogies - self._body(x)

    def _body(self, x: np.ndarray) -> np.ndarray:
        """The carbody's absolute velocities at the dampers ``ẋ2`` (n, n_act), m/s."""
        if self.n_act == 1:
            return self._velocities(x)[1][:, None]
        return body_velocities(x, self.obs_names, self._base.vehicle_params)

    def _bogie(self, x: np.ndarray) -> np.ndarray:
        """The bogies' absolute velocities ``ẋ1`` (n, n_act), m/s."""
        if self.n_act == 1:
            return self._velocities(x)[0][:, None]
        return self._body(x) + self._rate(x)

    def _suspension(self) -> Any:
        """What the default gains scale to: the one-bogie vehicle's kernel parameters, or the
        whole vehicle's secondary suspension (one bogie's share)."""
        base = self._base
        return base.vehicle_params if self.n_act == 1 else base.vehicle.suspension

    def command(self, x: np.ndarray) -> np.ndarray:
        """Damper commands (n, n_act) in [0, 1] from the physical observation (n, n_obs)."""
        return damper_command(self.force(x), self._rate(x), self.damper)

    def action(self, x: np.ndarray) -> np.ndarray:
        """The commands (n, n_act)."""
        return self.command(x).reshape(x.shape[0], self.n_act)


class ConstantCommand(_SemiActive):
    """A constant damper command: 0 (``passive``: the softest damper) or 1 (``constant-max``)."""

    def __init__(self, env: Any, command: float = 0.0) -> None:
        super().__init__(env)
        if not (math.isfinite(command) and 0.0 <= command <= 1.0):
            raise ValueError(f"command must lie in [0, 1], got {command!r}")
        self.value = float(command)

    def command(self, x: np.ndarray) -> np.ndarray:
        """``value`` for every damper (n, n_act)."""
        return np.full((x.shape[0], self.n_act), self.value)


class DamperSkyhook(_SemiActive):
    """Continuous semi-active skyhook: the demand ``−c_sky·ẋ2`` through the damper's inverse.

    Default ``c_sky``: :func:`agents.controllers.control_base.default_c_sky` (the force-mode
    skyhook's damping ratio 0.2 of the bounce mode; 47 kN·s/m on the Manchester vehicle).
    """

    needs_velocities = True

    def __init__(self, env: Any, c_sky: float | None = None) -> None:
        super().__init__(env)
        self.c_sky = _default_gain("c_sky", c_sky, self._suspension())

    def force(self, x: np.ndarray) -> np.ndarray:
        """Skyhook demands on the carbody (n, n_act), N."""
        return -self.c_sky * self._body(x)


class OnOffSkyhook(DamperSkyhook):
    """On–off skyhook: command 1 where the skyhook force ``−c_sky·ẋ2`` has the sign the damper
    can give (that of ``v = ẋ1 − ẋ2``, i.e. ``ẋ2·v < 0``), else 0; ``c_sky`` only sets that
    sign (any positive gain switches alike)."""

    def command(self, x: np.ndarray) -> np.ndarray:
        """1 where ``−c_sky·ẋ2·v > 0``, else 0 (n, n_act)."""
        return (self.force(x) * self._rate(x) > 0.0).astype(np.float64)


class DamperGroundhook(_SemiActive):
    """Semi-active groundhook: the demand ``+c_gnd·ẋ1`` on the carbody (the reaction of a
    damper from the bogie to the ground, :class:`agents.controllers.classical.Groundhook`)
    through the damper's inverse. Default ``c_gnd``:
    :func:`agents.controllers.control_base.default_c_gnd` (40 kN·s/m on the Manchester vehicle)."""

    needs_velocities = True

    def __init__(self, env: Any, c_gnd: float | None = None) -> None:
        super().__init__(env)
        self.c_gnd = _default_gain("c_gnd", c_gnd, self._suspension())

    def force(self, x: np.ndarray) -> np.ndarray:
        """Groundhook demands on the carbody (n, n_act), N."""
        return self.c_gnd * self._bogie(x)


class _SensorChannels:
    """The semi-active env as the LQG design sees it: its sensor channels ``sensors`` (the
    filtered commands left out); every other attribute is the env's."""

    def __init__(self, base: Any, sensors: tuple[str, ...]) -> None:
        self._env = base
        self.obs_names = sensors
        self.obs_scale = np.asarray(base.obs_scale)[[base.obs_names.index(n) for n in sensors]]

    @property
    def unwrapped(self) -> _SensorChannels:
        return self

    def __getattr__(self, name: str) -> Any:
        return getattr(self._env, name)


class _DamperLQG(LQG):
    """The LQG's filter and gain designed on the semi-active env's sensor channels."""

    actuator = "semi-active"


class _DamperVehicleLQG(VehicleLQG):
    """The whole vehicle's LQG designed on the semi-active env's sensor channels."""

    actuator = "semi-active"


class ClippedLQG(LQGMixin, _SemiActive):
    """The LQG's force demand clipped to what the damper can give (``clipped-lqg``).

    Filter and gain: :class:`agents.controllers.lqg.LQG` (whole vehicle:
    :class:`agents.controllers.lqg.VehicleLQG`) on the env's sensor channels (the env's reward
    weights, or ``q_acc``, ``q_defl``, ``r_force``; needs ``observation="sensors"``); each demand of
    ``−K·x̂`` (N, within ±f_max) goes through :func:`damper_command` at its measured deflection
    rate. The filter's prediction uses the force the damper gives over the coming step instead of
    the demand: :func:`steady_force` at the mean filtered command of the step,
    ``ū = c + (u₀ − c)·(1 − e^{−η·Δt})/(η·Δt)`` (``u₀`` the observed filtered command,
    ``c`` the new command, ``η`` the damper's command bandwidth, ``Δt`` = ``control_dt``).
    The estimate is kept between ``predict`` calls as :class:`~agents.controllers.lqg.LQG`'s.
    """

    def __init__(
        self,
        env: Any,
        q_acc: float | None = None,
        q_defl: float | None = None,
        r_force: float | None = None,
    ) -> None:
        super().__init__(env)
        sensors, lqg = (
            (LQG.SENSORS, _DamperLQG) if self.n_act == 1 else (VEHICLE_SENSORS, _DamperVehicleLQG)
        )
        wanted = (*sensors, *damper_channels(self.n_act))
        if not set(wanted) <= set(self.obs_names):
            raise ValueError(
                f"observation must be 'sensors' for clipped-lqg (channels {list(wanted)}); "
                f"the env observes {list(self.obs_names)}"
            )
        self._sensors = [self._index(n) for n in sensors]
        design = lqg(_SensorChannels(self._base, sensors), q_acc, q_defl, r_force)
        self.kf, self.K = design.kf, design.K
        step = self._base.cfg.control_dt * self.damper.eta
        self._lag = -math.expm1(-step) / step
        self.x_pred = None  # type: ignore[assignment]

    def action(self, x: np.ndarray) -> np.ndarray:
        """Filter update and LQG demands, their commands, the filter told the dampers'
        forces."""
        demand = LQGMixin.action(self, x[:, self._sensors]) * self.f_max
        v = self._rate(x)
        command = damper_command(demand, v, self.damper)
        mean_u = command + (x[:, self._commands] - command) * self._lag
        applied = steady_force(v, mean_u, self.damper)
        self.x_pred = self.x_pred + (applied - demand) @ self.kf.gamma.T
        self.u_prev = applied
        return command


#: the semi-active controllers by ``railgym evaluate`` name, of both envs: (class, its
#: arguments, the env arguments it needs besides ``actuator="semi-active"``)
SEMI_ACTIVE_CONTROLLERS: dict[str, tuple[type, dict[str, Any], dict[str, Any]]] = {
    "passive": (ConstantCommand, {"command": 0.0}, {}),
    "constant-max": (ConstantCommand, {"command": 1.0}, {}),
    "skyhook-onoff": (OnOffSkyhook, {}, {}),
    "skyhook": (DamperSkyhook, {}, {}),
    "groundhook": (DamperGroundhook, {}, {}),
    "clipped-lqg": (ClippedLQG, {}, {"observation": "sensors"}),
}
