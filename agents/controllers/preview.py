"""LQ preview control of ``railgym/VerticalVehicle-v1`` with track preview (``preview=H``).

The front wheelset measures the track that the rear bogie meets ``2a/v`` later: with
``preview=H`` the env observes the track height and rate ahead of the rear wheelset up to
``H`` metres (docs/envs/vehicle_vertical.md, *Preview*). The controllers here put that known
track into the LQ design as augmented states:

* **Register.** ``r = ⌊H/(v·T)⌋ + 1`` track samples ``ξ_m = (z, ż)`` (m, m/s) at ``m·v·T``
  ahead of the rear wheelset, ``m = 0..r−1`` (``T`` = ``control_dt``, ``v`` the design
  speed), read from the preview channels by cubic Hermite interpolation in space. Each step
  the register shifts by one sample; the track entering at its head is unknown (zero mean).
* **Plant.** The 14 states of :func:`railgym.vehicles.vehicle.model.linear_state_space` sampled at
  ``T``, the force held (as the env applies it). A wheelset inside the register (sample index
  ``p_j = s_j/(v·T) ≤ r − 1``, ``s_j`` its distance ahead of the rear wheelset) sees the
  register's track, Hermite-interpolated at ``p_j`` and ``p_j + 1`` and held first-order over
  the step; the wheelsets beyond it are unknown disturbances.
* **Gains.** Cost per step: :class:`~agents.controllers.classical.VehicleLQR`'s weights
  ``(Q, N, R)`` times ``T``; the register block ``K_ξ`` of the DARE gain of the augmented
  model (plant + register, :func:`preview_gain`) is the preview feed-forward. The feedback on
  the vehicle states stays the continuous LQR gain of :class:`VehicleLQR` (the one ``lqr`` and
  ``lqg`` use), so a controller on an env without preview is :class:`VehicleLQR` (``lqr-preview``)
  or :class:`~agents.controllers.lqg.VehicleLQG` (``lq-preview``), action for action.

``F = −K·x̂ − K_ξ·ξ``, clipped to ±f_max (the filter of ``lq-preview`` is told the clipped
force). Designed for the env's control step and its speed (the middle of a speed range), as
:class:`~agents.controllers.lqg.VehicleLQG`.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from scipy.linalg import expm, solve_discrete_are

from agents.controllers.control_base import VehicleController, vehicle_lqr_gain, vehicle_lqr_weights
from agents.controllers.lqg import VehicleLQG, design_speed
from railgym.vehicles.vehicle.model import linear_state_space

__all__ = [
    "LQGPreview",
    "LQRPreview",
    "PreviewDesign",
    "preview_design",
    "preview_gain",
]


class PreviewDesign(NamedTuple):
    """The discrete augmented model of the LQ preview design (SI; ``r`` register entries,
    ``2r`` states ``[z_0, ż_0, z_1, ż_1, …]``)."""

    phi: np.ndarray  # (14, 14) vehicle transition over T
    gamma: np.ndarray  # (14, 2) force held over T, per N
    g: np.ndarray  # (14, 2r) register → vehicle states over T
    q: np.ndarray  # (14, 14) cost per step
    n: np.ndarray  # (14, 2) cross cost per step
    r: np.ndarray  # (2, 2) force cost per step
    positions: np.ndarray  # (r,) register distances ahead of the rear wheelset, m
    known: tuple[int, ...]  # wheelsets (0 front .. 3 rear) inside the register


def _track_rows(pos: np.ndarray, n: int, step: float) -> np.ndarray:
    """Rows (2m, 2n) of the cubic Hermite interpolation (as the kernel's
    :func:`~railgym.vehicles.vehicle.lanes.hermite`) of samples ``[z_0, ż_0, z_1, ż_1, …]`` on the
    grid ``0..n−1`` (``n ≥ 2``, ``step`` seconds apart: the derivative per index is
    ``ż·step``) at the fractional indices ``pos`` (m,) in ``[0, n − 1]``: ``(z, ż)`` there."""
    out = np.zeros((2 * len(pos), 2 * n))
    for row, p in enumerate(pos):
        i0 = min(int(math.floor(p)), n - 2)
        u = p - i0
        u2, u3 = u * u, u * u * u
        cols = slice(2 * i0, 2 * i0 + 4)
        out[2 * row, cols] = (2 * u3 - 3 * u2 + 1, u3 - 2 * u2 + u, -2 * u3 + 3 * u2, u3 - u2)
        out[2 * row + 1, cols] = (
            6 * u2 - 6 * u,
            3 * u2 - 4 * u + 1,
            6 * u - 6 * u2,
            3 * u2 - 2 * u,
        )
        out[2 * row, cols][1::2] *= step  # the sample derivatives per index
        out[2 * row + 1, cols][0::2] /= step  # the interpolant's derivative per second
    return out


def _held(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Φ, Γ_0, Γ_1)`` of ``ẋ = A·x + B·w`` over ``dt`` with ``w`` linear in time from
    ``w_0`` to ``w_1``: ``x(dt) = Φ·x(0) + Γ_0·w_0 + Γ_1·w_1`` (first-order hold)."""
    n, m = b.shape
    big = np.zeros((n + 2 * m, n + 2 * m))
    big[:n, :n], big[:n, n : n + m] = a * dt, b * dt
    big[n : n + m, n + m :] = np.eye(m)
    e = expm(big)
    ramp = e[:n, n + m :]  # per unit change of w over the step
    return e[:n, :n], e[:n, n : n + m] - ramp, ramp


def preview_design(
    env: Any, cfg: Any, vehicle: Any, params: Any, horizon: float, **weights: Any
) -> PreviewDesign:
    """The :class:`PreviewDesign` of ``env`` (its design speed), its ``cfg`` (``control_dt``,
    ``band``, reward weights), ``vehicle`` and its kernel ``params``, for ``horizon`` metres
    of preview; ``weights``: ``q_acc``, ``q_defl``, ``r_force`` of :class:`VehicleLQR`."""
    _, speed = design_speed(env)
    dt = float(cfg.control_dt)
    a, b, q, n_cost, r = vehicle_lqr_weights(vehicle, params, cfg, **weights)
    _, _, e, _, _ = linear_state_space(vehicle, cfg.flexible)
    step = speed * dt  # m between register entries
    n_reg = int(math.floor(horizon / step + 1e-9)) + 1
    wheel = vehicle.wheelset_positions - vehicle.wheelset_positions[-1]
    p = wheel / step  # wheelset sample indices ahead of the rear one
    known = tuple(j for j in range(4) if p[j] <= n_reg - 1)
    beyond = np.vstack([np.eye(2 * n_reg), np.zeros((2, 2 * n_reg))])  # the head + 1: zero
    phi, f0, f1 = _held(a, b, dt)
    gamma = f0 + f1  # the force held over the step
    g = np.zeros((14, 2 * n_reg))
    for j in known:
        _, g0, g1 = _held(a, e[:, [j, 4 + j]], dt)
        now = _track_rows(np.array([p[j]]), n_reg + 1, dt) @ beyond
        then = _track_rows(np.array([p[j] + 1.0]), n_reg + 1, dt) @ beyond
        g += g0 @ now + g1 @ then
    return PreviewDesign(phi, gamma, g, q * dt, n_cost * dt, r * dt, step * np.arange(n_reg), known)


def preview_gain(design: PreviewDesign) -> tuple[np.ndarray, np.ndarray]:
    """``(K_x, K_ξ)``: the gain (2, 14 + 2r) of the discrete algebraic Riccati equation of the
    augmented model ``[x; ξ]⁺ = [[Φ, G], [0, S]]·[x; ξ] + [Γ; 0]·F`` (``S`` the register's
    shift, the cost of ``design`` on ``x`` and ``F``), N per SI state.

    Solved by its block structure (Tomizuka's): ``ξ`` is neither controlled nor weighted, so
    the vehicle block ``P_xx`` is the plant's own DARE and ``K_x`` its gain; the cross block
    solves ``P_xξ = Φ_cᵀ·(P_xx·G + P_xξ·S)`` (``Φ_c = Φ − Γ·K_x``), a finite recursion over
    the register entries as ``S`` shifts them, and ``K_ξ = (R + ΓᵀP_xxΓ)⁻¹·Γᵀ(P_xx·G + P_xξ·S)``.
    """
    phi, gamma, g = design.phi, design.gamma, design.g
    p_xx = solve_discrete_are(phi, gamma, design.q, design.r, s=design.n)
    r_t = design.r + gamma.T @ p_xx @ gamma
    k_x = np.linalg.solve(r_t, gamma.T @ p_xx @ phi + design.n.T)
    phi_c_t = (phi - gamma @ k_x).T
    drive = p_xx @ g  # P_xx·G, then + P_xξ·S block by block
    p_xs = np.zeros_like(g)
    for m in range(0, g.shape[1], 2):  # (P_xξ·S) of entry m is P_xξ of entry m − 1
        if m:
            drive[:, m : m + 2] += p_xs[:, m - 2 : m]
        p_xs[:, m : m + 2] = phi_c_t @ drive[:, m : m + 2]
    return k_x, np.linalg.solve(r_t, gamma.T @ drive)


class _PreviewFeedForward:
    """The preview part shared by :class:`LQRPreview` and :class:`LQGPreview`: the design,
    the register read from the observation and its gain."""

    _base: Any
    obs_names: tuple[str, ...]
    vehicle: Any
    params: Any

    def _design_preview(self, weights: dict[str, Any]) -> None:
        """:attr:`design` (``None`` without preview), :attr:`read` (2r, n_obs): the register
        from the physical observation, :attr:`k_preview` (2, 2r): its gain, N per SI."""
        cfg = self._base.cfg
        points = np.asarray(cfg.preview_points, dtype=float)
        n_obs = len(self.obs_names)
        if points.size == 0:
            self.design = None
            self.read, self.k_preview = np.zeros((0, n_obs)), np.zeros((2, 0))
            return
        self.design = preview_design(
            self._base, cfg, self.vehicle, self.params, points[-1], **weights
        )
        _, speed = design_speed(self._base)
        spacing = points[1] - points[0]
        grid = _track_rows(self.design.positions / spacing, points.size, spacing / speed)
        first = self.obs_names.index("preview_z_0")
        self.read = np.zeros((grid.shape[0], n_obs))
        self.read[:, first : first + points.size] = grid[:, 0::2]
        self.read[:, first + points.size : first + 2 * points.size] = grid[:, 1::2]
        self.k_preview = preview_gain(self.design)[1]

    def register(self, x: np.ndarray) -> np.ndarray:
        """The register ``[z_0, ż_0, …]`` (n, 2r), m and m/s, from the physical observation."""
        return x @ self.read.T

    def feedforward(self, x: np.ndarray) -> np.ndarray:
        """The preview force ``−K_ξ·ξ`` (n, 2), N, from the physical observation (n, n_obs)."""
        return -(self.register(x) @ self.k_preview.T)


class LQRPreview(_PreviewFeedForward, VehicleController):
    """:class:`~agents.controllers.classical.VehicleLQR` (its gain ``K`` on the 14 states of
    ``observation="full"``) plus the preview feed-forward (module docstring); without preview
    its actions are :class:`VehicleLQR`'s."""

    def __init__(self, env: Any, **weights: Any) -> None:
        super().__init__(env)
        if self.obs_names[0] != "z_c":
            raise ValueError(
                "observation must be 'full' for LQRPreview (it needs the 14 states); "
                f"the env observes {list(self.obs_names)}"
            )
        self.K = vehicle_lqr_gain(self.vehicle, self.params, self._base.cfg, **weights)[3]
        self._design_preview(weights)

    def force(self, x: np.ndarray) -> np.ndarray:
        """``−K·x − K_ξ·ξ`` (n, 2), N."""
        return -(x[:, :14] @ self.K.T) + self.feedforward(x)


class LQGPreview(_PreviewFeedForward, VehicleLQG):
    """:class:`~agents.controllers.lqg.VehicleLQG` plus the preview feed-forward (module docstring):
    ``observation="sensors"`` and ``preview=H``; without preview it is :class:`VehicleLQG`.
    The filter is the LQG's (the preview channels are not measurements of it)."""

    def __init__(self, env: Any, **weights: Any) -> None:
        super().__init__(env, **weights)
        self._design_preview(weights)
