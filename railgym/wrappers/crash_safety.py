"""Crash-safety summary of a train-crash episode (``railgym/TrainCrash-v1``).

Per car: the peak and the time-averaged deceleration (in g, from the per-step
``info["decel_g"]``); per crush zone: the largest crush, i.e. stroke used (m, from
``info["crush_m"]``), the energy absorbed (J) and the fraction of the absorber stroke used;
plus the share of the train's initial kinetic energy the zones absorbed. With an env that
reports them (``TrainCrash-v1`` does), the crash criteria of
:mod:`railgym.vehicles.crash.criteria` and their pass/fail against the scenario's limits
(the crash scenarios are only inspired by EN 15227; see ``docs/envs/crash.md``).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

#: the railgym env the wrapper is made for (any other env must report :data:`STEP_KEYS`)
CRASH_ENV = "railgym/TrainCrash-v1"
#: per-step info keys the wrapper accumulates
STEP_KEYS = ("decel_g", "crush_m")
#: episode-end criteria info keys copied into the summary when the env reports them
CRITERIA_KEYS = (
    "pulse_mean_decel_g",
    "moving_average_peak_g",
    "intrusion_m",
    "mean_decel_passed",
    "peak_decel_passed",
    "moving_average_passed",
    "intrusion_passed",
    "criteria_passed",
)


class CrashSafety(gym.Wrapper):
    """Per-car deceleration and per-zone energy and stroke of each crash episode.

    Parameters
    ----------
    env : env whose ``step`` info holds ``decel_g`` (per car, deceleration in g, positive
        when braking) and ``crush_m`` (per zone, m) every step, and ``absorbed_energy_J``
        (per zone, J, cumulative), ``stroke_exceeded`` and ``energy_error`` (relative energy
        balance residual) — as ``railgym.envs.crash.env.TrainCrashEnv``. A missing key raises
        ``ValueError`` on the first step that needs it.

    Notes
    -----
    At episode end ``info["crash_safety"]`` holds: ``peak_decel_g`` and ``mean_decel_g``
    (per car, the mean over every control step of the episode, including the steps after the
    car has stopped — not the pulse mean, which is ``pulse_mean_decel_g`` Δv / (g·t_stop)),
    ``max_peak_decel_g``, ``worst_car``
    (index of the largest peak), ``max_crush_m`` (per zone: stroke used, m),
    ``absorbed_energy_J`` (per zone), ``total_absorbed_J``, ``stroke_exceeded``,
    ``energy_error``, ``duration`` (s, steps × control_dt when the env has ``cfg.control_dt``,
    else the step count), ``steps``; and, when the env exposes them (``cfg.absorber_stroke``;
    ``cfg.scenario.car_masses`` with ``info["initial_speed"]``): ``stroke_used`` (max crush /
    absorber stroke, per zone) and ``absorbed_fraction`` (total absorbed / initial kinetic
    energy ``½ Σ m v0²``, the payload included when the env has ``car_masses``); and the
    criteria of :data:`CRITERIA_KEYS` the env's info holds: per car ``pulse_mean_decel_g``
    (Δv / (g·t_stop) over its crash pulse), ``moving_average_peak_g`` (10 ms), per zone
    ``intrusion_m``, the pass/fail arrays and ``criteria_passed``.
    """

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        spec = getattr(env.unwrapped, "spec", None)
        env_id = getattr(spec, "id", None) or ""
        if env_id.startswith("railgym/") and env_id != CRASH_ENV:
            raise ValueError(
                f"env: CrashSafety summarises crash episodes ({CRASH_ENV}), got {env_id}"
            )
        self._cfg = getattr(env.unwrapped, "cfg", None)
        self._clear()

    def _clear(self) -> None:
        self._n = 0
        self._peak: np.ndarray | None = None
        self._sum: np.ndarray | None = None
        self._crush: np.ndarray | None = None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the env and the episode statistics."""
        self._clear()
        return self.env.reset(seed=seed, options=options)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Step the env and accumulate the per-car decelerations and per-zone crush."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        decel, crush = (np.atleast_1d(np.asarray(_need(info, k), float)) for k in STEP_KEYS)
        if self._n == 0:
            self._peak, self._sum, self._crush = decel.copy(), decel.copy(), crush.copy()
        else:
            np.maximum(self._peak, decel, out=self._peak)
            self._sum += decel
            np.maximum(self._crush, crush, out=self._crush)
        self._n += 1
        if terminated or truncated:
            info["crash_safety"] = self._summary(info)
        return obs, reward, terminated, truncated, info

    def _summary(self, info: dict[str, Any]) -> dict[str, Any]:
        energy = np.atleast_1d(np.asarray(_need(info, "absorbed_energy_J"), float)).copy()
        out: dict[str, Any] = {
            "peak_decel_g": self._peak.copy(),
            "mean_decel_g": self._sum / self._n,
            "max_peak_decel_g": float(self._peak.max()),
            "worst_car": int(np.argmax(self._peak)),
            "max_crush_m": self._crush.copy(),
            "absorbed_energy_J": energy,
            "total_absorbed_J": float(energy.sum()),
            "stroke_exceeded": bool(np.any(_need(info, "stroke_exceeded"))),
            "energy_error": float(_need(info, "energy_error")),
            "steps": self._n,
        }
        cfg = self._cfg
        control_dt = getattr(cfg, "control_dt", None)
        out["duration"] = self._n * control_dt if control_dt is not None else float(self._n)
        stroke = getattr(cfg, "absorber_stroke", None)
        if stroke is not None:
            out["stroke_used"] = self._crush / np.asarray(stroke, float)
        masses = getattr(self.env.unwrapped, "car_masses", None)
        if masses is None:
            masses = getattr(getattr(cfg, "scenario", None), "car_masses", None)
        if masses is not None and "initial_speed" in info:
            energy0 = 0.5 * float(np.sum(masses)) * float(info["initial_speed"]) ** 2
            out["absorbed_fraction"] = out["total_absorbed_J"] / energy0
        for key in CRITERIA_KEYS:
            if key in info:
                value = info[key]
                out[key] = value.copy() if isinstance(value, np.ndarray) else value
        return out


def _need(info: dict[str, Any], key: str) -> Any:
    if key not in info:
        raise ValueError(f"info: CrashSafety needs {key!r} in the env's step info")
    return info[key]
