"""Classical baselines for ``railgym/VerticalSuspension-v1``: passive, skyhook, groundhook, LQR;
for ``railgym/VerticalVehicle-v1`` (two actuators): passive, skyhook per bogie, modal skyhook
and LQR on the full linear model (:class:`BogieSkyhook`, :class:`ModalSkyhook`,
:class:`VehicleLQR`, at the end of the module); the observer-based LQG is in
:mod:`agents.controllers.lqg`.

Every controller reads the env's observation (physical value = obs × ``obs_scale``, SI) and
returns the normalised actuator commands ``F_a / f_max`` clipped to [−1, 1] with
stable-baselines3's ``predict`` signature, for one observation (n_obs,) → action (n_act,) or
a batch from the vector env (n, n_obs) → (n, n_act), float32 (``n_act`` = 1 or 2). Sign
convention of the env (see :mod:`railgym.vehicles.vertical`): velocities are upward,
``F_a > 0`` pushes the carbody up and the bogie down (``m2·ẍ2 = F_s + F_a``,
``m1·ẍ1 = … − F_s − F_a``), and the deflection rate is ``δ̇ = ẋ1 − ẋ2``.

The controllers by their ``railgym evaluate`` name, per env id, and the baselines of each
env: :mod:`agents.controllers.registry`.

Default gains are chosen for the Manchester vehicle (``m2`` = 16 t, ``k2`` = 860 kN/m,
``c2`` = 40 kN·s/m: body bounce 1.17 Hz, passive damping ratio 0.17) and the env's default
``f_max`` = 8 kN; each class docstring says why. Only numpy and scipy are used.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.controllers.control_base import (
    Controller,
    LQDesign,
    VehicleController,
    checked_gain,
    default_c_gnd,
    default_c_sky,
    lqr_weights,
    vehicle_lqr_gain,
    vertical_lqr_gain,
)
from railgym.envs.vehicle.env import ACC_REF as VEHICLE_ACC_REF
from railgym.envs.vertical.env import ACC_REF

__all__ = [
    "LQR",
    "BogieSkyhook",
    "Groundhook",
    "ModalSkyhook",
    "Passive",
    "Skyhook",
    "VehicleLQR",
]


class Passive(Controller):
    """Zero actuator force: the passive suspension alone."""

    def force(self, x: np.ndarray) -> np.ndarray:
        """Zero force (n, n_actuators), N."""
        return np.zeros((x.shape[0], self.n_act))


class Skyhook(Controller):
    """Skyhook damper on the carbody, ``F = −c_sky·ẋ2`` (absolute carbody velocity).

    ``mode="active"``: the actuator applies ``−c_sky·ẋ2`` whatever its power flow.
    ``mode="semi-active"`` (clipped skyhook): the actuator emulates a variable damper in
    parallel with the passive one. A damper between bogie and carbody can only push the
    carbody with the sign of ``ẋ1 − ẋ2`` (it dissipates energy: ``F·(ẋ2 − ẋ1) ≤ 0``), so the
    skyhook force is applied only when ``ẋ2·(ẋ2 − ẋ1) > 0`` and is 0 otherwise; with the
    sensors, ``ẋ1 = ẋ2 + δ̇`` (``carbody_vel`` + ``deflection_rate``).

    Default ``c_sky`` (:func:`default_c_sky`; ``DEFAULT_C_SKY`` = 47 kN·s/m on the
    Manchester vehicle, scaled to the same damping ratio on another): damping ratio
    ``c_sky / (2·√(k2·m2))`` = 0.2 on the 1.17 Hz body mode on top of the passive 0.17, and
    ``c_sky × 8.6 cm/s`` (passive carbody velocity RMS, class 5) ≈ 4 kN = f_max/2, so the
    command saturates only on the largest peaks. Works with both observation modes.
    """

    needs_velocities = True

    def __init__(self, env: Any, c_sky: float | None = None, mode: str = "active") -> None:
        super().__init__(env)
        self.c_sky = checked_gain(c_sky, default_c_sky(self._base.vehicle_params), "c_sky")
        if mode not in ("active", "semi-active"):
            raise ValueError(f"mode must be 'active' or 'semi-active', got {mode!r}")
        self.mode = mode

    def force(self, x: np.ndarray) -> np.ndarray:
        """Skyhook force (n,), N; zero where a semi-active damper could not produce it."""
        v1, v2 = self._velocities(x)
        f = -self.c_sky * v2
        if self.mode == "semi-active":
            f = np.where(v2 * (v2 - v1) > 0.0, f, 0.0)
        return f


class Groundhook(Controller):
    """Groundhook damper on the bogie: ``−c_gnd·ẋ1`` on the bogie, i.e. ``F_a = +c_gnd·ẋ1``.

    The ideal groundhook is a damper from the bogie to the (inertial) ground, force
    ``−c_gnd·ẋ1`` on the bogie. The actuator pushes the bogie with ``−F_a``, hence
    ``F_a = +c_gnd·ẋ1`` on the carbody: the reaction lands on the carbody, so groundhook
    damps the bogie (its acceleration and the dynamic wheel load) at the cost of ride comfort.

    Default ``c_gnd`` (:func:`default_c_gnd`; ``DEFAULT_C_GND`` = 40 kN·s/m on the
    Manchester vehicle, scaled to the same ratio on another): ``c_gnd × 10 cm/s`` (passive bogie
    velocity RMS, class 5) ≈ f_max/2, as for the skyhook gain; it is 0.16 of the critical
    damping ``2·√((k1 + k2)·m1)`` = 245 kN·s/m of the 7.5 Hz bogie mode. On the linear
    model (class 5) it lowers the RMS bogie acceleration by about 20 % and raises the
    carbody acceleration and the suspension deflection. Works with both observation modes.
    """

    needs_velocities = True

    def __init__(self, env: Any, c_gnd: float | None = None) -> None:
        super().__init__(env)
        self.c_gnd = checked_gain(c_gnd, default_c_gnd(self._base.vehicle_params), "c_gnd")

    def force(self, x: np.ndarray) -> np.ndarray:
        """Groundhook force on the carbody (n,), N."""
        v1, _ = self._velocities(x)
        return self.c_gnd * v1


class LQR(LQDesign, Controller):
    """Linear-quadratic regulator on the linearised vertical model (needs ``observation="full"``).

    Minimises ``J = ∫ (q_acc·ẍ2² + q_defl·δ² + r_force·F_a²) dt`` with ``ẍ2 = C·x + D·F_a``
    and ``δ = x1 − x2`` (:func:`linear_model`; the track input is an unmodelled disturbance):
    ``Q = q_acc·CᵀC + q_defl·C_δᵀC_δ``, cross term ``N = q_acc·Cᵀ·D``,
    ``R = r_force + q_acc·D²``; ``P`` solves the CARE with the cross term and
    ``F_a = −K·x``, ``K = R⁻¹·(BᵀP + Nᵀ)`` (N per SI state, shape (1, 4)).

    Defaults are the env's own reward weights ``w`` (``reward_weights``) in SI:
    ``q_acc = w_a/ACC_REF²`` (s⁴/m²), ``q_defl = w_d/free_travel²`` (1/m²),
    ``r_force = w_f/f_max²`` (1/N²; the default weights 1, 1, 0.1), so the LQR minimises the
    continuous-time version of the reward the RL agents see. The design
    ignores the ±f_max limit (how often the command saturates: ``docs/results.md``).

    Parameters
    ----------
    env : a VerticalSuspension env made with ``observation="full"``.
    q_acc, q_defl, r_force : weights; ``None`` = the reward-based defaults above.
    """

    NEEDS = ("full", "LQR", "it needs the states x1, v1, x2, v2")

    def _observes(self, names: tuple[str, ...]) -> bool:
        return names[:4] == ("x1", "v1", "x2", "v2")

    def _design(self, q_acc: float | None, q_defl: float | None, r_force: float | None) -> None:
        self.q_acc, self.q_defl, self.r_force = lqr_weights(
            self._base.cfg, ACC_REF, q_acc, q_defl, r_force
        )
        self.A, self.B, self.P, self.K = vertical_lqr_gain(
            self._base.vehicle_params, self._base.cfg, q_acc, q_defl, r_force
        )

    def closed_loop_poles(self) -> np.ndarray:
        """Eigenvalues of ``A − B·K`` (1/s), unsaturated actuator."""
        return np.linalg.eigvals(self.A - self.B @ self.K)

    def force(self, x: np.ndarray) -> np.ndarray:
        """State feedback ``−K·x`` (n,), N."""
        return -(x[:, :4] @ self.K[0])


# ============================================================ VerticalVehicle-v1 (2 actuators)


class BogieSkyhook(VehicleController):
    """Skyhook damper at each bogie: ``F_i = −c_sky·v_i``, ``v_i`` the carbody's absolute
    velocity over bogie ``i`` (m/s).

    Default ``c_sky``: :func:`default_c_sky` of the one-bogie model (half the carbody on
    one bogie's secondary), ``DEFAULT_C_SKY`` (47 kN·s/m) on the Manchester vehicle (skyhook
    damping ratio 0.2 of bounce). Works with both observation modes.
    """

    def __init__(self, env: Any, c_sky: float | None = None) -> None:
        super().__init__(env)
        self.c_sky = checked_gain(c_sky, default_c_sky(self.vehicle.suspension), "c_sky")

    def force(self, x: np.ndarray) -> np.ndarray:
        """Skyhook forces (n, 2), N."""
        return -self.c_sky * self._body_velocities(x)


class ModalSkyhook(VehicleController):
    """Skyhook on the carbody's rigid modes: bounce force ``−c_bounce·ż_c`` and pitch moment
    ``−c_pitch·θ̇_c`` shared by the two actuators ``a`` from the centre.

    ``ż_c = (v_0 + v_1)/2`` and ``θ̇_c = (v_0 − v_1)/(2a)`` from the carbody velocities over
    the bogies; ``F_0,1 = −c_bounce·ż_c/2 ∓ c_pitch·θ̇_c/(2a)``. Defaults: damping ratio
    ``zeta`` (0.2, as :class:`Skyhook`) of each mode's critical damping on the secondary
    springs, ``c_bounce = 2ζ·√(2·k2·m_c)`` (94 kN·s/m) and
    ``c_pitch = 2ζ·√(2·k2·a²·J_c)`` (7.0 MN·m·s). Works with both observation modes.
    """

    def __init__(
        self,
        env: Any,
        c_bounce: float | None = None,
        c_pitch: float | None = None,
        zeta: float = 0.2,
    ) -> None:
        super().__init__(env)
        v = self.vehicle
        k2, a = v.suspension.k2, v.bogie_semi_spacing
        if not (np.isfinite(zeta) and zeta >= 0):
            raise ValueError(f"zeta must be a non-negative number, got {zeta!r}")
        if c_bounce is None:
            c_bounce = 2 * zeta * np.sqrt(2 * k2 * v.carbody_mass)
        if c_pitch is None:
            c_pitch = 2 * zeta * np.sqrt(2 * k2 * a * a * v.carbody_pitch_inertia)
        gains = {"c_bounce": c_bounce, "c_pitch": c_pitch}
        for name, value in gains.items():
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a non-negative number, got {value!r}")
        if a <= 0:
            raise ValueError("ModalSkyhook needs a positive bogie semi-spacing")
        self.c_bounce, self.c_pitch = float(gains["c_bounce"]), float(gains["c_pitch"])
        self.a = float(a)

    def force(self, x: np.ndarray) -> np.ndarray:
        """Actuator forces (n, 2), N."""
        v = self._body_velocities(x)
        bounce = -0.5 * self.c_bounce * 0.5 * (v[:, 0] + v[:, 1])
        pitch = -self.c_pitch * (v[:, 0] - v[:, 1]) / (2 * self.a) / (2 * self.a)
        return np.stack([bounce + pitch, bounce - pitch], axis=1)


class VehicleLQR(LQDesign, VehicleController):
    """LQR on the full linear whole-vehicle model (needs ``observation="full"``).

    Model :func:`railgym.vehicles.vehicle.model.linear_state_space` (14 states, linear secondary,
    track input as unmodelled disturbance). Minimises the continuous version of the env's
    reward, ``J = ∫ (q_acc·mean_p a_p² + q_defl·mean_i δ_i² + r_force·mean_i F_i²) dt``
    with the floor accelerations ``a = C·x + D·F``: ``Q = q_acc·CᵀC/3 + q_defl·Σ c_iᵀc_i/2``,
    ``N = q_acc·CᵀD/3``, ``R = r_force·I/2 + q_acc·DᵀD/3``; ``F = −K·x``. Defaults: the
    env's reward weights ``w`` in SI, ``q_acc = w_a/ACC_REF²``, ``q_defl = w_d/free_travel²``,
    ``r_force = w_f/f_max²``. The ±f_max limit is ignored by the design (the command is
    clipped).
    """

    NEEDS = ("full", "VehicleLQR", "it needs the 14 states")

    def _observes(self, names: tuple[str, ...]) -> bool:
        return names[0] == "z_c"

    def _design(self, q_acc: float | None, q_defl: float | None, r_force: float | None) -> None:
        cfg = self._base.cfg
        self.q_acc, self.q_defl, self.r_force = lqr_weights(
            cfg, VEHICLE_ACC_REF, q_acc, q_defl, r_force
        )
        self.A, self.B, self.P, self.K = vehicle_lqr_gain(
            self.vehicle, self.params, cfg, q_acc, q_defl, r_force
        )

    def closed_loop_poles(self) -> np.ndarray:
        """Eigenvalues of ``A − B·K`` (1/s), unsaturated actuators."""
        return np.linalg.eigvals(self.A - self.B @ self.K)

    def force(self, x: np.ndarray) -> np.ndarray:
        """State feedback ``−K·x`` (n, 2), N."""
        return -(x[:, :14] @ self.K.T)
