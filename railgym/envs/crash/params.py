"""The arguments of ``railgym/TrainCrash-v1`` (:mod:`railgym.envs.crash`), declared once.

:class:`CrashParams` holds every argument with its default, unit, limits and description
(:func:`railgym.envs.params.param`), checks them in one place and derives what the batch
needs (the scenario with its overrides, the impact envelope, the observation layout, the
crash criteria). The docs table of arguments (``docs/envs/crash.md``) is generated from it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from railgym import _checks as val
from railgym.envs.crash.step import Criteria
from railgym.envs.params import Params, declared, derived, param
from railgym.vehicles.crash.criteria import ONSET_G, WINDOW
from railgym.vehicles.crash.scenario import (
    LIMITS,
    MAX_SPEED,
    CrashScenario,
    CrushZone,
    load_scenario,
)
from railgym.vehicles.crash.surrogate import VARIANTS

__all__ = [
    "A_SCALE_G",
    "BACKENDS",
    "CrashParams",
    "DEFAULT_WEIGHTS",
    "MAX_CONTROL_DT",
    "MAX_DURATION",
    "MAX_WEIGHT",
    "MIN_CONTROL_DT",
    "X_SCALE",
    "nominal_force",
]

BACKENDS = ("surrogate", "reference")
DEFAULT_WEIGHTS = {"decel": 1.0, "intrusion": 1.0, "peak": 0.0}
#: largest control step, s: the statistics and the reward sample the state once per step, so
#: a coarser step misses the deceleration peaks of a crash lasting a few hundred ms
MAX_CONTROL_DT = 0.01
#: smallest control step, s: the scenario check keeps the reference's stable step above it
MIN_CONTROL_DT = 1e-6
#: longest episode, s
MAX_DURATION = 60.0
#: largest reward weight and absorber rate (1/s): keeps every reward finite
MAX_WEIGHT = 1e6
#: observation scales: displacement (m) and acceleration (in g)
X_SCALE = 1.0
A_SCALE_G = 10.0


def nominal_force(zone: CrushZone) -> float:
    """Largest point force (N) of the zone's envelope within its absorber stroke."""
    inside = [f for s, f in zip(zone.stroke, zone.force, strict=True) if s <= zone.absorber_stroke]
    return max(inside, default=zone.force[0])


def _scenario(value: Any, name: str) -> CrashScenario:
    return value if isinstance(value, CrashScenario) else load_scenario(value)


@declared
class CrashParams(Params):
    """The arguments of ``TrainCrash-v1`` (:class:`~railgym.envs.crash.env.TrainCrashEnv`),
    checked, and what the batch derives from them (SI units).

    ``scenario`` becomes the :class:`CrashScenario` with ``n_cars`` and ``speed`` applied;
    ``speed_range`` (m/s) and ``payload_range`` ((cars, 2) kg) are the impact envelope drawn
    at each reset, or ``None`` without one (every episode at ``scenario.speed``, no payload).
    """

    backend: str = param(
        "surrogate",
        "",
        "crash model: surrogate elements (paper eq. 4) or the lumped-mass reference chain",
        kind="choice",
        values=BACKENDS,
    )
    scenario: Any = param(
        "paper",
        "",
        "packaged scenario name or YAML path (or a `CrashScenario`); errors name the file's field",
        kind="object",
        check=_scenario,
    )
    n_cars: int | None = param(
        None,
        "",
        "number of cars; `None` = the scenario's (its `n_cars`)",
        kind="int",
        lo=1,
        hi=LIMITS["n_cars"][1],
        optional=True,
    )
    speed: float | None = param(
        None,
        "m/s",
        "initial speed; `None` = the scenario's; with an envelope it fixes the envelope's speed",
        lo=0.0,
        lo_open=True,
        hi=MAX_SPEED,
        optional=True,
    )
    control_dt: float = param(
        0.001,
        "s",
        "agent step (the statistics and the reward sample the state once per step)",
        lo=MIN_CONTROL_DT,
        hi=MAX_CONTROL_DT,
    )
    max_duration: float = param(
        2.0,
        "s",
        "truncation, rounded to whole control steps",
        lo=0.0,
        lo_open=True,
        hi=MAX_DURATION,
    )
    absorber_range: float = param(
        0.3,
        "1",
        "action ±1 sets the absorber force scale to 1 ± range",
        lo=0.0,
        hi=1.0,
        lo_open=True,
        hi_open=True,
    )
    absorber_rate: float = param(
        20.0,
        "1/s",
        "largest rate of change of the force scale",
        lo=0.0,
        lo_open=True,
        hi=MAX_WEIGHT,
    )
    speed_jitter: float = param(
        0.0,
        "1",
        "initial speed × U(1 − j, 1 + j), drawn from the env's `np_random` at each reset",
        lo=0.0,
        hi=1.0,
        hi_open=True,
    )
    reward_weights: dict[str, float] = param(
        DEFAULT_WEIGHTS,
        "1",
        "weights of the reward terms; `None` or missing keys: the default",
        kind="weights",
        hi=MAX_WEIGHT,
    )
    surrogate: Any = param(
        None,
        "",
        "`CrashSurrogate` elements (`build_crash_surrogate`); `None` = the packaged envelope "
        'elements of the scenario\'s train, else fitted on a reference run; backend `"surrogate"`',
        kind="object",
    )
    surrogate_variant: str = param(
        "hysteretic",
        "",
        'elements used when `surrogate=None`; `"paper"` creates energy at rebound',
        kind="choice",
        values=VARIANTS,
    )

    n_steps: int = derived("1", "control steps per episode")
    max_scale_change: float = derived("1", "largest change of the force scale per step")
    weights: tuple[float, float, float] = derived("1", "reward weights, in declared key order")
    speed_range: tuple[float, float] | None = derived("m/s", "envelope speeds, or None")
    payload_range: np.ndarray | None = derived("kg", "(cars, 2) envelope payloads, or None")
    absorber_stroke: np.ndarray = derived("m", "(zones,) absorber stroke")
    obs_names: tuple[str, ...] = derived("", "observation channels")
    obs_scale: np.ndarray = derived("SI", "scale of each observation channel")
    criteria: Criteria = derived("", "crash criteria of the bookkeeping")

    def _derive(self) -> None:
        scenario = self.scenario.with_overrides(n_cars=self.n_cars, speed=self.speed)
        self._set("scenario", scenario)
        n_steps = round(self.max_duration / self.control_dt)
        if n_steps < 1:
            raise val.FieldError(
                "max_duration", f"({self.max_duration} s) must be at least control_dt"
            )
        self._set("n_steps", n_steps)
        self._set("max_scale_change", self.absorber_rate * self.control_dt)
        self._set("weights", tuple(self.reward_weights[k] for k in DEFAULT_WEIGHTS))
        speed_range = payload_range = None
        if scenario.envelope is not None:  # an explicit speed fixes the envelope's speed
            speed_range = (
                (scenario.speed, scenario.speed)
                if self.speed is not None
                else scenario.envelope.speed
            )
            payload_range = scenario.envelope.payload_ranges(scenario.n_cars)
        self._set("speed_range", speed_range)
        self._set("payload_range", payload_range)
        zones = [scenario.wall] + [scenario.interface] * (scenario.n_cars - 1)
        self._set("absorber_stroke", np.array([z.absorber_stroke for z in zones]))
        self._observation(zones)
        window_steps = max(1, round(WINDOW / self.control_dt))
        criteria = Criteria(
            onset_g=ONSET_G,
            window_steps=window_steps,
            window=window_steps * self.control_dt,
            **scenario.criteria._asdict(),
        )
        self._set("criteria", criteria)

    def _observation(self, zones: list[CrushZone]) -> None:
        """Names and scales of the observation: car x, v, a, then zone crush, force, scale."""
        scenario, n = self.scenario, self.scenario.n_cars
        cars = ["lead"] + [f"car{k + 1}" for k in range(1, n)]
        zone_names = ["wall"] + [f"interface_{k}" for k in range(1, n)]
        channels = (("x", cars), ("v", cars), ("a", cars))
        channels += (("crush", zone_names), ("force", zone_names), ("scale", zone_names))
        self._set("obs_names", tuple(f"{q}_{p}" for q, parts in channels for p in parts))
        top_speed = scenario.speed if self.speed_range is None else self.speed_range[1]
        scale = np.concatenate(
            [
                np.full(n, X_SCALE),
                np.full(n, top_speed),
                np.full(n, A_SCALE_G * scenario.gravity),
                self.absorber_stroke,
                np.array([nominal_force(z) for z in zones]),
                np.full(n, self.absorber_range),
            ]
        )
        self._set("obs_scale", scale)
