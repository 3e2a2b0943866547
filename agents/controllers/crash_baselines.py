"""Classical baselines for ``railgym/TrainCrash-v1``: passive, constant absorber, speed-adaptive.

Every controller reads the env's observation (physical value = obs × ``obs_scale``, SI: the
cars' displacement, velocity and acceleration, each zone's crush, force and absorber scale)
and returns one action per crush zone in [−1, 1] (the absorber's force scale target
``1 + absorber_range · action``) with stable-baselines3's ``predict`` signature, for one
observation (n_obs,) → (zones,) or a batch from the vector env (n, n_obs) → (n, zones),
float32; as :mod:`agents.controllers` does for the vertical env.

:func:`rollout` runs a controller on the vector env and records the histories that
:mod:`railgym.vehicles.crash.criteria` evaluates; :func:`search_constant` is the search for
the best constant setting over an impact envelope (``docs/envs/crash_baselines.md``).
"""

from __future__ import annotations

import itertools
from typing import Any, NamedTuple

import numpy as np

from agents.controllers.feedback import ObservationController
from railgym.envs.crash.env import TrainCrashVectorEnv
from railgym.vehicles.crash.criteria import CrashCriteria, crash_criteria
from railgym.vehicles.crash.scenario import CrushZone

#: constant absorber action (wall, interface) found by :func:`search_constant` on the
#: reference over 25–50 km/h, levels −1 … 1 in steps of 0.25 (docs/envs/crash_baselines.md)
BEST_CONSTANT_ACTION = (0.0, -1.0)


class _CrashController(ObservationController):
    """Crash-env baselines: one absorber action per crush zone."""

    env_name = "TrainCrash"

    def __init__(self, env: Any) -> None:
        super().__init__(env)
        base = self._base
        if not hasattr(base.cfg, "absorber_stroke"):
            raise ValueError(f"env must be a railgym TrainCrash env, got {type(base).__name__}")
        self.cfg = base.cfg
        self.n_zones = int(np.asarray(base.cfg.absorber_stroke).size)

    def columns(self, prefix: str) -> np.ndarray:
        """Observation columns whose name starts with ``prefix`` (front to back)."""
        return np.array([i for i, n in enumerate(self.obs_names) if n.startswith(prefix)])

    def action(self, x: np.ndarray) -> np.ndarray:
        """Action (n, zones) from the physical observation (n, n_obs)."""
        raise NotImplementedError


class CrashPassive(_CrashController):
    """Action 0 everywhere: every absorber at its nominal force (the passive train)."""

    def action(self, x: np.ndarray) -> np.ndarray:
        """Zeros (n, zones)."""
        return np.zeros((x.shape[0], self.n_zones))


class ConstantAbsorber(_CrashController):
    """One constant action per zone for the whole crash.

    Parameters
    ----------
    env : a TrainCrash env.
    action : per zone (wall first), one number for every zone, or a ``(wall, interface)``
        pair (every interface the second); default :data:`BEST_CONSTANT_ACTION` (the paper
        train's best setting over its envelope; on another train that setting, not one
        searched for it: :func:`search_constant`).
    """

    def __init__(self, env: Any, action: Any = BEST_CONSTANT_ACTION) -> None:
        super().__init__(env)
        a = np.asarray(action, dtype=np.float64)
        if a.shape == (2,) and self.n_zones > 2:
            a = np.concatenate([a[:1], np.full(self.n_zones - 1, a[1])])
        a = np.broadcast_to(a, (self.n_zones,)).copy()
        if not np.all(np.isfinite(a)) or np.any(np.abs(a) > 1):
            raise ValueError(f"action must be in [-1, 1] per zone, got {action!r}")
        self.constant = a

    def action(self, x: np.ndarray) -> np.ndarray:
        """The constant action (n, zones)."""
        return np.broadcast_to(self.constant, (x.shape[0], self.n_zones))


def remaining_absorber_energy(zone: CrushZone, crush: np.ndarray) -> np.ndarray:
    """Energy (J) the zone's nominal envelope (no folding wave) absorbs from ``crush`` (m) to
    its absorber stroke; 0 beyond the stroke."""
    grid = np.linspace(0.0, zone.absorber_stroke, 2001)
    f = np.interp(grid, np.concatenate(([0.0], zone.stroke)), np.concatenate(([0.0], zone.force)))
    energy = np.concatenate(([0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(grid))))
    return energy[-1] - np.interp(np.clip(crush, 0.0, zone.absorber_stroke), grid, energy)


class SpeedAdaptive(_CrashController):
    """Absorber force from the observed speed by the energy balance over the stroke left.

    Each zone is set so that, at its force level, the stroke it has left could absorb the
    kinetic energy ``½ M v²`` of everything behind it: for the wall zone the whole train
    (``M`` = all cars, ``v`` = the lead car's speed towards the barrier), for the interface
    behind car k the cars behind it (``v`` = the speed of car k + 1). The absorber scale is
    ``s = margin · ½ M v² / E_left(crush)`` (:func:`remaining_absorber_energy` at nominal
    force), so the action is ``(s − 1) / absorber_range``, clipped to [−1, 1]. Every zone is
    thus sized as if it alone stopped the mass behind it, an upper bound on its share (the
    other zones and friction take the rest): a slow crash gets soft absorbers, a fast one the
    stiffest allowed. ``margin`` (≥ 0) scales the demand.
    """

    def __init__(self, env: Any, margin: float = 1.0) -> None:
        super().__init__(env)
        if not (np.isfinite(margin) and margin >= 0):
            raise ValueError(f"margin must be a non-negative number, got {margin!r}")
        self.margin = float(margin)
        sc = self.cfg.scenario
        masses = sc.car_masses
        self.behind = np.array([masses[k:].sum() for k in range(sc.n_cars)])
        self.zones = [sc.wall] + [sc.interface] * (sc.n_cars - 1)
        self.v_cols = self.columns("v_")
        self.crush_cols = self.columns("crush_")

    def action(self, x: np.ndarray) -> np.ndarray:
        """Energy-balance action (n, zones)."""
        v = np.maximum(x[:, self.v_cols], 0.0)  # zone k is stopped by car k's speed
        demand = self.margin * 0.5 * self.behind * v**2
        left = np.column_stack(
            [
                remaining_absorber_energy(z, x[:, c])
                for z, c in zip(self.zones, self.crush_cols, strict=True)
            ]
        )
        scale = np.divide(demand, left, out=np.full_like(demand, np.inf), where=left > 0)
        return (scale - 1.0) / self.cfg.absorber_range


class Rollout(NamedTuple):
    """Histories of one crash (:func:`rollout`): time (n,) s, car velocity and acceleration
    (n, cars) m/s, m/s², zone crush (n, zones) m, absorber stroke (zones,) m, gravity m/s²;
    ``diverged``: the env cut the run where its state diverged (``info["diverged"]``: a zone
    crushed through a car, or a state too violent to score), so the histories end there."""

    t: np.ndarray
    v: np.ndarray
    a: np.ndarray
    crush: np.ndarray
    absorber_stroke: np.ndarray
    gravity: float
    diverged: bool = False

    def criteria(self, **kwargs: Any) -> CrashCriteria:
        """:func:`railgym.vehicles.crash.criteria.crash_criteria` of this crash."""
        args = (self.t, self.v, self.a, self.crush, self.absorber_stroke)
        return crash_criteria(*args, g=self.gravity, **kwargs)


def rollout(
    env: TrainCrashVectorEnv,
    controller: Any,
    seed: int = 0,
    options: dict[str, Any] | None = None,
) -> list[Rollout]:
    """Run one episode of every sub-env of ``env`` under ``controller.predict`` (reset with
    ``seed`` and ``options``; ``deterministic=True``, so a stable-baselines3 policy acts by its
    mean action, not a sample of its exploration noise); histories from the env's accessors
    (float64), each until its sub-env terminates or truncates, and whether the env cut it as
    diverged."""
    obs, _ = env.reset(seed=seed, options=options)
    n = env.num_envs
    rec: list[list[np.ndarray]] = [[] for _ in range(3)]

    def record() -> None:
        rec[0].append(env.velocities)
        rec[1].append(env.accelerations)
        rec[2].append(env.crush)

    record()
    length = np.zeros(n, np.int64)
    done = np.zeros(n, bool)
    diverged = np.zeros(n, bool)
    while not done.all():
        action, _ = controller.predict(obs, deterministic=True)
        obs, _, term, trunc, info = env.step(action)
        record()
        length[~done] += 1
        diverged |= ~done & np.asarray(info["diverged"], bool)
        done |= term | trunc
    v, a, crush = (np.stack(r, axis=1) for r in rec)
    t = np.arange(length.max() + 1) * env.cfg.control_dt
    stroke, g = env.absorber_stroke, env.cfg.scenario.gravity
    return [
        Rollout(t[: m + 1], v[i, : m + 1], a[i, : m + 1], crush[i, : m + 1], stroke, g, bool(d))
        for i, (m, d) in enumerate(zip(length, diverged, strict=True))
    ]


class ConstantSearch(NamedTuple):
    """Result of :func:`search_constant`.

    Attributes
    ----------
    best : the best action (zones,). score : its mean worst-car peak deceleration, g.
    candidates : every action tried (k, zones). peak : (speeds, k) worst car's peak
        deceleration, g. intrusion : (speeds, k) largest zone intrusion, m.
    admissible : (k,) the candidates that meet the intrusion constraints.
    """

    best: np.ndarray
    score: float
    candidates: np.ndarray
    peak: np.ndarray
    intrusion: np.ndarray
    admissible: np.ndarray


def search_constant(
    speeds: Any,
    levels: Any = (-1.0, -0.5, 0.0, 0.5, 1.0),
    intrusion_free_up_to: float = 12.5,
    **env_kwargs: Any,
) -> ConstantSearch:
    """Grid search of the constant action per zone (all combinations of ``levels``) over the
    speeds (m/s) of an envelope.

    The best setting has the lowest mean over the speeds of the worst car's peak deceleration
    among the admissible ones: no more intrusion than passive at any speed and none at speeds
    up to ``intrusion_free_up_to`` (m/s; default 45 km/h), the intrusion targets of issue 11.
    ``env_kwargs`` go to :class:`~railgym.envs.crash.env.TrainCrashVectorEnv` (e.g.
    ``backend="reference"``); every speed runs all candidates in one vector env.
    """
    speeds = np.asarray(speeds, dtype=np.float64)
    probe = TrainCrashVectorEnv(num_envs=1, **env_kwargs)
    n_zones = probe.single_action_space.shape[0]
    cand = np.array(list(itertools.product(levels, repeat=n_zones)), dtype=np.float64)
    if not np.any(np.all(cand == 0.0, axis=1)):
        cand = np.vstack([np.zeros(n_zones), cand])  # passive is the reference for intrusion
    peaks, intr = [], []
    for v in speeds:
        env = TrainCrashVectorEnv(num_envs=len(cand), speed=float(v), **env_kwargs)
        crits = [r.criteria() for r in rollout(env, FixedActions(cand))]
        peaks.append([c.peak_decel_g.max() for c in crits])
        intr.append([c.intrusion_m.max() for c in crits])
    peak, intrusion = np.array(peaks), np.array(intr)
    passive = int(np.flatnonzero(np.all(cand == 0.0, axis=1))[0])
    ok = np.all(intrusion <= intrusion[:, [passive]] + 1e-6, axis=0)
    ok &= np.all(intrusion[speeds <= intrusion_free_up_to] == 0.0, axis=0)
    score = np.where(ok, peak.mean(axis=0), np.inf)
    best = int(np.argmin(score))
    return ConstantSearch(cand[best], float(score[best]), cand, peak, intrusion, ok)


class FixedActions:
    """A fixed action per sub-env (rows of ``actions``), for :func:`search_constant`."""

    def __init__(self, actions: np.ndarray) -> None:
        self.actions = actions.astype(np.float32)

    def predict(self, observation: Any, **_: Any) -> tuple[np.ndarray, None]:
        return self.actions, None
