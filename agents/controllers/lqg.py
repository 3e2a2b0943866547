"""Observer-based LQR (LQG) baselines: a steady-state Kalman filter on the linear model, fed by
the env's sensor observation, and the full-state LQR gain of :mod:`agents.controllers.classical`
on the estimate. :class:`LQG` is for ``railgym/VerticalSuspension-v1`` (one bogie),
:class:`VehicleLQG` for ``railgym/VerticalVehicle-v1`` (two actuators); both run as ``lqg`` in
``railgym evaluate``.

Filter model (continuous, then sampled at ``control_dt`` with the actuator force held, as the
env applies it): the linear vehicle of the LQR plus, per wheel input, a shaping filter whose
output has the FRA spectrum of the env's track class at its speed (:func:`fra_shaping`).
Process noise: that filter's white-noise intensity. Measurement noise: the env's
``sensor_noise`` times each channel's ``obs_scale`` (the std it adds, SI), at least
:data:`MIN_SENSOR_NOISE` × ``obs_scale`` (model mismatch: the reference suspension is not
linear). The control is the LQR's ``F = −K·x̂`` on the vehicle states of the estimate (the track
states get no gain), clipped to ±f_max; the filter is told the clipped force.

The estimate is kept in the controller between ``predict`` calls, one row per sub-env; it
starts at rest (the env's reset state) and a row is reset where ``episode_start`` is True (or
all rows when the batch size changes). Make a new controller (or pass ``episode_start``) for
every new episode.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.linalg import expm, solve_discrete_are

from agents.controllers.control_base import (
    Controller,
    LQDesign,
    VehicleController,
    vehicle_lqr_gain,
    vertical_lqr_gain,
)
from railgym.track import class_parameters
from railgym.vehicles.vehicle.model import linear_state_space
from railgym.vehicles.vertical.params import P_C1, P_K1, P_M1

__all__ = ["LQG", "MIN_SENSOR_NOISE", "KalmanFilter", "VehicleLQG", "fra_shaping"]

#: lowest sensor-noise std the filter assumes, in units of each channel's ``obs_scale``
MIN_SENSOR_NOISE = 0.01


def fra_shaping(track_class: int, speed: float, longest: float) -> tuple[np.ndarray, float]:
    """Shaping filter of the FRA vertical profile seen at ``speed`` (m/s).

    States ``[z, y]`` (m, m/s): ``ż = y − ω_r·z``, ``ẏ = −ω_c·y + w`` with white noise ``w`` of
    intensity ``q`` (m²/s³), ``ω_c = V·Ω_c`` and ``ω_r = 2πV/longest`` (``longest``: the
    longest wavelength of the env's band, m). For ``ω ≫ ω_r`` the one-sided PSD of ``z`` is
    the FRA ``k·A_v·Ω_c²/(Ω²(Ω² + Ω_c²))`` at ``Ω = ω/V`` (per rad/m, divided by V), which
    sets ``q = π·k·A_v·Ω_c²·V³``.

    Returns
    -------
    A (2, 2) in 1/s, q in m²/s³.
    """
    p = class_parameters(track_class)
    w_c, w_r = speed * p.omega_c, 2.0 * math.pi * speed / longest
    a = np.array([[-w_r, 1.0], [0.0, -w_c]])
    return a, math.pi * p.k * p.a_v * p.omega_c**2 * speed**3


class KalmanFilter:
    """Steady-state Kalman filter of ``ẋ = A·x + B·u + G·w`` sampled every ``dt`` (``u`` held),
    measured as ``y_k = C·x_k + D·u_{k−1}`` with white noise of covariance ``R``.

    ``w`` is continuous white noise of intensity ``diag(q)``; its discrete covariance is Van
    Loan's integral. ``P`` is the a-priori error covariance (discrete Riccati equation), ``M``
    the gain of the measurement update ``x⁺ = x⁻ + M·(y − C·x⁻ − D·u)``, and the prediction is
    ``x⁻ ← Φ·x⁺ + Γ·u``.
    """

    def __init__(
        self,
        a: np.ndarray,
        b: np.ndarray,
        g: np.ndarray,
        q: np.ndarray,
        c: np.ndarray,
        d: np.ndarray,
        r: np.ndarray,
        dt: float,
    ) -> None:
        n, m = b.shape
        big = np.zeros((n + m, n + m))
        big[:n, :n], big[:n, n:] = a, b
        e = expm(big * dt)
        self.phi, self.gamma = e[:n, :n], e[:n, n:]
        van = np.zeros((2 * n, 2 * n))  # Van Loan: Q_d = Φ·∫ e^{−Aτ} G q Gᵀ e^{−Aᵀτ} dτ
        van[:n, :n], van[:n, n:], van[n:, n:] = -a, g @ np.diag(q) @ g.T, a.T
        v = expm(van * dt)
        qd = v[n:, n:].T @ v[:n, n:]
        self.q_d = 0.5 * (qd + qd.T)
        self.c, self.d, self.r = c, d, r
        self.P = solve_discrete_are(self.phi.T, c.T, self.q_d, r)
        self.M = self.P @ c.T @ np.linalg.inv(c @ self.P @ c.T + r)

    def error_poles(self) -> np.ndarray:
        """Eigenvalues of the estimation error dynamics ``Φ·(I − M·C)`` (discrete)."""
        return np.linalg.eigvals(self.phi @ (np.eye(self.phi.shape[0]) - self.M @ self.c))


class LQGMixin:
    """Estimate bookkeeping shared by :class:`LQG` and :class:`VehicleLQG`."""

    kf: KalmanFilter
    K: np.ndarray  # (n_act, n_aug): the LQR gain padded with zeros on the track states
    f_max: float
    n_act: int
    x_pred: np.ndarray  # (n, n_aug) a-priori estimate for the coming observation
    u_prev: np.ndarray  # (n, n_act) force applied over the last step, N

    def _start(self, n: int) -> None:
        self.x_pred = np.zeros((n, self.kf.phi.shape[0]))
        self.u_prev = np.zeros((n, self.n_act))

    def predict_action(
        self, observation: Any, episode_start: Any, deterministic: bool
    ) -> np.ndarray:
        """As :meth:`agents.controllers.feedback.ObservationController.predict_action`;
        ``episode_start`` (bool per sub-env) puts those estimates back at rest before this
        observation."""
        n = 1 if np.ndim(observation) == 1 else int(np.shape(observation)[0])
        if getattr(self, "x_pred", None) is None or self.x_pred.shape[0] != n:
            self._start(n)
        elif episode_start is not None:
            rows = np.flatnonzero(np.broadcast_to(np.asarray(episode_start, bool), (n,)))
            self.x_pred[rows] = 0.0
            self.u_prev[rows] = 0.0
        return super().predict_action(observation, episode_start, deterministic)  # type: ignore[misc]

    def feedforward(self, x: np.ndarray) -> np.ndarray:
        """Force added to the LQR's (n, n_act), N, from the physical observation: none here
        (the preview controllers of :mod:`agents.controllers.preview` add theirs)."""
        return np.zeros((x.shape[0], self.n_act))

    def action(self, x: np.ndarray) -> np.ndarray:
        """Filter update with the sensor channels of the observation (the first ones; an env
        with track preview adds its own after them), LQR on the estimate plus
        :meth:`feedforward`, filter prediction."""
        kf = self.kf
        innov = x[:, : kf.c.shape[0]] - self.x_pred @ kf.c.T - self.u_prev @ kf.d.T
        x_est = self.x_pred + innov @ kf.M.T
        u = np.clip(-(x_est @ self.K.T) + self.feedforward(x), -self.f_max, self.f_max)
        self.x_est = x_est
        self.x_pred = x_est @ kf.phi.T + u @ kf.gamma.T
        self.u_prev = u
        return u / self.f_max

    def closed_loop_poles(self) -> np.ndarray:
        """Discrete closed-loop poles of plant + filter + gain (unsaturated): those of
        ``Φ − Γ·K`` and of the filter error ``Φ·(I − M·C)`` (separation principle)."""
        kf = self.kf
        return np.concatenate([np.linalg.eigvals(kf.phi - kf.gamma @ self.K), kf.error_poles()])


def _noise(base: Any, scale: np.ndarray) -> np.ndarray:
    """Measurement noise covariance (diagonal), SI², from the env's ``sensor_noise``."""
    sigma = max(float(base.cfg.sensor_noise), MIN_SENSOR_NOISE)
    return np.diag((sigma * scale) ** 2)


def design_speed(env: Any) -> tuple[int, float]:
    """Track class and speed (m/s) of the env (a speed range: its middle)."""
    single = getattr(env, "single_env", env)
    speed = getattr(single, "speed", None)
    if speed is None:
        speed = 0.5 * (single.speeds[0] + single.speeds[1])
    return int(single.track_class), float(speed)


class LQG(LQGMixin, LQDesign, Controller):
    """LQG for ``railgym/VerticalSuspension-v1`` with the sensor observation (carbody and bogie
    accelerations, deflection and its rate, carbody velocity: ``observation="sensors"``).

    Filter states ``[x1, v1, x2, v2, z, y]``: :func:`railgym.vehicles.vertical.params.linear_model`
    with the track force ``k1·z + c1·ż`` and the class's shaping filter at the env's speed
    (:func:`fra_shaping`); gain: :class:`agents.controllers.classical.LQR`'s ``K`` (the env's reward
    weights, or ``q_acc``, ``q_defl``, ``r_force``). The wheelbase filter of the env
    (``wheelbase=``) is not modelled.
    """

    SENSORS = ("carbody_acc", "bogie_acc", "deflection", "deflection_rate", "carbody_vel")

    NEEDS = ("sensors", "LQG", "with 'full', use LQR")

    def _observes(self, names: tuple[str, ...]) -> bool:
        return names == self.SENSORS

    def _design(self, q_acc: float | None, q_defl: float | None, r_force: float | None) -> None:
        base = self._base
        params = base.vehicle_params
        a4, b4, _, k = vertical_lqr_gain(params, base.cfg, q_acc, q_defl, r_force)
        track_class, speed = design_speed(base)
        a_t, q = fra_shaping(track_class, speed, base.cfg.band[1])
        k1, c1, m1 = params[P_K1], params[P_C1], params[P_M1]
        a = np.zeros((6, 6))
        a[:4, :4], a[4:, 4:] = a4, a_t
        # track force on the bogie k1·z + c1·ż with ż = y − ω_r·z (a_t[0, 0] = −ω_r)
        a[1, 4], a[1, 5] = (k1 + c1 * a_t[0, 0]) / m1, c1 / m1
        b = np.zeros((6, 1))
        b[:4] = b4
        g = np.zeros((6, 1))
        g[5, 0] = 1.0
        # channels: carbody_acc = ẋ[3], bogie_acc = ẋ[1], δ, δ̇, v2
        c = np.zeros((5, 6))
        d = np.zeros((5, 1))
        c[0], d[0] = a[3], b[3]
        c[1], d[1] = a[1], b[1]
        c[2, [0, 2]] = 1.0, -1.0
        c[3, [1, 3]] = 1.0, -1.0
        c[4, 3] = 1.0
        r = _noise(base, self.obs_scale)
        self.kf = KalmanFilter(a, b, g, np.array([q]), c, d, r, base.cfg.control_dt)
        self.K = np.zeros((1, 6))
        self.K[:, :4] = k
        self.x_pred = None  # type: ignore[assignment]


class VehicleLQG(LQGMixin, LQDesign, VehicleController):
    """LQG for ``railgym/VerticalVehicle-v1`` with the sensor observation (three floor and two
    bogie accelerations, the two secondary deflections and their rates, the carbody velocity
    over each bogie: ``observation="sensors"``).

    Filter states: the 14 of :func:`railgym.vehicles.vehicle.model.linear_state_space` and a shaping
    filter (:func:`fra_shaping`, 2 states) per wheelset, the four taken as independent (the
    delay between wheelsets is not modelled); gain:
    :class:`agents.controllers.classical.VehicleLQR`'s ``K``. Designed for the env's track class at
    its speed (the middle of a speed range).
    """

    NEEDS = ("sensors", "VehicleLQG", "with 'full', use VehicleLQR")

    def _observes(self, names: tuple[str, ...]) -> bool:
        return names[0] == "acc_front"

    def _design(self, q_acc: float | None, q_defl: float | None, r_force: float | None) -> None:
        base = self._base
        cfg, p = base.cfg, self.params
        a14, b14, _, k = vehicle_lqr_gain(self.vehicle, p, cfg, q_acc, q_defl, r_force)
        _, _, e, _, _ = linear_state_space(self.vehicle, cfg.flexible)
        track_class, speed = design_speed(base)
        a_t, q = fra_shaping(track_class, speed, cfg.band[1])
        n = 14 + 8
        a = np.zeros((n, n))
        a[:14, :14] = a14
        for j in range(4):  # wheelset j: states (w_j, y_j) at 14 + 2j; ẇ_j = y_j − ω_r·w_j
            i = 14 + 2 * j
            a[i : i + 2, i : i + 2] = a_t
            a[:14, i] = e[:, j] + a_t[0, 0] * e[:, 4 + j]
            a[:14, i + 1] = e[:, 4 + j]
        b = np.zeros((n, 2))
        b[:14] = b14
        g = np.zeros((n, 4))
        g[15::2, :] = np.eye(4)
        xs = (p.a, -p.a)
        rows_x, rows_d = np.zeros((11, n)), np.zeros((11, n))  # channel = rx·x + rd·ẋ
        for j, (w_q, x_b) in enumerate(((p.phi_a, xs[0]), (p.phi_c, 0.0), (p.phi_a, xs[1]))):
            rows_d[j, [7, 8, 9]] = 1.0, x_b, w_q
        rows_d[3, 10], rows_d[4, 12] = 1.0, 1.0
        for bgi, x_b in enumerate(xs):
            rows_x[5 + bgi, [3 + 2 * bgi, 0, 1, 2]] = 1.0, -1.0, -x_b, -p.phi_a
            rows_x[7 + bgi, [10 + 2 * bgi, 7, 8, 9]] = 1.0, -1.0, -x_b, -p.phi_a
            rows_x[9 + bgi, [7, 8, 9]] = 1.0, x_b, p.phi_a
        c = rows_x + rows_d @ a
        d = rows_d @ b
        r = _noise(base, self.obs_scale[: c.shape[0]])  # the sensor channels
        self.kf = KalmanFilter(a, b, g, np.full(4, q), c, d, r, cfg.control_dt)
        self.K = np.zeros((2, n))
        self.K[:, :14] = k
        self.x_pred = None  # type: ignore[assignment]
