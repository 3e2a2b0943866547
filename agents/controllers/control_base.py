"""Shared parts of the classical controllers (:mod:`agents.controllers`,
:mod:`agents.controllers.lqg`): the base classes that turn a demanded actuator force into the env's
normalised action and the LQR gains of both vertical envs (SI units throughout)."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from scipy.linalg import solve_continuous_are

from agents.controllers.feedback import ObservationController
from railgym.envs.vehicle.env import ACC_REF as VEHICLE_ACC_REF
from railgym.envs.vertical.env import ACC_REF
from railgym.vehicles.vehicle.model import linear_state_space
from railgym.vehicles.vertical.params import SuspensionParams, linear_model

__all__ = [
    "DEFAULT_C_GND",
    "DEFAULT_C_SKY",
    "LQDesign",
    "body_velocities",
    "checked_gain",
    "default_c_gnd",
    "default_c_sky",
    "vehicle_lqr_gain",
    "vehicle_lqr_weights",
    "vertical_lqr_gain",
]


class Controller(ObservationController):
    """Vertical-env baselines: a demanded actuator force, normalised by ``f_max``."""

    env_name = "VerticalSuspension"
    #: reads the bogie and carbody velocities (:meth:`_velocities`)
    needs_velocities = False
    #: channel sets any of which gives those velocities (one bogie: full, sensors)
    velocity_channels: tuple[tuple[str, ...], ...] = (
        ("v1", "v2"),
        ("carbody_vel", "deflection_rate"),
    )
    #: the env's ``actuator`` it commands (an env without that argument: ``"force"``); the
    #: semi-active damper's controllers: :mod:`agents.controllers.semi_active_control`
    actuator = "force"

    def __init__(self, env: Any) -> None:
        super().__init__(env)
        base = self._base
        names = set(self.obs_names)
        velocities = any(set(chans) <= names for chans in self.velocity_channels)
        if not hasattr(base.cfg, "f_max") or (self.needs_velocities and not velocities):
            raise ValueError(
                f"env must be a railgym {self.env_name} env (actuator force f_max"
                f"{', bogie and carbody velocities observed' if self.needs_velocities else ''}"
                f"), got {type(base).__name__}"
            )
        env_actuator = getattr(base.cfg, "actuator", "force")
        if env_actuator != self.actuator:
            raise ValueError(
                f"{type(self).__name__} commands actuator={self.actuator!r}, the env has "
                f"actuator={env_actuator!r}"
            )
        self.f_max = float(base.cfg.f_max)
        self.n_act = int(getattr(base, "single_action_space", base.action_space).shape[-1])

    def _index(self, name: str) -> int:
        return self.obs_names.index(name)

    def _velocities(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bogie and carbody absolute velocities ``(ẋ1, ẋ2)``, m/s, from physical obs (n, n_obs)."""
        if "v1" in self.obs_names:
            return x[:, self._index("v1")], x[:, self._index("v2")]
        v2 = x[:, self._index("carbody_vel")]
        return v2 + x[:, self._index("deflection_rate")], v2

    def force(self, x: np.ndarray) -> np.ndarray:
        """Demanded actuator force (n,), N, from the physical observation (n, n_obs)."""
        raise NotImplementedError

    def action(self, x: np.ndarray) -> np.ndarray:
        """``F_a / f_max`` (n, n_act) from the physical observation (n, n_obs)."""
        return (self.force(x) / self.f_max).reshape(x.shape[0], self.n_act)


def lqr_weights(
    cfg: Any, acc_ref: float, q_acc: float | None, q_defl: float | None, r_force: float | None
) -> tuple[float, float, float]:
    """LQR weights in SI; ``None`` = the env's reward weights (``cfg.reward_weights``, default
    1, 1, 0.1): ``w_a/acc_ref²``, ``w_d/free_travel²``, ``w_f/f_max²``. ValueError names a
    negative or non-finite weight, or ``r_force <= 0`` (a reward without a force term needs
    an explicit ``r_force``)."""
    w = cfg.reward_weights
    weights = {
        "q_acc": w["acceleration"] / acc_ref**2 if q_acc is None else q_acc,
        "q_defl": w["deflection"] / cfg.free_travel**2 if q_defl is None else q_defl,
        "r_force": w["force"] / cfg.f_max**2 if r_force is None else r_force,
    }
    for name, value in weights.items():
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a non-negative number, got {value!r}")
    if weights["r_force"] <= 0:
        raise ValueError(
            f"r_force must be positive, got {weights['r_force']!r} (a reward without a force "
            "term: pass r_force)"
        )
    return float(weights["q_acc"]), float(weights["q_defl"]), float(weights["r_force"])


def vertical_lqr_gain(
    params: SuspensionParams,
    cfg: Any,
    q_acc: float | None = None,
    q_defl: float | None = None,
    r_force: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, P, K)`` of :class:`LQR` for kernel parameters ``params`` and the env config
    ``cfg`` (weights: see :class:`LQR`); ``K`` is (1, 4), N per SI state."""
    w_acc, w_defl, w_force = lqr_weights(cfg, ACC_REF, q_acc, q_defl, r_force)
    a, b, c, d = linear_model(params)
    c_d = np.array([1.0, 0.0, -1.0, 0.0])
    q = w_acc * np.outer(c, c) + w_defl * np.outer(c_d, c_d)
    n = w_acc * d * c[:, None]
    r = np.array([[w_force + w_acc * d * d]])
    p = solve_continuous_are(a, b, q, r, s=n)
    return a, b, p, np.linalg.solve(r, b.T @ p + n.T)


class VehicleController(Controller):
    """Plumbing for the whole-vehicle env: carbody velocities over the two bogies."""

    def __init__(self, env: Any) -> None:
        super().__init__(env)
        if not hasattr(self._base, "vehicle") or self.n_act != 2:
            raise ValueError(
                f"env must be a railgym VerticalVehicle env, got {type(self._base).__name__}"
            )
        self.vehicle = self._base.vehicle
        self.params = self._base.vehicle_params

    def _body_velocities(self, x: np.ndarray) -> np.ndarray:
        """Absolute carbody velocities over the front and rear bogie (n, 2), m/s."""
        return body_velocities(x, self.obs_names, self.params)


def body_velocities(x: np.ndarray, obs_names: tuple[str, ...], params: Any) -> np.ndarray:
    """Absolute carbody velocities over the front and rear bogie (n, 2), m/s, from the
    physical whole-vehicle observation ``x`` (n, n_obs) of channels ``obs_names`` (kernel
    ``params``: bogie semi-spacing ``a``, m, bending mode at the bogies ``phi_a``)."""
    if "carbody_vel_front" in obs_names:
        return x[:, [obs_names.index("carbody_vel_front"), obs_names.index("carbody_vel_rear")]]
    v, w, qd = (x[:, obs_names.index(n)] for n in ("z_c_dot", "theta_c_dot", "q_dot"))
    return np.stack([v + s * params.a * w + params.phi_a * qd for s in (1.0, -1.0)], axis=1)


class LQDesign:
    """The constructor the LQR and LQG designs share (:class:`~agents.controllers.classical.LQR`,
    :class:`~agents.controllers.lqg.LQG` and their whole-vehicle variants): ``(env, q_acc, q_defl,
    r_force)`` (weights: :func:`lqr_weights`), the env's observation checked
    (:meth:`_observes`; the error from :attr:`NEEDS`), then :meth:`_design` with the weights.
    Listed before the controller base it initialises."""

    #: ``(observation mode, design name, what it needs)`` of the observation error
    NEEDS: ClassVar[tuple[str, str, str]]
    obs_names: tuple[str, ...]

    def __init__(
        self,
        env: Any,
        q_acc: float | None = None,
        q_defl: float | None = None,
        r_force: float | None = None,
    ) -> None:
        super().__init__(env)  # type: ignore[call-arg]
        mode, name, needs = self.NEEDS
        if not self._observes(self.obs_names):
            raise ValueError(
                f"observation must be {mode!r} for {name} ({needs}); "
                f"the env observes {list(self.obs_names)}"
            )
        self._design(q_acc, q_defl, r_force)

    def _observes(self, names: tuple[str, ...]) -> bool:
        """Whether the env's observation channels ``names`` are what the design needs."""
        raise NotImplementedError

    def _design(self, q_acc: float | None, q_defl: float | None, r_force: float | None) -> None:
        """The design (gain, filter) with the weights (``None``: the env's reward weights)."""
        raise NotImplementedError


def vehicle_lqr_weights(
    vehicle: Any,
    params: Any,
    cfg: Any,
    q_acc: float | None = None,
    q_defl: float | None = None,
    r_force: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, Q, N, R)`` of :class:`VehicleLQR`: the linear model (14 states) and the
    weights of ``J = ∫ (xᵀQx + 2xᵀN·F + FᵀR·F) dt`` (SI; see :class:`VehicleLQR`)."""
    w_acc, w_defl, w_force = lqr_weights(cfg, VEHICLE_ACC_REF, q_acc, q_defl, r_force)
    a, b, _, c, d = linear_state_space(vehicle, cfg.flexible)
    q = w_acc * c.T @ c / 3.0
    for s in (1.0, -1.0):  # δ_i = z_b,i − z_c − x_i·θ_c − φ(a)·q
        c_d = np.zeros(a.shape[0])
        c_d[[3 if s > 0 else 5, 0, 1, 2]] = 1.0, -1.0, -s * params.a, -params.phi_a
        q += 0.5 * w_defl * np.outer(c_d, c_d)
    n = w_acc * c.T @ d / 3.0
    r = 0.5 * w_force * np.eye(2) + w_acc * d.T @ d / 3.0
    return a, b, q, n, r


def vehicle_lqr_gain(
    vehicle: Any,
    params: Any,
    cfg: Any,
    q_acc: float | None = None,
    q_defl: float | None = None,
    r_force: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, P, K)`` of :class:`VehicleLQR` for ``vehicle``, its kernel ``params`` and the
    env config ``cfg`` (weights: see :class:`VehicleLQR`); ``K`` is (2, 14)."""
    a, b, q, n, r = vehicle_lqr_weights(vehicle, params, cfg, q_acc, q_defl, r_force)
    p = solve_continuous_are(a, b, q, r, s=n)
    return a, b, p, np.linalg.solve(r, b.T @ p + n.T)


#: skyhook gain, N·s/m: ``c_sky·σ(ẋ2)`` ≈ f_max/2 at the passive carbody velocity RMS on the
#: training case (8.6 cm/s, class 5 at 144 km/h), i.e. a skyhook damping ratio of 0.2
DEFAULT_C_SKY = 4.7e4
#: groundhook gain, N·s/m: ``c_gnd·σ(ẋ1)`` ≈ f_max/2 at the passive bogie velocity RMS on the
#: training case (10 cm/s), like the skyhook gain; 0.16 of the bogie mode's critical damping
DEFAULT_C_GND = 4.0e4
#: the vehicle the default gains were chosen for (Manchester, one bogie): ``m1, m2`` kg,
#: ``k1, k2`` N/m; another vehicle gets them scaled to the same damping ratio of its modes
_GAIN_VEHICLE = {"m1": 2615.0, "m2": 16000.0, "k1": 4.88e6, "k2": 8.6e5}


def default_c_sky(p: Any) -> float:
    """``DEFAULT_C_SKY`` scaled to the bounce mode of the vehicle ``p`` (``m2``, ``k2``):
    the same skyhook damping ratio ``c_sky / (2·√(k2·m2))``, N·s/m."""
    g = _GAIN_VEHICLE
    return DEFAULT_C_SKY * float(np.sqrt(p.k2 * p.m2 / (g["k2"] * g["m2"])))


def default_c_gnd(p: Any) -> float:
    """``DEFAULT_C_GND`` scaled to the bogie mode of the vehicle ``p`` (``m1``, ``k1 + k2``):
    the same ratio to its critical damping ``2·√((k1 + k2)·m1)``, N·s/m."""
    g = _GAIN_VEHICLE
    ref = (g["k1"] + g["k2"]) * g["m1"]
    return DEFAULT_C_GND * float(np.sqrt((p.k1 + p.k2) * p.m1 / ref))


def checked_gain(value: float | None, default: float, name: str) -> float:
    """A checked non-negative gain (N·s/m); ``None``: ``default``."""
    value = default if value is None else value
    if not (np.isfinite(value) and value >= 0):
        raise ValueError(f"{name} must be a non-negative number in N·s/m, got {value!r}")
    return float(value)
