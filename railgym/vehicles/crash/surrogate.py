"""Surrogate crash elements (paper eq. 4) fitted on reference runs: :func:`build_crash_surrogate`.

One mass per car (plus the obstacle, if any); the wall element's feature is
``u = x_lead − x_barrier`` (``x_barrier = 0`` for a rigid wall), the interface's
``u = x_{k+1} − x_k``, both from the cars' centre-of-mass displacements, as the paper's
``(x_1, f_1)`` and ``(x_1 − x_2, f_2)``. Two element variants:

``"paper"``
    one LPR for the loading branch and one for the unloading branch, switched by the sign of
    the crush rate ``u̇`` (paper section 3.1); the training samples are split by
    :func:`surrogates.features.split_branches`. Each LPR's output is clipped to the force
    range of its branch's data: the unloading branch is fitted on few samples (the rebound)
    and, unclipped, its extrapolation throws the cars apart. Being memoryless, this variant
    can push at any crush (e.g. the loading force at rest when ``u̇`` is a hair above zero).
``"hysteretic"``
    the loading LPR is the envelope (fitted on virgin-loading samples only); unloading and
    reloading follow a straight line of stiffness ``k̂_u`` (estimated from the unloading samples)
    from the largest crush reached, with permanent set, exactly like the reference law; so the
    element dissipates energy only on the envelope. Interface tension, if the data have any, is a
    fitted linear spring ``k̂_t`` with slack ``ŝ`` beyond the permanent set.

A wall element never pulls (``f ≥ 0``) in either variant. LPR degrees are chosen by 10-fold
cross-validation (:func:`surrogates.selection.select_kfold`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from railgym.vehicles.crash.outputs import CrashResult
from railgym.vehicles.crash.piecewise import PIECE_DEGREES, fit_piecewise
from surrogates.features import LOADING, split_branches
from surrogates.selection import factory_for, select_kfold

__all__ = [
    "VARIANTS",
    "CrashElement",
    "CrashFitOptions",
    "CrashSurrogate",
    "NoUnloadingError",
    "TrainingSet",
    "build_crash_surrogate",
    "crash_errors",
    "crash_training_data",
    "plastic_loading",
    "virgin_loading",
    "zone_unloading_stiffness",
]

#: element variants of the surrogate model
VARIANTS = ("paper", "hysteretic")
#: element features of :func:`crash_training_data`
FEATURES = ("com", "zone")
#: most masses per car of the surrogate model
MAX_NODES_PER_CAR = 16


class NoUnloadingError(ValueError):
    """The training runs hold no elastic unloading of an element: its unloading stiffness
    ``k_u`` cannot be estimated (``element``: its name)."""

    def __init__(self, element: str, message: str) -> None:
        super().__init__(message)
        self.element = element


@dataclass
class CrashElement:
    """One surrogate crash element (paper eq. 4), fitted on reference time histories.

    Attributes
    ----------
    name : ``"wall"`` (lead car against the barrier) or ``"interface"`` (between two cars).
    variant : ``"paper"`` or ``"hysteretic"`` (see the module docstring).
    loading : LPR of the loading branch (``"paper"``) or of the envelope (``"hysteretic"``),
        force (N) of the feature ``u`` (m); or a
        :class:`~railgym.vehicles.crash.piecewise.PiecewiseEnvelope` (one LPR per stage).
    unloading : LPR of the unloading branch (``"paper"`` only).
    unloading_stiffness : ``k̂_u`` of elastic unloading/reloading, N/m (estimated for both
        variants, used by ``"hysteretic"``).
    tension_stiffness, slack : fitted coupler tension ``k̂_t`` (N/m; 0 = none) and slack ``ŝ``
        (m) beyond the permanent set (``"hysteretic"``).
    unilateral : the element never pulls and carries no force for ``u ≤ 0`` (the wall).
    force_range : (branch → (lowest, highest) training force, N); each LPR's output is clipped
        to its branch's range, so that a branch extrapolated beyond its data (the paper
        variant's unloading branch, fitted on a narrow set) cannot produce unseen forces.
    selection : 10-fold cross-validation table of each fitted LPR (branch → SelectionResult).
    n_samples : number of training samples of each branch.
    zone_unloading_stiffness : the zone's own ``k̂_u`` (N/m), on the crush between the car
        ends (:func:`zone_unloading_stiffness`); with one mass per car ``unloading_stiffness``
        is that of the zone and the carbodies in series, lower. ``None``: not estimated
        (elements written before railgym 0.5).
    """

    name: str
    variant: str
    loading: Any
    unloading: Any
    unloading_stiffness: float
    tension_stiffness: float
    slack: float
    unilateral: bool
    force_range: dict[str, tuple[float, float]]
    selection: dict[str, Any]
    n_samples: dict[str, int]
    zone_unloading_stiffness: float | None = None

    @property
    def degrees(self) -> dict[str, int]:
        """Chosen LPR degree of each branch."""
        out = {"loading": _degree(self.loading)}
        if self.unloading is not None:
            out["unloading"] = _degree(self.unloading)
        return out


@dataclass
class CrashSurrogate:
    """The surrogate elements of one model: ``elements["wall"]`` and ``elements["interface"]``.

    ``nodes_per_car`` is the number of lumped masses per car the elements were fitted for: 1
    (paper eq. 4; the elements' feature ``u`` from the cars' centres of mass) or more (each car
    an elastic chain of that many masses, as the reference's carbody; the elements join the
    car ends and their feature is the zone crush).
    """

    variant: str
    elements: dict[str, CrashElement]
    source: str  #: name of the scenario the elements belong to (checked by the env)
    build_time: float
    origin: str = "reference model"  #: where the training data came from
    nodes_per_car: int = 1


def _degree(model: Any) -> int:
    d = model.degree
    return int(d[0] if isinstance(d, tuple) else d)


TrainingSet = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def crash_training_data(
    result: CrashResult, branch_tol: float = 0.01, feature: str = "com"
) -> dict[str, TrainingSet]:
    """Surrogate training data ``(u, f, u̇, loading, series)`` per element type.

    ``u`` with ``feature="com"`` from the cars' centre-of-mass displacements: wall
    ``x_lead − x_barrier``, interface ``x_{k+1} − x_k`` (all interfaces pooled); with
    ``"zone"`` the zone's crush between the car ends; ``f`` the zone's force (N); ``u̇`` by
    :func:`numpy.gradient` of each series (m/s); ``loading`` the loading-branch mask of
    :func:`surrogates.features.split_branches` (sign of the crush rate with hysteresis
    ``branch_tol`` × the 90th percentile of |u̇|; its default 0.05, i.e. ~0.5 m/s in a 40 km/h
    crash, would label the slow rebound as loading); ``series`` the index of the time
    history each sample comes from (one per interface).
    """
    t = result.t
    if t.size < 3:
        raise ValueError("result has fewer than 3 samples: too short to train on")
    names = result.body_names
    x_bar = result.x[:, names.index("obstacle")] if "obstacle" in names else 0.0
    n_cars = result.scenario.n_cars
    series: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {"wall": [], "interface": []}
    wall = result.force[:, result.zone_names.index("wall")]
    if feature not in FEATURES:
        raise ValueError(f"feature must be one of {FEATURES}, got {feature!r}")
    zone = feature == "zone"
    u_wall = result.crush[:, result.zone_names.index("wall")] if zone else result.x[:, 0] - x_bar
    series["wall"].append((u_wall, wall))
    for k in range(1, n_cars):
        j = result.zone_names.index(f"interface_{k}")
        u = result.crush[:, j] if zone else result.x[:, k] - result.x[:, k - 1]
        series["interface"].append((u, result.force[:, j]))
    out = {}
    for key, items in series.items():
        if items:
            u = np.concatenate([s[0] for s in items])
            f = np.concatenate([s[1] for s in items])
            rate = np.concatenate([np.gradient(s[0], t) for s in items])
            load = np.concatenate(
                [split_branches(s[0], t, tol=branch_tol) == LOADING for s in items]
            )
            series_id = np.repeat(np.arange(len(items)), t.size)
            out[key] = (u, f, rate, load, series_id)
    return out


def virgin_loading(
    u: np.ndarray, rate: np.ndarray, series: np.ndarray | None = None, tol: float = 1e-4
) -> np.ndarray:
    """Mask of the samples on the virgin loading path: crush growing and within ``tol`` (m) of
    the largest crush reached so far in the same time history (``series``, default one)."""
    series = np.zeros(u.size, dtype=np.int64) if series is None else series
    out = np.zeros(u.size, dtype=bool)
    for k in np.unique(series):
        i = series == k
        out[i] = (rate[i] > 0.0) & (u[i] >= np.maximum.accumulate(u[i]) - tol)
    return out


def plastic_loading(
    u: np.ndarray,
    f: np.ndarray,
    rate: np.ndarray,
    stiffness: float,
    series: np.ndarray | None = None,
    scale: np.ndarray | None = None,
    tol: float = 1e-6,
) -> np.ndarray:
    """Mask of the samples on the loading envelope: on the virgin loading path
    (:func:`virgin_loading`) and inside plastic flow.

    The permanent set a sample implies under elastic unloading of stiffness ``k_u`` (N/m) is
    ``u − f / k_u`` (m); plastic flow is where that set grows by more than ``tol`` (m) over the
    interval before the sample and the one after it, the zone in compression (``f > 0``) at
    both ends of each, in the same time history (``series``, default one). This leaves out
    samples on an elastic line at the largest crush reached so far: the end of a reload, and the
    elastic rise of a zone whose scaled envelope is steeper there than ``k_u`` (an absorber
    scale above 1 on the first rise), whose forces are not the envelope's; ``rate`` (m/s) as
    :func:`virgin_loading`. ``scale``: the envelope's scale at each sample (default 1); a sample
    whose scale differs from the one before it is left out too (after a step up of the scale the
    zone reloads elastically for part of the interval).
    """
    series = np.zeros(u.size, dtype=np.int64) if series is None else series
    scale = np.ones(u.size) if scale is None else scale
    out = np.zeros(u.size, dtype=bool)
    for k in np.unique(series):
        i = np.flatnonzero(series == k)
        if i.size < 3:
            continue
        contact = f[i] > 0.0
        grow = (np.diff(u[i] - f[i] / stiffness) > tol) & contact[:-1] & contact[1:]
        same = np.diff(scale[i]) == 0.0
        out[i[1:-1]] = grow[:-1] & grow[1:] & same[:-1]
    return out & virgin_loading(u, rate, series)


def _fit_lpr(
    u: np.ndarray, f: np.ndarray, max_degree: int, seed: int, degrees: Any = None
) -> tuple[Any, Any]:
    """LPR of f(u) with the degree chosen by 10-fold CV (``clip`` extrapolation) among
    ``degrees`` (default 1 … ``max_degree``)."""
    n = u.size
    if n < 4:
        raise ValueError(f"too few training samples ({n}) to fit a surrogate branch")
    make = factory_for("lpr", extrapolation="clip")
    tried = range(1, max_degree + 1) if degrees is None else degrees
    cands = [int(d) for d in tried if 1 <= d <= n - 2]
    sel = select_kfold(make, cands, u[:, None], f, k=min(10, n), seed=seed)
    return make(sel.best).fit(u[:, None], f), sel


def _unloading_stiffness(
    u: np.ndarray,
    f: np.ndarray,
    rate: np.ndarray,
    series: np.ndarray,
    name: str = "element",
    on_force: bool = False,
) -> float:
    """Least-squares slope (N/m) of f against u on the elastic unloading lines: each run of
    consecutive intervals of unloading under load (u and f falling) is one line with its own
    intercept (its permanent set), the slope pooled over the lines (:class:`NoUnloadingError`
    naming the element ``name`` when there are none). ``on_force``: ``u`` is fitted on ``f``
    and the slope is the inverse of that compliance, for a ``u`` with errors of its own (a
    reconstructed zone crush), which would dilute the slope of ``f`` on ``u``.

    Fitting the levels of each line, not the slopes of single intervals, keeps the noise of
    short intervals (a stress wave in a carbody, the digits of an FE file) from biasing it low.
    """
    du, df = np.diff(u), np.diff(f)
    ok = (rate[1:] < 0) & (rate[:-1] < 0) & (f[1:] > 0) & (f[:-1] > 0) & (du < 0) & (df < 0)
    ok &= series[1:] == series[:-1]
    if np.count_nonzero(ok) < 2:
        raise NoUnloadingError(
            name,
            f"the training data hold no elastic unloading of the {name} element: k_u cannot be "
            "estimated",
        )
    idx = np.flatnonzero(ok)  # interval i joins samples i and i + 1
    line = np.cumsum(np.concatenate(([1], np.diff(idx) != 1)))
    num = den = 0.0
    for k in np.unique(line):
        pts = np.append(idx[line == k], idx[line == k][-1] + 1)
        uu, ff = u[pts] - u[pts].mean(), f[pts] - f[pts].mean()
        num += float(ff @ ff if on_force else uu @ ff)
        den += float(uu @ ff if on_force else uu @ uu)
    return num / den


def zone_unloading_stiffness(references: list[CrashResult]) -> dict[str, float]:
    """Unloading stiffness ``k̂_u`` (N/m) of each element type on the zones' own crush
    (``result.crush``, between the car ends), the runs pooled; an element type whose runs
    hold no elastic unloading is left out."""
    out = {}
    for name, ((u, f, rate, _, series), _) in _pooled_training_data(references, "zone").items():
        try:
            out[name] = _unloading_stiffness(u, f, rate, series, name, on_force=True)
        except NoUnloadingError:
            continue
    return out


def _element_scale(scale: Any, name: str) -> float:
    """Absorber scale of element type ``name`` in a run of absorber scale ``scale``: one number
    for every zone, or a ``(wall, interface)`` pair."""
    if np.ndim(scale) == 0:
        return float(scale)
    return float(scale[0 if name == "wall" else 1])


def _pooled_training_data(
    references: list[CrashResult], feature: str = "com"
) -> dict[str, tuple[TrainingSet, np.ndarray]]:
    """:func:`crash_training_data` of several results pooled per element type (series
    numbered apart) with each sample's absorber scale (``result.extra["absorber_scale"]``,
    default 1: one number for every zone of a run, or a ``(wall, interface)`` pair)."""
    pooled: dict[str, list[tuple[TrainingSet, float]]] = {}
    for ref in references:
        scale = ref.extra.get("absorber_scale", 1.0)
        for name, data in crash_training_data(ref, feature=feature).items():
            pooled.setdefault(name, []).append((data, _element_scale(scale, name)))
    out = {}
    for name, items in pooled.items():
        offset, parts, scales = 0, [], []
        for (u, f, rate, load, series), scale in items:
            parts.append((u, f, rate, load, series + offset))
            scales.append(np.full(u.size, scale))
            offset += int(series.max()) + 1
        cols = tuple(np.concatenate([p[j] for p in parts]) for j in range(5))
        out[name] = (cols, np.concatenate(scales))
    return out


def build_crash_surrogate(
    reference: CrashResult | list[CrashResult],
    variant: str = "hysteretic",
    seed: int = 0,
    max_degree: int = 30,
    degrees: Any = None,
    nodes_per_car: int = 1,
    knots: dict[str, Any] | None = None,
) -> CrashSurrogate:
    """Fit the surrogate elements of paper eq. (4) on one reference result or several.

    Parameters
    ----------
    reference : output of :func:`simulate_reference`, or a list of reference results of one
        scenario (e.g. :func:`railgym.vehicles.crash.elements.envelope_runs`) pooled into one
        element set. A run with absorber scale ``s`` (``result.extra["absorber_scale"]``: one
        number, or a ``(wall, interface)`` pair, each zone its own) contributes its loading
        forces divided by ``s`` within the absorber stroke, i.e. the nominal envelope the
        element scales at run time; unloading samples (``k̂_u``) as they are.
    variant : ``"paper"`` (loading/unloading LPR switched by the crush rate) or
        ``"hysteretic"`` (LPR envelope + elastic unloading, energy-consistent).
    seed : seed of the cross-validation folds.
    max_degree : largest LPR degree tried by 10-fold cross-validation; degrees : the LPR
        degrees tried instead (a sequence of positive integers, e.g. a coarse grid up to a
        high degree).
    nodes_per_car : masses per car of the model the elements are for
        (:attr:`CrashSurrogate.nodes_per_car`): 1 fits on the centre-of-mass feature, more on
        the zone crush.
    knots : element name → crush (m) of the stage ends; that element's envelope
        (``"hysteretic"``) is then one LPR per stage (:func:`fit_piecewise`, degrees by CV
        among ``degrees`` or :data:`~railgym.vehicles.crash.piecewise.PIECE_DEGREES`).
    """
    refs = _check_build(reference, variant, nodes_per_car)
    scenario = refs[0].scenario
    t0 = time.perf_counter()
    absorber = {
        "wall": scenario.wall.absorber_stroke,
        "interface": scenario.interface.absorber_stroke,
    }
    feature = "com" if nodes_per_car == 1 else "zone"
    fit = CrashFitOptions(variant, seed, max_degree, degrees, nodes_per_car, knots)
    elements = {
        name: _fit_element(name, data, run_scale, absorber[name], fit)
        for name, (data, run_scale) in _pooled_training_data(refs, feature).items()
    }
    for name, ku in zone_unloading_stiffness(refs).items():
        elements[name].zone_unloading_stiffness = ku
    return CrashSurrogate(
        variant=variant,
        elements=elements,
        source=scenario.name,
        build_time=time.perf_counter() - t0,
        nodes_per_car=int(nodes_per_car),
    )


def _check_build(
    reference: CrashResult | list[CrashResult], variant: str, nodes_per_car: Any
) -> list[CrashResult]:
    """The reference results of :func:`build_crash_surrogate`; ``ValueError`` naming a bad
    argument."""
    if isinstance(nodes_per_car, bool) or not isinstance(nodes_per_car, int | np.integer):
        raise ValueError(f"nodes_per_car must be an integer, got {nodes_per_car!r}")
    if not 1 <= nodes_per_car <= MAX_NODES_PER_CAR:
        raise ValueError(f"nodes_per_car must be in [1, {MAX_NODES_PER_CAR}], got {nodes_per_car}")
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    refs = reference if isinstance(reference, list) else [reference]
    if not refs:
        raise ValueError("reference must hold at least one reference result")
    for ref in refs:
        if ref.model != "reference":
            raise ValueError(f"reference must be a reference-model result, got {ref.model!r}")
    return refs


@dataclass(frozen=True)
class CrashFitOptions:
    """How the crash elements are fitted: the arguments of :func:`build_crash_surrogate`
    after ``reference`` (documented there), for callers that pass them on
    (:func:`railgym.vehicles.crash.fe.crash_surrogate_from_fe`)."""

    variant: str = "hysteretic"
    seed: int = 0
    max_degree: int = 30
    degrees: Any = None
    nodes_per_car: int = 1
    knots: dict[str, Any] | None = None


def _fit_element(
    name: str, data: tuple, run_scale: np.ndarray, absorber: float, fit: CrashFitOptions
) -> CrashElement:
    """The element ``name`` fitted on its pooled training ``data`` (:func:`_pooled_training_data`)
    with the run scales ``run_scale`` applied within the ``absorber`` stroke (m)."""
    u, f, rate, loading, series = data
    # nominal envelope: the loading forces of a scaled absorber divided by its scale
    env_scale = np.where(u <= absorber, run_scale, 1.0)
    nominal = f / env_scale
    unilateral = name == "wall"
    sel: dict[str, Any] = {}
    kt = slack = 0.0
    unload = None
    ku = _unloading_stiffness(u, f, rate, series, name)
    if fit.variant == "paper":
        lo, un = loading, ~loading
        load, sel["loading"] = _fit_lpr(u[lo], nominal[lo], fit.max_degree, fit.seed, fit.degrees)
        unload, sel["unloading"] = _fit_lpr(u[un], f[un], fit.max_degree, fit.seed, fit.degrees)
        n = {"loading": int(lo.sum()), "unloading": int(un.sum())}
        rng = {
            "loading": (nominal[lo].min(), nominal[lo].max()),
            "unloading": (f[un].min(), f[un].max()),
        }
    else:
        # the zone crush's own law: plastic flow; the centre-of-mass feature (one mass per car)
        # holds carbody elasticity as well, so there the samples at the largest crush so far
        if fit.nodes_per_car > 1:
            vg = plastic_loading(u, f, rate, ku, series, env_scale) & (f > 0)
        else:
            vg = virgin_loading(u, rate, series) & (f > 0)
        uu = np.concatenate(([0.0], u[vg]))
        ff = np.concatenate(([0.0], nominal[vg]))
        if fit.knots is not None and name in fit.knots:
            cands = PIECE_DEGREES if fit.degrees is None else fit.degrees
            load, tables = fit_piecewise(uu, ff, fit.knots[name], fit.seed, cands)
            sel.update({f"loading_{i}": t for i, t in enumerate(tables)})
        else:
            load, sel["loading"] = _fit_lpr(uu, ff, fit.max_degree, fit.seed, fit.degrees)
        n = {"loading": int(uu.size)}
        rng = {"loading": (0.0, ff.max())}
        tension = f < 0
        if not unilateral and np.count_nonzero(tension) >= 5:
            # f = k_t (u − u_p + ŝ) on the tension samples, u_p the permanent set of each
            # run's history (its absorber scale applied), so runs with different sets pool
            up = _permanent_set_history(u, series, load, ku, env_scale)
            stretch = u[tension] - up[tension]
            A = np.column_stack([stretch, np.ones(np.count_nonzero(tension))])
            (kt, c), *_ = np.linalg.lstsq(A, f[tension], rcond=None)
            slack = max(0.0, float(c / kt)) if kt > 0 else 0.0
            kt = max(float(kt), 0.0)
            n["tension"] = int(np.count_nonzero(tension))
    return CrashElement(
        name=name,
        variant=fit.variant,
        loading=load,
        unloading=unload,
        unloading_stiffness=ku,
        tension_stiffness=kt,
        slack=slack,
        unilateral=unilateral,
        force_range={k: (float(a), float(b)) for k, (a, b) in rng.items()},
        selection=sel,
        n_samples=n,
    )


def _permanent_set_history(
    u: np.ndarray, series: np.ndarray, envelope: Any, ku: float, scale: Any = 1.0
) -> np.ndarray:
    """Permanent set (m) along each feature history ``u`` under the hysteretic element law,
    the envelope times ``scale`` (per sample, or one number)."""
    env = envelope.predict(u[:, None]) * scale
    up = np.zeros_like(u)
    cur = 0.0
    for i in range(u.size):
        if i > 0 and series[i] != series[i - 1]:
            cur = 0.0
        if env[i] > 0 and ku * (u[i] - cur) >= env[i]:
            cur = u[i] - env[i] / ku
        up[i] = cur
    return up


def crash_errors(prediction: CrashResult, truth: CrashResult) -> dict[str, np.ndarray]:
    """Paper eq. (9) average absolute errors per car over the common samples.

    Returns ``{"x": (cars,) m, "v": (cars,) m/s, "a": (cars,) m/s²}``.
    """
    if not np.isclose(prediction.t[1] - prediction.t[0], truth.t[1] - truth.t[0]):
        raise ValueError("prediction and truth must share the sample interval")
    n = min(prediction.t.size, truth.t.size)
    cars = truth.scenario.n_cars
    if prediction.scenario.n_cars != cars:
        raise ValueError("prediction and truth have different numbers of cars")
    out = {}
    for key in ("x", "v", "a"):
        diff = getattr(prediction, key)[:n, :cars] - getattr(truth, key)[:n, :cars]
        out[key] = np.mean(np.abs(diff), axis=0)
    return out
