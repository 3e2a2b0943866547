"""The benchmark tasks: named ``gym.make`` ids with fixed arguments and a fixed evaluation
protocol, and the normalised score (docs/tasks.md, docs/leaderboard.md).

A :class:`Task` is one env id on the newest version of its env with fixed keyword
arguments, the held-out evaluation :class:`Case` s (track class, speed, payload or crash
case, each run for ``episodes`` episodes on the track seeds ``seed + i``) and its metric
(lower is better: a_w in m/s², or the crash cost in g). :func:`score` maps a metric value
of a case to ``(passive − value) / (passive − bound)``: 0 is the passive vehicle, 1 the
task's bound (no causal controller can do better on the case), from the reference values
of :data:`REFERENCES_FILE` (``railgym leaderboard references`` writes them).

    >>> import railgym.tasks as tasks
    >>> env = tasks.make("bogie-active")
    >>> tasks.score("bogie-active", {"class4": 0.30})  # doctest: +SKIP
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from typing import Any

import gymnasium as gym
import numpy as np

from railgym import _checks as val

__all__ = [
    "CRASH_COST_G_PER_MM",
    "REFERENCES_FILE",
    "TASKS",
    "Case",
    "Task",
    "case_kwargs",
    "make",
    "normalise",
    "references",
    "score",
]

#: crash cost: g of worst-car peak deceleration per mm of survival-space intrusion (the ratio
#: of the crash config's reward weights ``peak`` 0.2 / g and ``intrusion`` 0.002 / mm)
CRASH_COST_G_PER_MM = 0.01
#: the passive and bound metric values per task and case (package data of railgym)
REFERENCES_FILE = "task_references.json"


@dataclass(frozen=True)
class Case:
    """One evaluation case of a task: ``label``; env arguments ``env_kwargs`` added to the
    task's; ``options`` of ``reset`` (the crash case's speed and payload); ``payload`` —
    factor on the carbody mass ``m2`` of the packaged vehicle (1: nominal)."""

    label: str
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    options: Mapping[str, Any] = field(default_factory=dict)
    payload: float = 1.0


@dataclass(frozen=True)
class Task:
    """A benchmark task: env id and fixed arguments, evaluation protocol, metric.

    Attributes
    ----------
    name, description : the task's name and one line on it.
    env_id : the ``gym.make`` id (newest version of the env).
    env_kwargs : its fixed keyword arguments.
    cases : the held-out evaluation cases.
    episodes : episodes per case, sub-env ``i`` on the track of seed ``seed + i``.
    seed : first held-out track seed (training uses other seeds).
    metric, unit : what is scored (lower is better) and its unit.
    baselines : the classical controllers of the task (``railgym leaderboard`` names).
    bound : how the bound of each case is computed.
    """

    name: str
    description: str
    env_id: str
    env_kwargs: Mapping[str, Any]
    cases: tuple[Case, ...]
    episodes: int
    seed: int
    metric: str
    unit: str
    baselines: tuple[str, ...]
    bound: str

    @property
    def case_labels(self) -> tuple[str, ...]:
        """The labels of :attr:`cases`, in order."""
        return tuple(c.label for c in self.cases)

    def case(self, label: str) -> Case:
        """The case ``label`` (a :class:`~railgym._checks.FieldError` naming the known ones)."""
        for c in self.cases:
            if c.label == label:
                return c
        raise val.FieldError("case", f"{self.name} has no case {label!r}: {self.case_labels}")


_VERTICAL = "railgym/VerticalSuspension-v3"
_VEHICLE = "railgym/VerticalVehicle-v3"
_CRASH = "railgym/TrainCrash-v1"
_A_W = "a_w (Wk, first 2 s left out)"
_A_W_FLOOR = "a_w (Wk), mean of the front, centre and rear floor points"
_TRIVIAL = (
    "0 m/s² (trivial: no controller has a negative a_w); the clairvoyant optimum under the "
    "force limit and bump stops is not computed"
)
_CLASSES = tuple(Case(f"class{tc}", {"track_class": tc}) for tc in (4, 5, 6))
#: the payload task: the class-5 maximum speed 40 m/s (144 km/h) and 60 % of it
_PAYLOAD_CASES = tuple(
    Case(f"m{int(round(100 * p))}-v{int(v)}", {"speed": v}, payload=p)
    for p in (0.75, 1.0, 1.25)
    for v in (24.0, 40.0)
)
_CRASH_CASES = tuple(
    Case(
        f"{kmh:g}kmh-{'loaded' if load[0] else 'empty'}", {}, {"speed_kmh": kmh, "payload_t": load}
    )
    for kmh in (25.0, 35.0, 45.0, 50.0)
    for load in ((0.0, 0.0), (2.0, 8.0))
)

#: the tasks by name
TASKS: dict[str, Task] = {
    t.name: t
    for t in (
        Task(
            "bogie-active",
            "one bogie, active force between bogie and carbody, sensor observation",
            _VERTICAL,
            {"backend": "reference", "actuator": "force", "duration": 20.0},
            _CLASSES,
            4,
            10_000,
            _A_W,
            "m/s²",
            ("passive", "skyhook", "groundhook", "lqg"),
            _TRIVIAL,
        ),
        Task(
            "bogie-semi-active",
            "one bogie, controllable damper (command in [0, 1]) in place of the passive one",
            _VERTICAL,
            {"backend": "reference", "actuator": "semi-active", "duration": 5.0},
            _CLASSES,
            2,
            10_000,
            _A_W,
            "m/s²",
            ("passive", "clipped-lqg", "skyhook-onoff", "skyhook", "groundhook"),
            "best open-loop command sequence found per track with full knowledge of it "
            "(agents.evaluation.semi_active_bound, L-BFGS-B from the baselines' commands)",
        ),
        Task(
            "vehicle-active",
            "whole vehicle (carbody bounce, pitch, bending; two bogies), two active forces",
            _VEHICLE,
            {"backend": "reference", "duration": 20.0},
            _CLASSES[:2],
            2,
            10_000,
            _A_W_FLOOR,
            "m/s²",
            ("passive", "skyhook", "modal-skyhook", "lqg"),
            _TRIVIAL,
        ),
        Task(
            "vehicle-preview",
            "whole vehicle with 21.56 m of track preview ahead of the rear wheelset",
            _VEHICLE,
            {"backend": "reference", "duration": 20.0, "preview": 21.56},
            _CLASSES[:2],
            2,
            10_000,
            _A_W_FLOOR,
            "m/s²",
            ("passive", "lqg", "lq-preview"),
            _TRIVIAL,
        ),
        Task(
            "crash-adaptive",
            "two-car train into a rigid wall, absorber force scale per crush zone, "
            "held-out speeds and payloads",
            _CRASH,
            {"backend": "reference", "scenario": "envelope", "control_dt": 0.005},
            _CRASH_CASES,
            1,
            10_000,
            f"crash cost: worst-car peak deceleration + {CRASH_COST_G_PER_MM:g} g/mm × "
            "largest intrusion",
            "g",
            ("passive", "best-constant", "speed-adaptive"),
            "best open-loop absorber commands found per case (piecewise constant, coordinate "
            "search from every constant setting and every baseline's commands); the crash is "
            "deterministic, so a causal controller is one such sequence",
        ),
        Task(
            "bogie-payload",
            "one bogie on the linear suspension, active force limited to 4 kN, carbody mass "
            "±25 % and speed 86 or 144 km/h per case, neither observed",
            _VERTICAL,
            {"backend": "linear", "actuator": "force", "duration": 20.0, "f_max": 4000.0},
            _PAYLOAD_CASES,
            2,
            10_000,
            _A_W,
            "m/s²",
            ("passive", "skyhook", "lqg", "lqg-scheduled"),
            "exact clairvoyant optimum per track: the linear model's weighted acceleration is "
            "affine in the force sequence, so the best sequence in the force box is a convex "
            "least-squares problem (agents.leaderboard.linear_bound)",
        ),
    )
}


def _task(name: str) -> Task:
    if name not in TASKS:
        raise val.FieldError("task", f"unknown task {name!r}; tasks: {', '.join(TASKS)}")
    return TASKS[name]


def case_kwargs(name: str, label: str) -> dict[str, Any]:
    """The env keyword arguments of case ``label`` of task ``name``: the task's, the case's,
    and the vehicle with the case's payload (carbody mass × ``payload``)."""
    task = _task(name)
    case = task.case(label)
    kwargs = {**task.env_kwargs, **case.env_kwargs}
    if case.payload != 1.0:
        from dataclasses import replace

        from railgym.vehicles.vertical.params import load_vehicle

        nominal = load_vehicle("manchester")
        kwargs["vehicle"] = replace(nominal, m2=nominal.m2 * case.payload)
    return kwargs


def make(name: str, case: str | None = None, **kwargs: Any) -> gym.Env:
    """``gym.make`` of task ``name`` (its first case, or ``case``); ``kwargs`` are added (a
    value given twice is refused, not replaced)."""
    task = _task(name)
    fixed = case_kwargs(name, case or task.cases[0].label)
    clash = sorted(set(fixed) & set(kwargs))
    if clash:
        raise val.FieldError(clash[0], f"is fixed by task {name!r} ({fixed[clash[0]]!r})")
    return gym.make(task.env_id, **fixed, **kwargs)


@cache
def references() -> dict[str, dict[str, dict[str, float]]]:
    """Task → case → ``{"passive": value, "bound": value}`` (the task's metric unit)."""
    text = resources.files("railgym").joinpath("data", REFERENCES_FILE).read_text()
    data: dict[str, dict[str, dict[str, float]]] = json.loads(text)
    return data


def normalise(value: Any, passive: Any, bound: Any) -> np.ndarray:
    """``(passive − value) / (passive − bound)``: 0 at passive, 1 at the bound (lower metric
    values are better); refuses a bound not below passive."""
    passive, bound = np.asarray(passive, float), np.asarray(bound, float)
    if np.any(~(bound < passive)):
        raise ValueError(f"the bound {bound} must be below passive {passive}")
    return (passive - np.asarray(value, float)) / (passive - bound)


def score(name: str, metrics: Mapping[str, Any]) -> dict[str, float]:
    """Normalised score per case of task ``name`` from ``metrics``: case label → metric value
    (a number, or the values of several runs, which are averaged)."""
    task = _task(name)
    refs = references().get(name)
    if refs is None:
        raise val.FieldError("task", f"{name!r} has no reference values in {REFERENCES_FILE}")
    out = {}
    for label, value in metrics.items():
        task.case(label)
        ref = refs[label]
        out[label] = float(np.mean(normalise(value, ref["passive"], ref["bound"])))
    return out
