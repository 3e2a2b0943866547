"""What the two policy-aware refinement loops share (:func:`railgym.vehicles.collect.refine`
for one bogie, :func:`railgym.vehicles.vehicle.refine.refine_vehicle` for the whole vehicle):
their runs (:class:`RefineOptions`), the initial and candidate training pairs, the refit on
the worst samples and the held-out score.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from railgym import _checks as val
from railgym.track import class_speed
from railgym.vehicles.collect_design import MEMORY_SAMPLE_RATE, collect_design
from railgym.vehicles.memory_element import (
    MEMORY_DESIGN,
    WARMUP,
    design_with,
    memory_training_data,
)
from surrogates.memory import MEMORY_FORMS, element_form
from surrogates.models import SurrogateModel

__all__ = [
    "RefineOptions",
    "element_pairs",
    "holdout_error",
    "initial_pairs",
    "refine_rounds",
    "refit_worst",
]


@dataclass(frozen=True)
class RefineOptions:
    """Runs of a policy-aware refinement (:func:`railgym.vehicles.collect.refine` and
    :func:`railgym.vehicles.vehicle.refine.refine_vehicle`); checked when made.

    Attributes
    ----------
    track_class, speed, duration : tracks of the runs (speed m/s, default the class's
        maximum; duration s).
    n_tracks, n_holdout, n_add : tracks per round, held-out tracks, samples added per round.
    sample_rate : Hz of the candidate samples along each run.
    control_dt : s the policy's action is held; f_max : actuator force per unit action, N.
    seed : seed of the tracks.
    """

    track_class: int = 5
    speed: float | None = None
    duration: float = 10.0
    n_tracks: int = 2
    n_holdout: int = 3
    n_add: int = 400
    sample_rate: float = MEMORY_SAMPLE_RATE
    control_dt: float = 0.01
    f_max: float = 8000.0
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("n_tracks", "n_holdout", "n_add"):
            val.integer(getattr(self, name), name, min=1)
        if self.speed is not None:
            val.positive(self.speed, "speed")

    def steps(self, dt: float) -> tuple[int, int]:
        """``(n_sub, every)``: integration steps of ``dt`` (s) per control step and per
        candidate sample."""
        n_sub = round(self.control_dt / dt)
        every = round(1.0 / (self.sample_rate * dt))
        if n_sub < 1 or every < 1:
            raise ValueError("control_dt and 1/sample_rate must be whole multiples of dt")
        return n_sub, every

    def track_seed(self, tag: tuple[int, ...]) -> int:
        """The seed of the track ``tag`` (held-out ``(1, i)``, round ``(2, r, i)``) drawn
        from ``seed``."""
        return int(np.random.default_rng((self.seed, *tag)).integers(2**63 - 1))

    def speed_or_class(self) -> float:
        """Running speed, m/s: ``speed``, or the class's maximum."""
        if self.speed is None:
            return class_speed(self.track_class)
        return val.positive(self.speed, "speed")


def initial_pairs(
    model: SurrogateModel, vehicle: Any, collect: Callable[[Any], dict[str, Any]] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Training pairs of the packaged recipe of ``model``'s form (memory: :data:`MEMORY_DESIGN`;
    static: the paper design), run on ``vehicle``'s reference or by ``collect`` (``design →``
    runs as :func:`collect_design` returns them, e.g. an FMU's)."""
    form = element_form(getattr(model, "features_", None))

    def builtin(design: Any) -> dict[str, Any]:
        return collect_design(design, vehicle=vehicle)

    run = builtin if collect is None else collect
    if form.form in MEMORY_FORMS:
        data = run(design_with(MEMORY_DESIGN, None, MEMORY_SAMPLE_RATE))
        product = form.form == "maxwell_product"
        return memory_training_data(data, form.tau, form.known_physics, vehicle, product=product)
    data = run("paper")
    return data["U"], data["V"]


def element_pairs(
    model: SurrogateModel, run: dict[str, Any], every: int, vehicle: str
) -> tuple[np.ndarray, np.ndarray]:
    """Training pairs of ``model``'s feature form from a full-rate run, at every ``every``-th
    row where the element force is finite."""
    form = element_form(getattr(model, "features_", None))
    rows = np.arange(0, run["t"].size, every)
    rows = rows[np.isfinite(run["force"][rows])]
    data = {"runs": [{**run, "rows": rows}]}
    if form.form in MEMORY_FORMS:
        product = form.form == "maxwell_product"
        return memory_training_data(
            data, form.tau, form.known_physics, vehicle, form.relaxation, product=product
        )
    keep = rows[run["t"][rows] >= WARMUP]
    return np.column_stack([run["delta"], run["delta_dot"]])[keep], run["force"][keep]


def refit_worst(
    model: SurrogateModel,
    data: tuple[np.ndarray, np.ndarray],
    candidates: list[tuple[np.ndarray, np.ndarray]],
    n_add: int,
) -> tuple[SurrogateModel, np.ndarray, np.ndarray]:
    """``(model, U, V)``: the ``n_add`` candidate pairs where ``model`` is worst (outside its
    training box first, then the largest force errors) added to ``data = (U, V)``, and a copy
    of ``model`` (same class, hyperparameters and feature form) fitted to them."""
    cu = np.concatenate([c[0] for c in candidates])
    cv = np.concatenate([c[1] for c in candidates])
    outside = np.any((cu < model.lower_) | (cu > model.upper_), axis=1)
    err = np.abs(model.predict(cu) - cv)
    worst = np.argsort(np.where(outside, np.inf, err))[::-1][:n_add]
    U, V = np.concatenate([data[0], cu[worst]]), np.concatenate([data[1], cv[worst]])
    features = getattr(model, "features_", None)
    model = type(model)(**model.get_params()).fit(U, V)
    if features is not None:
        model.features_ = features
    return model, U, V


def holdout_error(
    runs: list[dict[str, Any]], refs: list[dict[str, Any]], key: str
) -> tuple[np.ndarray, int]:
    """Median over the held-out tracks of the relative RMS error of ``run[key]`` against the
    reference's (per column of a 2-D record; ``inf`` for a diverged run), and the surrogate
    runs' total out-of-domain evaluations."""
    errs, ood = [], 0
    for sur, ref in zip(runs, refs, strict=True):
        ood += sur["ood"]
        a, b = sur[key], ref[key]
        if sur["diverged"] or not np.all(np.isfinite(a)):
            errs.append(np.full(np.shape(b)[1:], np.inf))
        else:
            errs.append(np.sqrt(np.sum((a - b) ** 2, axis=0) / np.sum(b**2, axis=0)))
    return np.median(errs, axis=0), ood


def refine_rounds(
    model: SurrogateModel,
    data: tuple[np.ndarray, np.ndarray],
    rounds: int,
    options: RefineOptions,
    track: Callable[[tuple[int, ...]], Any],
    reference: Callable[[Any], dict[str, Any]],
    surrogate: Callable[[Any, SurrogateModel], dict[str, Any]],
    pairs: Callable[[SurrogateModel, dict[str, Any]], list[tuple[np.ndarray, np.ndarray]]],
    key: str,
    report: Callable[[int, np.ndarray, int, int], tuple[dict[str, Any], str]],
    log: Any = print,
) -> tuple[SurrogateModel, list[dict[str, Any]]]:
    """The refinement loop of both refiners: the reference run (``reference(track)``) on the
    ``options.n_holdout`` fixed tracks ``track((1, i))``; then for each round ``r`` of
    0..``rounds``, from round 1 the ``options.n_add`` worst of the candidate ``pairs(model,
    run)`` of reference runs on ``options.n_tracks`` new tracks ``track((2, r, i))`` added to
    ``data = (U, V)`` and refitted (:func:`refit_worst`), and the element scored on the held-out
    tracks (``surrogate(track, model)``, :func:`holdout_error` of ``run[key]``).
    ``report(r, errors, ood, n_samples)`` gives the round's history row and its ``log`` line
    (``log=None``: silent). Returns ``(model, history)``."""
    U, V = np.asarray(data[0]), np.asarray(data[1], dtype=np.float64)
    holdout = [track((1, i)) for i in range(options.n_holdout)]
    refs = [reference(tr) for tr in holdout]
    history = []
    for r in range(rounds + 1):
        if r > 0:
            candidates = []
            for i in range(options.n_tracks):
                candidates.extend(pairs(model, reference(track((2, r, i)))))
            model, U, V = refit_worst(model, (U, V), candidates, options.n_add)
        runs = [surrogate(tr, model) for tr in holdout]
        errors, ood = holdout_error(runs, refs, key)
        row, line = report(r, errors, ood, int(V.size))
        history.append(row)
        if log is not None:
            log(line)
    return model, history
