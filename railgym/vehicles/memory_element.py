"""The memory element of the vertical suspension (:mod:`surrogates.memory`): its training
pairs ``(δ, δ̇, ζ) → F_s`` (or ``(δ, δ̇, ζ, δ·ζ)``, form ``"maxwell_product"``) from collected
runs, and ``τ``, the degrees and the form chosen by k-fold CV (:func:`build_memory_surrogate`,
which ``railgym.vehicles.collect`` calls)."""

from __future__ import annotations

import dataclasses
import itertools
import warnings
from collections.abc import Callable, Iterable, Sequence
from functools import partial
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
from surrogates import tau_search as ts
from surrogates.memory import TauSelection, law_document, maxwell_state, relaxed_state
from surrogates.models import SurrogateModel
from surrogates.models.lpr import LegendreRegression
from surrogates.passive import PassiveLegendreRegression
from surrogates.selection import SelectionResult, select_kfold

__all__ = [
    "MEMORY_DEGREES",
    "MEMORY_DESIGN",
    "COUPLED_DEGREES",
    "MEMORY_GAIN",
    "PRODUCT_DEGREES",
    "PRODUCT_FLOOR",
    "WARMUP",
    "build_memory_surrogate",
    "choose_memory_element",
    "design_with",
    "element_runs",
    "memory_degrees",
    "memory_training_data",
    "select_memory_element",
    "stage",
]

#: relative k-fold RMS gain of the memory form over the memoryless one above which the data
#: "show memory" (the default number of memory states is then 1), and of the coupled map
#: over the additive one above which the coupled map is taken
MEMORY_GAIN = 0.05
#: total degrees of the coupled map (LPR with interactions) scored at the chosen τ
COUPLED_DEGREES = (4, 6, 8)
#: degrees of the product input δ·ζ (form ``"maxwell_product"``) scored with the additive
#: winner's degrees of (δ, δ̇, ζ)
PRODUCT_DEGREES = (1, 2, 4)
#: relative k-fold RMS of the additive memory map below which the product input is not scored
#: (a map within 1 % of the force needs no coupling)
PRODUCT_FLOOR = 0.01
#: degree tuples (δ, δ̇, ζ) tried by default for the memory element: ζ needs high degrees
#: (the controlled runs' error falls with it), capped at 20 for the cost of the recurrences
MEMORY_DEGREES = tuple(itertools.product((12, 14, 16), (12, 14, 16), (14, 16, 18, 20)))
#: top of the packaged element's degree grid (δ, δ̇, ζ): ``memory_degrees(PACKAGED_GRID)``
#: is :data:`MEMORY_DEGREES`, searched without widening when the packaged file is regenerated
PACKAGED_GRID = (16, 16, 20)
#: the packaged element's candidate Maxwell time constants, s (its regeneration scores these)
PACKAGED_TAUS = (0.004, 0.008, 0.016)
#: largest degree per input that the default grid is widened to when its winner sits at the top
WIDEN_LIMIT = (24, 40, 32)
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


def element_runs(
    data: dict[str, Any], known_physics: Iterable[str] | None = None, vehicle: Any = "manchester"
) -> list[dict[str, Any]]:
    """The runs of a :func:`collect_design` result as the element is fitted on them: full
    histories ``t, delta, delta_dot``, the sample indices ``rows`` after :data:`WARMUP` and
    ``force`` (N) at those rows, less the bump-stop law with ``"bump_stop"`` in
    ``known_physics`` (default: the vehicle's own)."""
    veh = load_vehicle(vehicle)
    known, p = veh.check_known_physics(known_physics), veh.kernel_params()
    out = []
    for r in data["runs"]:
        rows = r["rows"][r["t"][r["rows"]] >= WARMUP]
        force = r["force"][rows]
        if "bump_stop" in known:
            force = force - np.array([bump_stop_force(x, p) for x in r["delta"][rows]])
        out.append({**r, "rows": rows, "force": force})
    return out


def memory_training_data(
    data: dict[str, Any],
    tau: float,
    known_physics: Iterable[str] | None = None,
    vehicle: Any = "manchester",
    relaxation: Any = None,
    runs: list[dict[str, Any]] | None = None,
    product: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Training pairs of the memory element from a :func:`collect_design` result.

    ``ζ = δ − s`` is built from each run's full-rate history (:func:`maxwell_state`, or
    :func:`~surrogates.memory.relaxed_state` with a nonlinear ``relaxation`` law; relaxed
    start) and taken at the rows of :func:`element_runs` (``runs``: those already built).

    Returns ``U`` (n, 3) = (δ, δ̇, ζ) in m, m/s, m (``product``: (n, 4) with ``δ·ζ`` in m²,
    the form ``"maxwell_product"``) and ``V`` (n,) in N.
    """
    if runs is None:
        runs = element_runs(data, known_physics, vehicle)
    Us, Vs = [], []
    for r in runs:
        d = r["delta"]
        if relaxation is None:
            zeta = maxwell_state(d, r["t"], tau)
        else:
            zeta = relaxed_state(d, r["t"], relaxation)
        cols = [d, r["delta_dot"], zeta, d * zeta] if product else [d, r["delta_dot"], zeta]
        Us.append(np.column_stack(cols)[r["rows"]])
        Vs.append(r["force"])
    return np.concatenate(Us), np.concatenate(Vs)


def build_memory_surrogate(
    design: str | CollectionDesign = MEMORY_DESIGN,
    tau: Any = None,
    degrees: Iterable[Any] | None = None,
    passive: bool = True,
    known_physics: Sequence[str] | None = None,
    duration: float | None = None,
    sample_rate: float | None = MEMORY_SAMPLE_RATE,
    k: int = 5,
    seed: int = 0,
    vehicle: Any = "manchester",
    progress: Callable[[str, int, int], None] | None = None,
    data: dict[str, Any] | None = None,
    memory_states: int | None = None,
    coupled: bool | None = False,
    product: bool = True,
) -> tuple[SurrogateModel, TauSelection, dict[str, Any]]:
    """The memory element: ``F̂(δ, δ̇, ζ)`` with ``τ``, the degrees and the number of memory
    states chosen from the data (:func:`choose_memory_element`).

    Parameters
    ----------
    design : ``"paper"``, ``"envelope"`` (default, :data:`MEMORY_DESIGN`) or a
        ``CollectionDesign``.
    tau : where ``τ`` is searched (s; :func:`surrogates.tau_search.tau_search`): ``None``
        the default continuous range, one value, a range ``(lo, hi)`` or three or more values.
    degrees : candidate degree tuples; ``None`` (default): :data:`MEMORY_DEGREES`, widened
        (:func:`widen_degrees`) while the winner sits at the top of an input.
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
    memory_states : 0 (memoryless), 1 (one Maxwell state) or ``None``: decided from the data.
    coupled : ``None``: the coupled LPR map (:data:`COUPLED_DEGREES`, unconstrained) where
        it lowers the k-fold RMS by :data:`MEMORY_GAIN`; ``False`` (default): additive only.
    product : ``True`` (default): an additive memory map gets the product input ``δ·ζ``
        (form ``"maxwell_product"``, its own ``τ`` search, :data:`PRODUCT_DEGREES`) where
        that lowers the k-fold RMS by :data:`MEMORY_GAIN` (scored above
        :data:`PRODUCT_FLOOR`); ``False``: never.

    Returns
    -------
    (model, selection, data) : the fitted element with its ``features_`` (form, τ, known
    physics), the :class:`~surrogates.memory.TauSelection` (score of the best degree of each
    ``τ`` tried, the decision; ``results`` the full tables) and the :func:`collect_design`
    data with the training pairs ``U_memory``, ``V_memory``.
    """
    search, states = ts.tau_search(tau, "tau"), ts.memory_states(memory_states, "memory_states")
    if data is None:
        data = collect_design(
            design_with(design, duration, sample_rate),
            vehicle=vehicle,
            progress=stage(progress, "reference runs"),
        )
    cls = PassiveLegendreRegression if passive else LegendreRegression
    model, selection = choose_memory_element(
        data,
        search,
        states,
        MEMORY_DEGREES if degrees is None else degrees,
        cls,
        known_physics,
        vehicle,
        k,
        seed,
        progress,
        coupled,
        widen=degrees is None,
        product=product,
    )
    return model, selection, data


def _static_degrees(degrees: Sequence[Any]) -> list[Any]:
    """Degrees of the memoryless form (δ, δ̇) from the memory form's candidates."""
    return sorted({tuple(d[:2]) if isinstance(d, tuple | list) else d for d in degrees})


def _probe_degree(degrees: Sequence[Any]) -> Any:
    """The degree that scores each ``τ`` of the search: the largest of each input."""
    if all(isinstance(d, tuple | list) for d in degrees):
        return tuple(int(v) for v in np.max(np.asarray(degrees), axis=0))
    return max(degrees)


def widen_degrees(
    res: SelectionResult, score: Callable[[list[tuple[int, ...]]], SelectionResult]
) -> SelectionResult:
    """``res`` (a degree search) with the search carried past its top while the winner sits
    there: each round scores (``score(grid)``, the same folds) the winner with the inputs at
    the top kept or raised by 2 and 4, up to :data:`WIDEN_LIMIT`. A winner still at the top is
    flagged by :meth:`~surrogates.selection.SelectionResult.at_cap` as before."""
    while cap := res.at_cap():
        best = tuple(int(d) for d in res.best)
        steps = [
            [b, *(d for d in (b + 2, b + 4) if j in cap and d <= WIDEN_LIMIT[j])]
            for j, b in enumerate(best)
        ]
        tried = {tuple(r["candidate"]) for r in res.table}
        grid = [g for g in itertools.product(*steps) if g not in tried]
        if not grid:
            break
        more = score(grid)
        res = SelectionResult(res.method, res.table + more.table)
        res.best = min((r for r in res.table if np.isfinite(r["rms"])), key=lambda r: r["rms"])[
            "candidate"
        ]
    return res


def _best(res: SelectionResult) -> dict[str, Any]:
    row = next(r for r in res.table if r["candidate"] == res.best)
    return {"degree": res.best, "rms": row["rms"], "nrms": row["nrms"]}


def choose_memory_element(
    data: dict[str, Any],
    search: Any,
    states: int | None,
    degrees: Iterable[Any],
    cls: Callable[..., SurrogateModel],
    known_physics: Sequence[str] | None,
    vehicle: Any,
    k: int,
    seed: int,
    progress: Callable[[str, int, int], None] | None = None,
    coupled: bool | None = False,
    widen: bool = False,
    product: bool = True,
) -> tuple[SurrogateModel, TauSelection]:
    """The element of class ``cls`` on ``data``: ``τ`` (a first guess by
    :func:`~surrogates.tau_search.fit_linear_memory`, refined by a bounded minimisation of
    the ``k``-fold CV error in ``log τ`` over the :class:`~surrogates.tau_search.TauSearch`
    ``search`` at the largest degree, then the degrees; candidate values each with every
    degree), the number of memory ``states`` (``None``: 1 when it lowers the CV error by
    :data:`MEMORY_GAIN`), ``coupled`` (:func:`_coupled_map`) and ``product``
    (:func:`_product_map`, for an additive map). A ``τ`` at the edge of
    ``search`` is a ``UserWarning`` naming ``--tau``. Pairs go to ``data["U_memory"],
    data["V_memory"]``. Arguments as :func:`build_memory_surrogate`."""
    degrees = list(degrees)
    known = load_vehicle(vehicle).check_known_physics(known_physics)
    runs = element_runs(data, known, vehicle)
    out = TauSelection(search=search, states=1 if states is None else states)
    out.guess = ts.fit_linear_memory(runs, search.lo, search.hi)

    def kfold(
        tau: float, make: Callable[..., Any], grid: Sequence[Any], what: str, prod: bool = False
    ) -> Any:
        U, V = memory_training_data(data, tau, runs=runs, product=prod)
        where = stage(progress, f"{what} at tau {1e3 * tau:.4g} ms")
        return select_kfold(make, grid, U, V, k=k, seed=seed, progress=where)

    fits: dict[float, SelectionResult] = {}

    # candidate values: each with the whole degree grid; a range: at the probe degree
    grid = degrees if search.values is not None else [_probe_degree(degrees)]

    def score(tau: float) -> float:
        fits[tau] = kfold(tau, lambda deg: cls(degree=deg), grid, "search")
        return _best(fits[tau])["rms"]

    found = None
    if states != 0:
        found = ts.search_tau(score, search, out.guess.tau)
        if search.values is None:
            fits[found.best] = kfold(found.best, lambda deg: cls(degree=deg), degrees, "degrees")
        if widen:
            at = found.best
            fits[at] = widen_degrees(
                fits[at], lambda g: kfold(at, lambda d: cls(degree=d), g, "wider")
            )
        for tau, _ in found.scores:
            out.table.append({"tau": tau, **_best(fits[tau])})
            out.results.append(fits[tau])
        out.best = (found.best, _best(fits[found.best])["degree"])
    if states != 1:
        out.static_result = _static_fit(data, out.guess.tau, runs, cls, degrees, k, seed)
        out.static = _best(out.static_result)
    _decide(out, states)
    found, make, take_product = _map(out, found, kfold, search, cls, coupled, product)
    best = out.guess.tau if found is None else found.best
    U, V = memory_training_data(data, best, runs=runs, product=take_product)
    if out.states == 0:
        assert out.static is not None
        U, out.best = U[:, :2], (None, out.static["degree"])
    else:
        out.warnings += _edge_warning(found, best, search)
    for text in out.warnings:
        warnings.warn(text.removeprefix("warning: "), UserWarning, stacklevel=3)
    model = make(degree=out.best[1]).fit(U, V)
    name = "maxwell_product" if take_product else "maxwell"
    form = {"form": name, "tau": best} if out.states else {"form": "static", "tau": None}
    model.features_ = {**form, "known_physics": list(known)}
    data["U_memory"], data["V_memory"] = U, V
    return model, out


def _static_fit(
    data: dict[str, Any],
    tau: float,
    runs: list[dict[str, Any]],
    cls: Callable[..., SurrogateModel],
    degrees: list[Any],
    k: int,
    seed: int,
) -> SelectionResult:
    """The k-fold selection of the memoryless map ``(δ, δ̇)`` over the static degrees of
    ``degrees`` (the pairs of ``τ`` with the memory input dropped)."""
    U, V = memory_training_data(data, tau, runs=runs)
    grid = _static_degrees(degrees)
    return select_kfold(lambda deg: cls(degree=deg), grid, U[:, :2], V, k=k, seed=seed)


def _edge_warning(found: Any, best: float, search: Any) -> list[str]:
    """The warning of a chosen ``τ`` (s) at an end of ``search`` (none inside it or
    without a search)."""
    if found is None or found.edge is None:
        return []
    return [
        f"warning: tau = {1e3 * best:.4g} ms is at the {found.edge} end of the search "
        f"({search.describe()}); widen it (--tau LO HI on the command line, "
        "tau=(lo, hi) in Python)"
    ]


def _map(
    out: TauSelection,
    found: Any,
    kfold: Callable[..., Any],
    search: Any,
    cls: Callable[..., SurrogateModel],
    coupled: bool | None,
    product: bool,
) -> tuple[Any, Callable[..., SurrogateModel], bool]:
    """The map of a memory element after the additive one (``found`` its τ search): the
    coupled LPR (``coupled`` ``None``, :func:`_coupled_map`), else the product input
    (``product``, an additive map above :data:`PRODUCT_FLOOR`, :func:`_product_map`).
    Returns the τ search of the map taken, its class and whether it has the product input."""
    if not out.states:
        return found, cls, False
    if coupled is None:
        found, take = _coupled_map(out, found, kfold, search)
        if take:
            return found, partial(LegendreRegression, interactions=True), False
    if product and min(r["nrms"] for r in out.table) > PRODUCT_FLOOR:
        found, take = _product_map(out, found, kfold, search, cls)
        if take:
            return found, _product_class(cls), True
    return found, cls, False


def _rival_search(
    out: TauSelection,
    found: Any,
    search: Any,
    fit: Callable[..., Any],
    grid: Sequence[Any],
    what: str,
) -> tuple[Any, dict[str, Any], Any, float]:
    """A map scored against the additive one: its own τ search from the additive map's
    ``found`` at the middle degree of ``grid`` (``fit(tau, degrees, what)`` scores), then
    every degree of ``grid`` at the best τ. Returns that search, the best row (``tau`` and
    :func:`_best`), its selection result and the gain, ``1 −`` its k-fold RMS over the
    additive map's."""
    fits: dict[float, Any] = {}

    def score(tau: float) -> float:
        fits[tau] = fit(tau, [grid[len(grid) // 2]], what)
        return float(_best(fits[tau])["rms"])

    rfound = ts.search_tau(score, search, found.best)
    fits[rfound.best] = fit(rfound.best, list(grid), f"{what} degrees")
    row = {"tau": rfound.best, **_best(fits[rfound.best])}
    return rfound, row, fits[rfound.best], 1.0 - row["rms"] / min(r["rms"] for r in out.table)


def _coupled_map(
    out: TauSelection, found: Any, kfold: Callable[..., Any], search: Any
) -> tuple[Any, bool]:
    """The coupled LPR with its own τ search (at the middle of :data:`COUPLED_DEGREES`) from
    the additive map's ``found``, then its total degree among them (``kfold(tau, make,
    grid, what)`` scores): its score goes to ``out.coupled``; taken (``out.best`` its ``τ``
    and total degree) when its k-fold RMS is :data:`MEMORY_GAIN` below the additive map's.
    Returns the search result of the map taken and whether it is the coupled one."""

    def make(degree: int) -> SurrogateModel:
        return LegendreRegression(degree=degree, interactions=True)

    def fit(tau: float, degrees: Sequence[Any], what: str) -> Any:
        return kfold(tau, make, degrees, what)

    cfound, out.coupled, out.coupled_result, gain = _rival_search(
        out, found, search, fit, COUPLED_DEGREES, "coupled"
    )
    take = gain > MEMORY_GAIN
    out.decision += (
        f"; map: {'coupled' if take else 'additive'} (the coupled LPR, total degree "
        f"{out.coupled['degree']} at tau {1e3 * cfound.best:.4g} ms, changes the k-fold RMS "
        f"by {-100 * gain:+.1f} %, threshold -{100 * MEMORY_GAIN:g} %)"
    )
    if take:
        out.best = (cfound.best, out.coupled["degree"])
    return (cfound if take else found), take


def _product_class(cls: Callable[..., SurrogateModel]) -> Callable[..., SurrogateModel]:
    """``cls`` for the inputs (δ, δ̇, ζ, δ·ζ): a passive map constrains the slopes of the
    first three only (the product's slope changes sign with ``δ``)."""
    if cls is PassiveLegendreRegression:
        return partial(PassiveLegendreRegression, monotone=(True, True, True, False))
    return cls


def _product_map(
    out: TauSelection,
    found: Any,
    kfold: Callable[..., Any],
    search: Any,
    cls: Callable[..., SurrogateModel],
) -> tuple[Any, bool]:
    """The additive map with the product input ``δ·ζ`` (form ``"maxwell_product"``): its own
    ``τ`` search from the additive map's ``found`` (the additive winner's degrees with the
    middle of :data:`PRODUCT_DEGREES`), then the product's degree among them; its score goes
    to ``out.product``; taken (``out.best`` its ``τ`` and degrees) when its k-fold RMS is
    :data:`MEMORY_GAIN` below the additive map's. Returns the search result of the map
    taken and whether it is the product one."""
    make = _product_class(cls)
    base = tuple(int(d) for d in out.best[1])

    def fit(tau: float, degrees: Sequence[int], what: str) -> Any:
        grid = [(*base, w) for w in degrees]
        return kfold(tau, lambda deg: make(degree=deg), grid, what, True)

    pfound, out.product, out.product_result, gain = _rival_search(
        out, found, search, fit, PRODUCT_DEGREES, "product"
    )
    take = gain > MEMORY_GAIN
    out.decision += (
        f"; map: {'with' if take else 'without'} the product input delta*zeta (form "
        f"'maxwell_product', degrees {out.product['degree']} at tau {1e3 * pfound.best:.4g} ms, "
        f"changes the k-fold RMS by {-100 * gain:+.1f} %, threshold -{100 * MEMORY_GAIN:g} %)"
    )
    if take:
        out.best = (pfound.best, out.product["degree"])
    return (pfound if take else found), take


def _decide(out: TauSelection, states: int | None) -> None:
    """``out.states`` and ``out.decision``: ``states`` as given, or (``None``) 1 when the
    memory form's k-fold RMS is :data:`MEMORY_GAIN` below the memoryless form's."""
    if states is not None:
        out.states, out.decision = states, f"memory states: {states} (given)"
        return
    assert out.static is not None
    gain = 1.0 - min(r["rms"] for r in out.table) / out.static["rms"]
    out.states = 1 if gain > MEMORY_GAIN else 0
    out.decision = (
        f"memory states: {out.states} (from the data: the memory state changes the k-fold "
        f"RMS by {-100 * gain:+.1f} %, threshold -{100 * MEMORY_GAIN:g} %)"
    )


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
    runs = element_runs(data, known_physics, vehicle)
    for tau in taus:
        law = None if laws is None else laws[tau]
        U, V = memory_training_data(data, tau, relaxation=law, runs=runs)
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
