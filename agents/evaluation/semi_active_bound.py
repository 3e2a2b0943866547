"""Clairvoyant bound of the semi-active damper: the best open-loop command sequence found.

On one track of a version of ``railgym/VerticalSuspension`` (default: the newest,
:data:`~agents.controllers.registry.ENV_ID`) with ``actuator="semi-active"`` (reference
backend) a causal controller, whatever it is, produces one command sequence
``u_0 … u_{N−1}`` in [0, 1]; the sequence that minimises the episode's ``a_w`` (Wk-weighted
RMS carbody acceleration, m/s², as :func:`agents.evaluation.runs.run_policy` computes it)
bounds what any controller can reach on that track. :class:`CommandProblem` searches it with
full knowledge of the track: the carbody acceleration of a command sequence is simulated by the
env's own kernel (:func:`~railgym.vehicles.vertical.kernels.advance_semi_active`, the step the env
runs), its Jacobian with respect to every command by forward differences in lanes of that
kernel (lane ``j`` perturbs command ``j`` and starts from the unperturbed state at step ``j``:
``N(N+1)/2`` lane-steps), and ``min a_w`` over the box [0, 1]^N by L-BFGS-B
(:func:`scipy.optimize.minimize`) from several starts: the closed-loop command records of
``clipped-lqg`` and ``skyhook`` and the constant commands 0, 0.5 and 1. The result is the
best found, a local optimum: an upper estimate of the clairvoyant optimum, which itself is a
lower bound of every causal controller's ``a_w``.

The command: ``railgym semi-active-bound`` (:mod:`agents.commands.semi_active_bound`).
Results: docs/results.md, *Semi-active*.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from scipy import optimize, signal

import railgym  # noqa: F401  (registers the envs)
from agents.controllers.registry import ENV_ID
from agents.policies.loading import load_policy
from railgym.comfort import WeightingFilter, weighted_rms
from railgym.track_stream import stream_samples
from railgym.vehicles.vertical.kernels import StepOutputs, advance_semi_active, step_outputs

__all__ = [
    "DISCARD_S",
    "ENV_KWARGS",
    "STARTS",
    "CommandProblem",
    "TrackResult",
    "closed_loop",
    "format_results",
    "optimise_track",
]

#: the env settings of the bound and its baselines (the env's defaults otherwise, as the
#: benchmark's baselines)
ENV_KWARGS: dict[str, Any] = {"backend": "reference", "actuator": "semi-active"}
#: settling time left out of ``a_w``, s (as :func:`agents.evaluation.runs.run_policy`)
DISCARD_S = 2.0
#: the starts of the search: closed-loop command records of these controllers, or constants
STARTS: tuple[str | float, ...] = ("clipped-lqg", "skyhook", 0.0, 0.5, 1.0)
#: forward-difference step of a command (dimensionless, command units)
FD_STEP = 1e-4


def closed_loop(
    policy: str,
    track_class: int,
    seed: int,
    duration: float,
    discard: float = DISCARD_S,
    env_id: str = ENV_ID,
    **env_kwargs: Any,
) -> dict[str, Any]:
    """One closed-loop episode of controller ``policy`` (a ``railgym evaluate`` name) on the
    track of ``seed`` of ``env_id``: its commands ``u`` (N,) as the env applied them, carbody
    acceleration ``acc`` (N,) in m/s², ``a_w`` (m/s², the first ``discard`` s left out) and
    ``contacts`` (bump-stop substeps)."""
    factory, needs, _ = load_policy(policy, env_id)
    kwargs = {**ENV_KWARGS, **needs, **env_kwargs}
    venv = gym.make_vec(
        env_id,
        num_envs=1,
        vectorization_mode="vector_entry_point",
        track_class=track_class,
        duration=duration,
        **kwargs,
    )
    ctrl = factory(venv)
    obs, _ = venv.reset(seed=seed)
    sim: Any = venv.unwrapped.sim  # type: ignore[attr-defined]
    commands, acc = [], []
    while True:
        action, _ = ctrl.predict(obs, deterministic=True)
        obs, _, term, trunc, info = venv.step(np.asarray(action, np.float32).reshape(1, 1))
        commands.append(float(sim.actions[0, 0]))
        acc.append(float(info["carbody_acc"][0]))
        if term[0]:
            raise RuntimeError(f"{policy}: the episode diverged")
        if trunc[0]:
            break
    fs = 1.0 / sim.cfg.control_dt
    a = np.asarray(acc)
    venv.close()
    return {
        "u": np.asarray(commands),
        "acc": a,
        "a_w": weighted_rms(a, fs, discard=discard, lowpass=False),
        "contacts": int(info["bump_stop_contacts"][0]),
    }


def whole_track(sim: Any, n_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Vehicle 0's track input ``(z, zdot)`` (1, ``n_samples``) in m and m/s from the start of
    its episode (``sim`` just reset): the whole arrays of the earlier versions, or on a
    streamed track (``VerticalSuspension-v3``) the held window followed by the samples its
    stream generates next, as the env's windows would hold them."""
    win = getattr(sim, "win", None)
    if win is None:
        return sim.z, sim.zdot
    if win.start[0] != 0 or win.shift[0] != 0.0 or win.measured[0]:
        raise ValueError("the streamed track must be a one-wheelset FRA track at its start")
    held = int(win.end[0])
    gen = type(sim.gen)(*(a[:1].copy() for a in sim.gen))
    z, zdot = np.empty((1, n_samples)), np.empty((1, n_samples))
    z[0, :held], zdot[0, :held] = sim.z[0, :held], sim.zdot[0, :held]
    stream_samples(gen, 0, z, zdot, held, n_samples)
    return z, zdot


class CommandProblem:
    """The open-loop command sequence of one track and its ``a_w``.

    Parameters
    ----------
    track_class : int
        FRA track class, run at its maximum speed.
    seed : int
        Track seed (the track of ``env.reset(seed=seed)``).
    duration : float
        Episode length, s (``N = duration / control_dt`` commands).
    discard : float
        Settling time left out of ``a_w``, s.
    fd_step : float
        Forward-difference step of a command.
    env_id : str
        The version of ``railgym/VerticalSuspension`` whose track and kernel are used.
    """

    def __init__(
        self,
        track_class: int,
        seed: int,
        duration: float,
        discard: float = DISCARD_S,
        fd_step: float = FD_STEP,
        env_id: str = ENV_ID,
    ) -> None:
        env = gym.make(env_id, track_class=track_class, duration=duration, **ENV_KWARGS)
        env.reset(seed=seed)
        sim: Any = env.unwrapped.sim  # type: ignore[attr-defined]
        c = sim.step_consts
        self.kind, self.n_sub, self.dt = c.kind, c.n_sub, c.dt
        self.params, self.lpr, self.damper = sim.params_record, sim.lpr, sim.damper
        self.state0 = sim.state[0].copy()
        self.n = int(c.n_steps)
        self.fs = 1.0 / c.control_dt
        self.discard, self.fd_step = discard, fd_step
        self.n0 = int(round(discard * self.fs))
        if not 0 <= self.n0 < self.n:
            raise ValueError(f"discard must be >= 0 and shorter than duration, got {discard}")
        self.sos = WeightingFilter(self.fs, "Wk", lowpass=False).sos
        # every lane on the same track: lane j of the Jacobian perturbs command j
        z, zdot = whole_track(sim, self.n * self.n_sub + 1)
        self._z = np.tile(z, (self.n, 1))
        self._zdot = np.tile(zdot, (self.n, 1))
        self._out = step_outputs(self.n)
        env.close()
        self._cache: tuple[bytes, dict[str, Any]] | None = None

    def _advance(self, state: np.ndarray, k: np.ndarray, command: np.ndarray, m: int) -> Any:
        """One control step of lanes ``0 … m−1`` (the kernel of the env); their outputs."""
        o = self._out
        out = StepOutputs(o.acc[:m], o.force[:m], o.count[:m], o.div[:m])
        advance_semi_active(
            self.kind,
            state[:m],
            self._z[:m],
            self._zdot[:m],
            k[:m],
            self.n_sub,
            self.dt,
            command[:m],
            self.params,
            self.lpr,
            self.damper,
            out,
            np.zeros(m),
        )
        if np.any(out.div):
            raise RuntimeError("the simulation diverged")
        return out

    def simulate(self, u: np.ndarray) -> dict[str, Any]:
        """The episode of commands ``u`` (N,): carbody acceleration ``acc`` (N,) in m/s², the
        state before every step ``states`` (N, s), ``contacts`` (bump-stop substeps) and
        ``a_w`` (m/s²)."""
        u = np.asarray(u, np.float64)
        key = u.tobytes()
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        state = self.state0[None, :].copy()
        k = np.zeros(1, np.int64)
        acc = np.empty(self.n)
        states = np.empty((self.n, state.shape[1]))
        contacts = 0
        for t in range(self.n):
            states[t] = state[0]
            out = self._advance(state, k, u[t : t + 1], 1)
            k += self.n_sub
            acc[t] = out.acc[0, 1]
            contacts += int(out.count[0, 0])
        run = {
            "acc": acc,
            "states": states,
            "contacts": contacts,
            "a_w": weighted_rms(acc, self.fs, discard=self.discard, lowpass=False),
        }
        self._cache = (key, run)
        return run

    def a_w(self, u: np.ndarray) -> float:
        """``a_w`` (m/s²) of commands ``u`` (N,)."""
        return float(self.simulate(u)["a_w"])

    def residuals(self, u: np.ndarray) -> np.ndarray:
        """Wk-weighted carbody acceleration after the settling time over ``√M`` (M,), m/s²:
        its squared norm is ``a_w²``."""
        y = signal.sosfilt(self.sos, self.simulate(u)["acc"])[self.n0 :]
        return y / np.sqrt(y.size)

    def acc_jacobian(self, u: np.ndarray) -> np.ndarray:
        """``∂ẍ2_t/∂u_j`` (N, N), m/s² per command unit: forward differences, lane ``j``
        started from the unperturbed state at step ``j`` (zero above the diagonal)."""
        u = np.asarray(u, np.float64)
        nom = self.simulate(u)
        h = np.where(u + self.fd_step <= 1.0, self.fd_step, -self.fd_step)
        state = np.empty((self.n, nom["states"].shape[1]))
        k = np.empty(self.n, np.int64)
        command = np.empty(self.n)
        jac = np.zeros((self.n, self.n))
        for t in range(self.n):
            m = t + 1  # lanes 0 … t run; lane t starts here
            state[t] = nom["states"][t]
            k[t] = t * self.n_sub
            command[:m] = u[t]
            command[t] += h[t]
            out = self._advance(state, k, command, m)
            k[:m] += self.n_sub
            jac[t, :m] = (out.acc[:m, 1] - nom["acc"][t]) / h[:m]
        return jac

    def jacobian(self, u: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`residuals` (M, N): the Wk filter (linear, from rest) applied
        to :meth:`acc_jacobian` along time."""
        y = signal.sosfilt(self.sos, self.acc_jacobian(u), axis=0)[self.n0 :]
        return y / np.sqrt(y.shape[0])

    def gradient(self, u: np.ndarray) -> np.ndarray:
        """Gradient of ``a_w`` with respect to the commands (N,), m/s² per command unit."""
        r = self.residuals(u)
        return self.jacobian(u).T @ r / max(float(np.linalg.norm(r)), 1e-300)

    def optimise(self, u0: np.ndarray, max_eval: int = 50) -> np.ndarray:
        """The commands (N,) in [0, 1] of a bounded quasi-Newton search from ``u0``
        (:func:`scipy.optimize.minimize`, L-BFGS-B, about ``max_eval`` evaluations of ``a_w``
        and its gradient): the lowest ``a_w`` evaluated, ``u0`` included (a local optimum
        when the search converged)."""
        u0 = np.clip(np.asarray(u0, np.float64), 0.0, 1.0)
        best: dict[str, Any] = {"a_w": self.a_w(u0), "u": u0}

        def fun(u: np.ndarray) -> tuple[float, np.ndarray]:
            a = self.a_w(u)
            if a < best["a_w"]:
                best.update(a_w=a, u=u.copy())
            return a, self.gradient(u)

        optimize.minimize(
            fun,
            u0,
            jac=True,
            method="L-BFGS-B",
            bounds=optimize.Bounds(0.0, 1.0),
            options={"maxfun": max_eval, "ftol": 1e-12, "gtol": 1e-10},
        )
        return np.asarray(best["u"])


@dataclass
class TrackResult:
    """The baselines and the best open-loop commands found on one track (a_w in m/s²,
    contacts in bump-stop substeps)."""

    track_class: int
    seed: int
    a_w: dict[str, float]  #: passive, clipped-lqg, skyhook, best
    contacts: dict[str, int]
    starts: dict[str, float]  #: a_w reached from each start
    best_start: str
    wall_s: float

    @property
    def margin(self) -> float:
        """``(best − clipped-lqg) / clipped-lqg``, %."""
        return 100.0 * (self.a_w["best"] / self.a_w["clipped-lqg"] - 1.0)


def optimise_track(
    track_class: int,
    seed: int,
    duration: float,
    starts: Sequence[str | float] = STARTS,
    screen_eval: int = 12,
    max_eval: int = 50,
    env_id: str = ENV_ID,
) -> TrackResult:
    """Baselines and the best open-loop commands on one track of ``env_id``: every start
    searched for ``screen_eval`` evaluations (:meth:`CommandProblem.optimise`), the best of
    them continued up to ``max_eval`` in all."""
    t0 = time.perf_counter()
    prob = CommandProblem(track_class, seed, duration, env_id=env_id)
    runs = {
        name: closed_loop(name, track_class, seed, duration, env_id=env_id)
        for name in ("passive", "clipped-lqg", "skyhook")
    }
    for name, run in runs.items():
        replay = prob.simulate(run["u"])
        if replay["a_w"] != run["a_w"]:  # the open loop is the env's step, exactly
            raise RuntimeError(f"{name}: replay a_w {replay['a_w']} != env {run['a_w']}")
    inits = {
        str(s): runs[s]["u"] if isinstance(s, str) else np.full(prob.n, float(s)) for s in starts
    }
    found = {name: prob.optimise(u0, screen_eval) for name, u0 in inits.items()}
    scores = {name: prob.a_w(u) for name, u in found.items()}
    best_start = min(scores, key=scores.__getitem__)
    if max_eval > screen_eval:
        found[best_start] = prob.optimise(found[best_start], max_eval - screen_eval)
        scores[best_start] = prob.a_w(found[best_start])
    best = prob.simulate(found[best_start])
    return TrackResult(
        track_class,
        seed,
        {**{n: float(r["a_w"]) for n, r in runs.items()}, "best": float(best["a_w"])},
        {**{n: int(r["contacts"]) for n, r in runs.items()}, "best": int(best["contacts"])},
        scores,
        best_start,
        time.perf_counter() - t0,
    )


def format_results(results: Sequence[TrackResult]) -> str:
    """A markdown table per track and the median margin per class."""
    lines = [
        "| class | seed | passive | clipped-lqg | skyhook | best found | best vs clipped-lqg "
        "| best start | contacts passive / clipped-lqg / skyhook / best | s |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    names = ("passive", "clipped-lqg", "skyhook", "best")
    for r in results:
        cells = [f"{r.a_w[n]:.4f}" for n in names]
        contacts = " / ".join(str(r.contacts[n]) for n in names)
        lines.append(
            f"| {r.track_class} | {r.seed} | {' | '.join(cells)} | {r.margin:+.1f} % "
            f"| {r.best_start} | {contacts} | {r.wall_s:.0f} |"
        )
    lines += ["", "| class | median best vs clipped-lqg | range |", "|---|---|---|"]
    for tc in sorted({r.track_class for r in results}):
        m = [r.margin for r in results if r.track_class == tc]
        lines.append(f"| {tc} | {np.median(m):+.1f} % | {min(m):+.1f} … {max(m):+.1f} % |")
    return "\n".join(lines)
