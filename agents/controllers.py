"""Classical baselines for ``railgym/VerticalSuspension-v0``: passive, skyhook, groundhook, LQR.

Every controller reads the env's observation (physical value = obs × ``obs_scale``, SI) and
returns the normalised actuator command ``F_a / f_max`` clipped to [−1, 1] with
stable-baselines3's ``predict`` signature, for one observation (n_obs,) → action (1,) or a
batch from the vector env (n, n_obs) → (n, 1), float32. Sign convention of the env (see
:mod:`railgym.vehicles.vertical`): velocities are upward, ``F_a > 0`` pushes the carbody up
and the bogie down (``m2·ẍ2 = F_s + F_a``, ``m1·ẍ1 = … − F_s − F_a``), and the
deflection rate is ``δ̇ = ẋ1 − ẋ2``.

Default gains are chosen for the Manchester vehicle (``m2`` = 16 t, ``k2`` = 860 kN/m,
``c2`` = 40 kN·s/m: body bounce 1.17 Hz, passive damping ratio 0.17) and the env's default
``f_max`` = 8 kN; each class docstring says why. Only numpy and scipy are used.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.linalg import solve_continuous_are

from railgym.envs.vertical import ACC_REF
from railgym.vehicles.vertical import P_C1, P_C2, P_K1, P_K2, P_M1, P_M2

#: skyhook gain, N·s/m: ``c_sky·σ(ẋ2)`` ≈ f_max/2 at the passive carbody velocity RMS on the
#: training case (8.6 cm/s, class 5 at 144 km/h), i.e. a skyhook damping ratio of 0.2
DEFAULT_C_SKY = 4.7e4
#: groundhook gain, N·s/m: ``c_gnd·σ(ẋ1)`` ≈ f_max/2 at the passive bogie velocity RMS on the
#: training case (10 cm/s), like the skyhook gain; 0.16 of the bogie mode's critical damping
DEFAULT_C_GND = 4.0e4


class _Controller:
    """Shared plumbing: env checks, observation decoding and the ``predict`` shape rules."""

    def __init__(self, env: Any) -> None:
        base = getattr(env, "unwrapped", env)
        for attr in ("obs_names", "obs_scale", "cfg"):
            if not hasattr(base, attr):
                raise ValueError(
                    f"env must be a railgym VerticalSuspension env (no attribute {attr!r}), "
                    f"got {type(base).__name__}"
                )
        self.obs_names: tuple[str, ...] = tuple(base.obs_names)
        self.obs_scale = np.asarray(base.obs_scale, dtype=np.float64)
        self.f_max = float(base.cfg.f_max)
        self._base = base

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

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, None]:
        """Action ``F_a / f_max`` clipped to [−1, 1]: (1,) for one obs, (n, 1) for a batch.

        ``state``, ``episode_start`` and ``deterministic`` exist for SB3 compatibility; the
        controllers are memoryless and deterministic.
        """
        obs = np.asarray(observation, dtype=np.float64)
        n_obs = len(self.obs_names)
        if obs.ndim not in (1, 2) or obs.shape[-1] != n_obs:
            raise ValueError(
                f"observation must have shape ({n_obs},) or (n, {n_obs}), got {obs.shape}"
            )
        x = np.atleast_2d(obs) * self.obs_scale
        u = np.clip(self.force(x) / self.f_max, -1.0, 1.0).astype(np.float32)[:, None]
        return (u[0] if obs.ndim == 1 else u), None


class Passive(_Controller):
    """Zero actuator force: the passive suspension alone."""

    def force(self, x: np.ndarray) -> np.ndarray:
        """Zero force (n,), N."""
        return np.zeros(x.shape[0])


class Skyhook(_Controller):
    """Skyhook damper on the carbody, ``F = −c_sky·ẋ2`` (absolute carbody velocity).

    ``mode="active"``: the actuator applies ``−c_sky·ẋ2`` whatever its power flow.
    ``mode="semi-active"`` (clipped skyhook): the actuator emulates a variable damper in
    parallel with the passive one. A damper between bogie and carbody can only push the
    carbody with the sign of ``ẋ1 − ẋ2`` (it dissipates energy: ``F·(ẋ2 − ẋ1) ≤ 0``), so the
    skyhook force is applied only when ``ẋ2·(ẋ2 − ẋ1) > 0`` and is 0 otherwise; with the
    sensors, ``ẋ1 = ẋ2 + δ̇`` (``carbody_vel`` + ``deflection_rate``).

    Default ``c_sky`` (``DEFAULT_C_SKY`` = 47 kN·s/m): damping ratio
    ``c_sky / (2·√(k2·m2))`` = 0.2 on the 1.17 Hz body mode on top of the passive 0.17, and
    ``c_sky × 8.6 cm/s`` (passive carbody velocity RMS, class 5) ≈ 4 kN = f_max/2, so the
    command saturates only on the largest peaks. Works with both observation modes.
    """

    def __init__(self, env: Any, c_sky: float = DEFAULT_C_SKY, mode: str = "active") -> None:
        super().__init__(env)
        if not (np.isfinite(c_sky) and c_sky >= 0):
            raise ValueError(f"c_sky must be a non-negative number in N·s/m, got {c_sky!r}")
        if mode not in ("active", "semi-active"):
            raise ValueError(f"mode must be 'active' or 'semi-active', got {mode!r}")
        self.c_sky, self.mode = float(c_sky), mode

    def force(self, x: np.ndarray) -> np.ndarray:
        """Skyhook force (n,), N; zero where a semi-active damper could not produce it."""
        v1, v2 = self._velocities(x)
        f = -self.c_sky * v2
        if self.mode == "semi-active":
            f = np.where(v2 * (v2 - v1) > 0.0, f, 0.0)
        return f


class Groundhook(_Controller):
    """Groundhook damper on the bogie: ``−c_gnd·ẋ1`` on the bogie, i.e. ``F_a = +c_gnd·ẋ1``.

    The ideal groundhook is a damper from the bogie to the (inertial) ground, force
    ``−c_gnd·ẋ1`` on the bogie. The actuator pushes the bogie with ``−F_a``, hence
    ``F_a = +c_gnd·ẋ1`` on the carbody: the reaction lands on the carbody, so groundhook
    damps the bogie (its acceleration and the dynamic wheel load) at the cost of ride comfort.

    Default ``c_gnd`` (``DEFAULT_C_GND`` = 40 kN·s/m): ``c_gnd × 10 cm/s`` (passive bogie
    velocity RMS, class 5) ≈ f_max/2, as for the skyhook gain; it is 0.16 of the critical
    damping ``2·√((k1 + k2)·m1)`` = 245 kN·s/m of the 7.5 Hz bogie mode. On the linear
    model (class 5) it lowers the RMS bogie acceleration by about 20 % and raises the
    carbody acceleration and the suspension deflection. Works with both observation modes.
    """

    def __init__(self, env: Any, c_gnd: float = DEFAULT_C_GND) -> None:
        super().__init__(env)
        if not (np.isfinite(c_gnd) and c_gnd >= 0):
            raise ValueError(f"c_gnd must be a non-negative number in N·s/m, got {c_gnd!r}")
        self.c_gnd = float(c_gnd)

    def force(self, x: np.ndarray) -> np.ndarray:
        """Groundhook force on the carbody (n,), N."""
        v1, _ = self._velocities(x)
        return self.c_gnd * v1


def linear_model(params: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Linear vertical model ``ẋ = A·x + B·F_a + E·f`` and its carbody acceleration.

    States ``x = [x1, v1, x2, v2]`` (m, m/s) from the static equilibrium, input ``F_a`` (N),
    linear secondary suspension ``k2, c2``; the track force ``f = k1·z + c1·ż`` is the
    disturbance (not returned). ``params`` is :meth:`VerticalVehicle.kernel_params`.

    Returns
    -------
    A (4, 4), B (4, 1), C (4,), D
        with ``ẍ2 = C·x + D·F_a`` (m/s²).
    """
    m1, m2, k1, c1 = params[P_M1], params[P_M2], params[P_K1], params[P_C1]
    k2, c2 = params[P_K2], params[P_C2]
    a = np.array([
        [0.0, 1.0, 0.0, 0.0],
        [-(k1 + k2) / m1, -(c1 + c2) / m1, k2 / m1, c2 / m1],
        [0.0, 0.0, 0.0, 1.0],
        [k2 / m2, c2 / m2, -k2 / m2, -c2 / m2],
    ])  # fmt: skip
    b = np.array([[0.0], [-1.0 / m1], [0.0], [1.0 / m2]])
    return a, b, a[3].copy(), 1.0 / m2


class LQR(_Controller):
    """Linear-quadratic regulator on the linearised vertical model (needs ``observation="full"``).

    Minimises ``J = ∫ (q_acc·ẍ2² + q_defl·δ² + r_force·F_a²) dt`` with ``ẍ2 = C·x + D·F_a``
    and ``δ = x1 − x2`` (:func:`linear_model`; the track input is an unmodelled disturbance):
    ``Q = q_acc·CᵀC + q_defl·C_δᵀC_δ``, cross term ``N = q_acc·Cᵀ·D``,
    ``R = r_force + q_acc·D²``; ``P`` solves the CARE with the cross term and
    ``F_a = −K·x``, ``K = R⁻¹·(BᵀP + Nᵀ)`` (N per SI state, shape (1, 4)).

    Defaults are the env's own reward weights in SI: ``q_acc = 1/ACC_REF²`` (s⁴/m²),
    ``q_defl = 1/free_travel²`` (1/m²), ``r_force = 0.1/f_max²`` (1/N²), so the LQR
    minimises the continuous-time version of the reward the RL agents see. The design
    ignores the ±f_max limit: on class 5 at 144 km/h the command saturates in about 30 % of
    the steps (50 % on class 4) and still gives the lowest carbody acceleration of these
    baselines (linear backend, 4 seeds × 20 s: 0.30 m/s² vs 0.65 passive, 0.48 skyhook);
    a tenfold ``r_force`` keeps it unsaturated at 0.42 m/s².

    Parameters
    ----------
    env : a VerticalSuspension env made with ``observation="full"``.
    q_acc, q_defl, r_force : weights; ``None`` = the reward-based defaults above.
    """

    def __init__(
        self,
        env: Any,
        q_acc: float | None = None,
        q_defl: float | None = None,
        r_force: float | None = None,
    ) -> None:
        super().__init__(env)
        if self.obs_names[:4] != ("x1", "v1", "x2", "v2"):
            raise ValueError(
                "observation must be 'full' for LQR (it needs the states x1, v1, x2, v2); "
                f"the env observes {list(self.obs_names)}"
            )
        cfg = self._base.cfg
        weights = {
            "q_acc": 1.0 / ACC_REF**2 if q_acc is None else q_acc,
            "q_defl": 1.0 / cfg.free_travel**2 if q_defl is None else q_defl,
            "r_force": 0.1 / cfg.f_max**2 if r_force is None else r_force,
        }
        for name, value in weights.items():
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a non-negative number, got {value!r}")
        if weights["r_force"] <= 0:
            raise ValueError(f"r_force must be positive, got {weights['r_force']!r}")
        self.q_acc, self.q_defl, self.r_force = weights.values()
        self.A, self.B, c, d = linear_model(self._base.sim.params)
        c_d = np.array([1.0, 0.0, -1.0, 0.0])
        q = self.q_acc * np.outer(c, c) + self.q_defl * np.outer(c_d, c_d)
        n = self.q_acc * d * c[:, None]
        r = np.array([[self.r_force + self.q_acc * d * d]])
        p = solve_continuous_are(self.A, self.B, q, r, s=n)
        self.P = p
        self.K = np.linalg.solve(r, self.B.T @ p + n.T)

    def closed_loop_poles(self) -> np.ndarray:
        """Eigenvalues of ``A − B·K`` (1/s), unsaturated actuator."""
        return np.linalg.eigvals(self.A - self.B @ self.K)

    def force(self, x: np.ndarray) -> np.ndarray:
        """State feedback ``−K·x`` (n,), N."""
        return -(x[:, :4] @ self.K[0])


# Crash controllers of railgym/TrainCrash-v0 (same predict interface), defined with their
# rollout and search helpers in agents.crash_baselines.
from agents.crash_baselines import (  # noqa: E402, F401  (re-exported)
    BEST_CONSTANT_ACTION,
    ConstantAbsorber,
    CrashPassive,
    SpeedAdaptive,
)
