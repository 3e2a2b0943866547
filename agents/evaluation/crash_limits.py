"""What limits a learning crash agent: ceilings of constant absorber settings on the held-out
envelope of ``railgym/TrainCrash-v1`` (reference backend), beside the speed-adaptive rule.

    railgym crash-limits [--range 0.3 0.5] [--levels 9]

For each absorber range, every constant action per zone on a grid of ``levels`` values in
[−1, 1] runs at every held-out case of the scenario's envelope
(:func:`agents.evaluation.crash_report.envelope_cases`: six speeds × the lightest and heaviest
payloads). Admissible settings have no more intrusion than passive in the cases they are used
for. The mean worst-car peak deceleration (g) over the cases is printed for: passive; the best
single setting for all cases; the best setting per impact speed (a policy that knows the speed
at first contact, which the observation ``v_lead`` gives, but not the payload); the best
setting per case (speed and payload known); and
:class:`~agents.controllers.crash_baselines.SpeedAdaptive` with the env's rate limit and a tenfold
one.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np

from agents.controllers.crash_baselines import CrashPassive, FixedActions, SpeedAdaptive, rollout
from agents.evaluation.crash_report import (
    envelope_cases,
    envelope_rows,
    envelope_summary,
)
from railgym.envs.crash.env import TrainCrashVectorEnv

__all__ = ["ceilings", "rule"]

#: env settings of the shipped crash training config (configs/agents/ppo_crash.yaml), its
#: scenario ``envelope`` the default of ``--scenario``
BASE = {"control_dt": 0.005, "backend": "reference"}


def ceilings(
    absorber_range: float = 0.3,
    levels: int = 9,
    speeds_kmh: Sequence[float] | None = None,
    payloads_t: Sequence[tuple[float, float]] | None = None,
    scenario: Any = "envelope",
) -> dict[str, float]:
    """Mean worst-car peak deceleration (g) over the cases of passive and of the best constant
    settings: ``one`` for all cases, ``per_speed``, ``per_case`` (see the module docstring);
    the cases of ``scenario``'s envelope (:func:`envelope_cases`) unless given."""
    kwargs = {**BASE, "absorber_range": absorber_range, "scenario": scenario}
    if speeds_kmh is None or payloads_t is None:
        speeds, payloads = envelope_cases(scenario)
        speeds_kmh = speeds if speeds_kmh is None else speeds_kmh
        payloads_t = payloads if payloads_t is None else payloads_t
    n_zones = TrainCrashVectorEnv(num_envs=1, **kwargs).single_action_space.shape[0]
    grid = np.linspace(-1.0, 1.0, levels)
    cand = np.array(list(itertools.product(grid, repeat=n_zones)))
    zero = int(np.flatnonzero(np.all(cand == 0.0, axis=1))[0]) if levels % 2 else None
    if zero is None:
        cand, zero = np.vstack([np.zeros(n_zones), cand]), 0
    peak, intr = {}, {}
    for kmh in speeds_kmh:
        for pay in payloads_t:
            env = TrainCrashVectorEnv(num_envs=len(cand), **kwargs)
            opts = {"speed_kmh": float(kmh), "payload_t": {"lead": pay[0], "passenger": pay[1]}}
            crit = [r.criteria() for r in rollout(env, FixedActions(cand), options=opts)]
            peak[kmh, pay] = np.array([c.peak_decel_g.max() for c in crit])
            intr[kmh, pay] = np.array([c.intrusion_m.max() for c in crit])

    def best(keys: list[Any]) -> list[float]:
        ok = np.all([intr[k] <= intr[k][zero] + 1e-6 for k in keys], axis=0)
        j = int(np.argmin(np.where(ok, np.mean([peak[k] for k in keys], axis=0), np.inf)))
        return [float(peak[k][j]) for k in keys]

    keys = list(peak)
    per_speed = [p for v in speeds_kmh for p in best([k for k in keys if k[0] == v])]
    return {
        "passive": float(np.mean([peak[k][zero] for k in keys])),
        "one": float(np.mean(best(keys))),
        "per_speed": float(np.mean(per_speed)),
        "per_case": float(np.mean([best([k])[0] for k in keys])),
    }


def rule(
    absorber_range: float = 0.3, absorber_rate: float = 20.0, scenario: Any = "envelope"
) -> float:
    """Mean worst-car peak deceleration (g) of the speed-adaptive rule over the held-out cases
    of ``scenario``'s envelope."""
    settings = {"absorber_range": absorber_range, "absorber_rate": absorber_rate}
    rows = envelope_rows(
        {"passive": CrashPassive, "speed-adaptive": SpeedAdaptive},
        {**BASE, **settings, "scenario": scenario},
    )
    return envelope_summary(rows)["speed-adaptive"]["peak_g"]
