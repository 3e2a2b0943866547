"""The memory element of the vertical suspension (:mod:`surrogates.memory`): its training
pairs ``(δ, δ̇, ζ) → F_s`` from collected runs, and ``τ`` and the degrees chosen by k-fold CV
(:func:`build_memory_surrogate`, which ``railgym.vehicles.collect`` calls)."""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np

from railgym.vehicles.collect_design import (
    MEMORY_SAMPLE_RATE,
    CollectionDesign,
    collect_design,
    design_named,
)
from railgym.vehicles.vertical.elements import bump_stop_force
from railgym.vehicles.vertical.params import load_vehicle
from surrogates.memory import TauSelection, law_document, maxwell_state, relaxed_state
from surrogates.models import SurrogateModel
from surrogates.models.lpr import LegendreRegression
from surrogates.passive import PassiveLegendreRegression
from surrogates.selection import select_kfold

__all__ = [
    "MEMORY_DEGREES",
    "MEMORY_DESIGN",
    "MEMORY_TAUS",
    "WARMUP",
    "build_memory_surrogate",
    "design_with",
    "memory_degrees",
    "memory_training_data",
    "select_memory_element",
    "stage",
]

#: Maxwell time constants tried by default, s
MEMORY_TAUS = (4e-3, 8e-3, 16e-3)
#: degree tuples (δ, δ̇, ζ) tried by default for the memory element: ζ needs high degrees
#: (the controlled runs' error falls with it), capped at 20 for the cost of the recurrences
MEMORY_DEGREES = tuple(itertools.product((12, 14, 16), (12, 14, 16), (14, 16, 18, 20)))
#: data-collection design of the packaged memory element
MEMORY_DESIGN = "envelope"
#: start of each run discarded from the memory element's training samples, s (≥ 5 τ)
WARMUP = 0.1


def design_with(
    design: str | CollectionDesign, duration: float | None, sample_rate: float | None
) -> CollectionDesign:
    """``design`` with ``duration`` (s) and ``sample_rate`` (Hz) replaced where given."""
    des = design_named(design)
    changes = {"duration": duration, "sample_rate": sample_rate}
    return dataclasses.replace(des, **{k: v for k, v in changes.items() if v is not None})


def stage(
    progress: Callable[[str, int, int], None] | None, stage: str
) -> Callable[[int, int], None] | None:
    """``progress`` bound to ``stage`` (``None`` stays ``None``)."""
    if progress is None:
        return None
    return lambda i, total: progress(stage, i, total)


def memory_degrees(max_degree: Sequence[int]) -> list[tuple[int, ...]]:
    """The memory element's degree grid up to ``max_degree`` (one per input δ, δ̇, ζ): each
    input from the start of :data:`MEMORY_DEGREES` in steps of 2 (the packaged grid is
    ``memory_degrees((16, 16, 20))``)."""
    starts = tuple(min(d[j] for d in MEMORY_DEGREES) for j in range(3))
    if len(max_degree) != len(starts):
        raise ValueError(f"max_degree needs one degree per input (3), got {len(max_degree)}")
    for j, (lo, top) in enumerate(zip(starts, max_degree, strict=True)):
        if top < lo:
            raise ValueError(f"max_degree[{j}] must be at least {lo} (grid start), got {top}")
    return list(
        itertools.product(
            *(range(lo, top + 1, 2) for lo, top in zip(starts, max_degree, strict=True))
        )
    )


def memory_training_data(
    data: dict[str, Any],
    tau: float,
    known_physics: Iterable[str] | None = None,
    vehicle: Any = "manchester",
    relaxation: Any = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Training pairs of the memory element from a :func:`collect_design` result.

    ``ζ = δ − s`` is built from each run's full-rate history (:func:`maxwell_state`, or
    :func:`~surrogates.memory.relaxed_state` with a nonlinear ``relaxation`` law; relaxed
    start) and taken at the run's ``rows`` after :data:`WARMUP`; with ``"bump_stop"`` in
    ``known_physics`` (default: the vehicle's own) the output is
    ``F_s − F_bump(δ)``.

    Returns ``U`` (n, 3) = (δ, δ̇, ζ) in m, m/s, m and ``V`` (n,) in N.
    """
    veh = load_vehicle(vehicle)
    known, p = veh.check_known_physics(known_physics), veh.kernel_params()
    Us, Vs = [], []
    for r in data["runs"]:
        rows = r["rows"][r["t"][r["rows"]] >= WARMUP]
        d = r["delta"]
        if relaxation is None:
            zeta = maxwell_state(d, r["t"], tau)
        else:
            zeta = relaxed_state(d, r["t"], relaxation)
        force = r["force"][rows]
        if "bump_stop" in known:
            force = force - np.array([bump_stop_force(x, p) for x in d[rows]])
        Us.append(np.column_stack([d, r["delta_dot"], zeta])[rows])
        Vs.append(force)
    return np.concatenate(Us), np.concatenate(Vs)


def build_memory_surrogate(
    design: str | CollectionDesign = MEMORY_DESIGN,
    taus: Sequence[float] = MEMORY_TAUS,
    degrees: Iterable[Any] = MEMORY_DEGREES,
    passive: bool = True,
    known_physics: Sequence[str] | None = None,
    duration: float | None = None,
    sample_rate: float | None = MEMORY_SAMPLE_RATE,
    k: int = 5,
    seed: int = 0,
    vehicle: Any = "manchester",
    progress: Callable[[str, int, int], None] | None = None,
    data: dict[str, Any] | None = None,
) -> tuple[SurrogateModel, TauSelection, dict[str, Any]]:
    """The memory element: ``F̂(δ, δ̇, ζ)`` with ``τ`` and the degrees chosen by k-fold CV.

    Parameters
    ----------
    design : ``"paper"``, ``"envelope"`` (default, :data:`MEMORY_DESIGN`) or a
        ``CollectionDesign``.
    taus : candidate Maxwell time constants, s. degrees : candidate degree tuples.
    passive : fit :class:`~surrogates.passive.PassiveLegendreRegression` (non-negative
        slopes in every input) instead of the unconstrained LPR.
    known_physics : ``("bump_stop",)`` adds the vehicle's bump-stop law in the kernel;
        ``None``: what ``vehicle`` has (``VerticalVehicle.check_known_physics``).
    vehicle : the vehicle of the data (name, YAML path or ``VerticalVehicle``): its
        reference runs, its known physics.
    duration, sample_rate : replace the design's (s, Hz); the default trains on 200 Hz.
    k, seed : folds and their shuffling seed.
    progress : optional ``callback(stage, i, total)`` (reference runs, degree search per τ).
    data : training data already collected (a :func:`collect_design` result, e.g. from an
        FMU by :func:`railgym.fmu.collect.collect_fmu`) instead of running ``design``.

    Returns
    -------
    (model, selection, data) : the fitted element with its ``features_`` (form, τ, known
    physics), the :class:`~surrogates.memory.TauSelection` (score of the best degree of each
    ``τ``; ``results`` the full tables) and the :func:`collect_design` data with the
    training pairs ``U_memory``, ``V_memory``.
    """
    if data is None:
        data = collect_design(
            design_with(design, duration, sample_rate),
            vehicle=vehicle,
            progress=stage(progress, "reference runs"),
        )
    cls = PassiveLegendreRegression if passive else LegendreRegression
    model, selection = select_memory_element(
        data, taus, degrees, cls, known_physics, vehicle, k, seed, progress
    )
    return model, selection, data


def select_memory_element(
    data: dict[str, Any],
    taus: Sequence[float],
    degrees: Iterable[Any],
    cls: Callable[..., SurrogateModel],
    known_physics: Sequence[str] | None,
    vehicle: Any,
    k: int,
    seed: int,
    progress: Callable[[str, int, int], None] | None = None,
    laws: dict[float, Any] | None = None,
) -> tuple[SurrogateModel, TauSelection]:
    """The memory element of class ``cls`` on collected ``data`` (:func:`memory_training_data`
    of ``vehicle``) with ``τ`` among ``taus`` (s) and the degrees among ``degrees`` chosen by
    ``k``-fold CV (folds shuffled by ``seed``); its training pairs go to
    ``data["U_memory"], data["V_memory"]``. ``laws``: a nonlinear relaxation law per ``τ``
    (:mod:`surrogates.memory`; stored in the model's features). Arguments as
    :func:`build_memory_surrogate`."""
    degrees = list(degrees)
    known_physics = load_vehicle(vehicle).check_known_physics(known_physics)
    out = TauSelection()
    pairs = {}
    for tau in taus:
        law = None if laws is None else laws[tau]
        U, V = memory_training_data(data, tau, known_physics, vehicle, law)
        res = select_kfold(
            lambda deg: cls(degree=deg),
            degrees,
            U,
            V,
            k=k,
            seed=seed,
            progress=stage(progress, f"degrees at tau {1e3 * tau:g} ms"),
        )
        row = next(r for r in res.table if r["candidate"] == res.best)
        out.table.append({"tau": tau, "degree": res.best, "rms": row["rms"], "nrms": row["nrms"]})
        out.results.append(res)
        pairs[tau] = (U, V)
    best = min(out.table, key=lambda r: r["rms"])
    out.best = (best["tau"], best["degree"])
    U, V = pairs[best["tau"]]
    model = cls(degree=best["degree"]).fit(U, V)
    model.features_ = {
        "form": "maxwell",
        "tau": best["tau"],
        "known_physics": list(known_physics),
    }
    if laws is not None and laws[best["tau"]] is not None:
        model.features_["relaxation"] = law_document(laws[best["tau"]])
    data["U_memory"], data["V_memory"] = U, V
    return model, out
