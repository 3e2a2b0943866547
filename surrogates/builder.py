"""The whole pipeline in one call: sample → select degree/kernel → fit → score.

``build(U, V)`` picks ``m`` space-filling training samples (section 3.2), chooses the
model's degree (LPR) or kernel (Kriging) by out-of-bag error or k-fold cross-validation
(section 3.4), refits the winner on the training samples and reports the paper's indices.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from surrogates.metrics import paper_error, rms_normalised_error, timer
from surrogates.models import SurrogateModel
from surrogates.models.base import as_inputs, as_outputs, check_domain
from surrogates.models.checks import choice, integer
from surrogates.sampling import METHODS, select
from surrogates.selection import (
    Factory,
    SelectionResult,
    candidate_label,
    default_candidates,
    factory_for,
    select_kfold,
    select_oob,
)
from surrogates.units import check_units, element_names


@dataclass
class BuildReport:
    """What :func:`build` did and how good the result is.

    Attributes
    ----------
    kind, sampling, selection : the choices made.
    chosen : the winning degree (LPR) or kernel (Kriging).
    scores : the selection score table (one row per candidate).
    training_time_s : T_t, wall time of sampling + selection + final fit, s.
    fit_time_s : wall time of the final fit alone, s.
    oob_error, oob_error_kind : eq. 8 or eq. 9 error on the out-of-bag samples (paper's rule).
    oob_nrms : RMS error on the out-of-bag samples / RMS of their outputs.
    domain : training box (lower, upper) per input.
    train_idx, oob_idx : indices of the training and out-of-bag samples.
    """

    kind: str
    sampling: str
    selection: str
    m: int
    n: int
    chosen: Any
    scores: SelectionResult
    training_time_s: float
    fit_time_s: float
    oob_error: float
    oob_error_kind: str
    oob_nrms: float
    domain: tuple[list[float], list[float]]
    train_idx: np.ndarray = field(repr=False)
    oob_idx: np.ndarray = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (without the index arrays)."""
        return {
            "kind": self.kind,
            "sampling": self.sampling,
            "selection": self.selection,
            "m": self.m,
            "n": self.n,
            "chosen": candidate_label(self.chosen),
            "at_cap": self.scores.at_cap(),
            "training_time_s": self.training_time_s,
            "fit_time_s": self.fit_time_s,
            "oob_error": self.oob_error,
            "oob_error_kind": self.oob_error_kind,
            "oob_nrms": self.oob_nrms,
            "domain": {"lower": self.domain[0], "upper": self.domain[1]},
        }

    def format(self, unit: str | None = None, table: bool = True) -> str:
        """Human-readable summary followed by the score table; ``unit`` is the output's unit
        (e.g. ``"N"``) of the absolute OOB error (``None``: "output units"). ``table=False``:
        the summary alone, with the table's warning of a winner at the search cap."""
        if self.oob_error_kind == "relative":
            err, what = "eq. 8 relative", "(dimensionless)"
        else:
            err, what = "eq. 9 absolute", unit or "(output units)"
        head = [
            f"model: {self.kind}   chosen: {candidate_label(self.chosen)}   "
            f"samples: {self.m} of {self.n} ({self.sampling})   selection: {self.selection}",
            f"T_t = {self.training_time_s:.4f} s (final fit {self.fit_time_s * 1e3:.3f} ms)",
            f"OOB error ({err}) = {self.oob_error:.4g} {what}   "
            f"OOB relative RMS = {self.oob_nrms:.3g} (dimensionless)",
        ]
        if table:
            return "\n".join(head) + "\n" + self.scores.format()
        warning = [x for x in self.scores.format().splitlines() if x.startswith("warning:")]
        return "\n".join(head + warning)


def build(
    U: Any,
    V: Any,
    kind: str = "lpr",
    m: int = 101,
    sampling: str = "ga",
    selection: str = "oob",
    seed: int | None = 0,
    candidates: Sequence[Any] | None = None,
    k: int = 10,
    extrapolation: str = "linear",
    progress: Callable[[str, int, int], None] | None = None,
    *,
    inputs: Sequence[str] | None = None,
    output: str | None = None,
    units: Mapping[str, str] | None = None,
    **model_params: Any,
) -> tuple[SurrogateModel, BuildReport]:
    """Build a surrogate element from data.

    Parameters
    ----------
    U, V : inputs (n, d) and outputs (n,).
    kind : ``"lpr"`` (Legendre polynomial regression) or ``"kriging"``.
    m : number of training samples picked by ``sampling`` (``"ga"``, ``"greedy"``, ``"random"``);
        the other n − m points are the out-of-bag test samples.
    selection : ``"oob"`` (score on the out-of-bag samples) or ``"kfold"`` (k-fold CV on the
        training samples).
    seed : seed of the sampling and the fold split.
    candidates : degrees (LPR) or kernels (Kriging) to choose from; default
        :func:`~surrogates.selection.default_candidates`.
    progress : optional ``callback(stage, i, total)`` (stage ``"sampling"`` or ``"selection"``).
    inputs, output : names of the d inputs and of the output (default ``u1 … ud``, ``"v"``).
    units : ``{name: unit}`` for every input and the output, or none (``None``); a unit of
        :data:`surrogates.units.KNOWN_UNITS`, e.g. ``{"du": "m", "dv": "m/s", "F": "N"}``.
        Given any of ``inputs``, ``output``, ``units``, the model's ``features_`` holds them,
        :func:`surrogates.io.save` writes them and :func:`surrogates.io.load` restores them
        (an env that checks units needs them; the data are not converted).
    model_params : further hyperparameters of the model class.

    Returns
    -------
    (model, report) : the fitted model and a :class:`BuildReport`.
    """
    U = as_inputs(U)
    V = as_outputs(V, U.shape[0])
    n = U.shape[0]
    m = _check_plan(U, V, kind, m, sampling, selection, k)
    in_names, out_name = element_names(U.shape[1], inputs, output)
    unit_map = check_units(units, in_names, out_name)
    cands = list(candidates) if candidates is not None else default_candidates(kind, U.shape[1])
    make = _checked_factory(kind, cands, extrapolation, model_params)
    with timer() as t_total:
        plan = (m, sampling, selection, seed, k)
        train_idx, oob_idx, result = _sample_and_select(U, V, make, cands, plan, progress)
        with timer() as t_fit:
            model = make(result.best).fit(U[train_idx], V[train_idx])
    if inputs is not None or output is not None or units is not None:
        # the static form, as io.load reads a file without a form
        model.features_ = {"inputs": in_names, "output": out_name, "units": unit_map}
        model.features_.update(form="static", tau=None, known_physics=[])
    err, err_kind, nrms = _oob_errors(model, U[oob_idx], V[oob_idx])
    report = BuildReport(
        kind=kind,
        sampling=sampling,
        selection=selection,
        m=int(m),
        n=n,
        chosen=result.best,
        scores=result,
        training_time_s=t_total["seconds"],
        fit_time_s=t_fit["seconds"],
        oob_error=err,
        oob_error_kind=err_kind,
        oob_nrms=nrms,
        domain=(model.lower_.tolist(), model.upper_.tolist()),
        train_idx=train_idx,
        oob_idx=oob_idx,
    )
    return model, report


def _sample_and_select(
    U: np.ndarray,
    V: np.ndarray,
    make: Factory,
    cands: list[Any],
    plan: tuple[int, str, str, int | None, int],
    progress: Callable[[str, int, int], None] | None,
) -> tuple[np.ndarray, np.ndarray, SelectionResult]:
    """The training and out-of-bag indices of the ``(m, sampling, selection, seed, k)`` plan
    and the candidates' scores on them (:func:`build`)."""
    m, sampling, selection, seed, k = plan

    def stage(name: str) -> Callable[[int, int], None] | None:
        return (lambda i, total: progress(name, i, total)) if progress else None

    train_idx, oob_idx = select(U, m, method=sampling, seed=seed, progress=stage("sampling"))
    Ut, Vt = U[train_idx], V[train_idx]
    if selection == "oob":
        result = select_oob(make, cands, Ut, Vt, U[oob_idx], V[oob_idx], stage("selection"))
    else:
        result = select_kfold(make, cands, Ut, Vt, k=k, seed=seed, progress=stage("selection"))
    return train_idx, oob_idx, result


def _check_plan(
    U: np.ndarray, V: np.ndarray, kind: str, m: Any, sampling: str, selection: str, k: Any
) -> int:
    """Check the build's options against the data; return ``m`` as an int."""
    n = U.shape[0]
    choice(kind, "kind", ("lpr", "kriging"))
    choice(selection, "selection", ("oob", "kfold"))
    choice(sampling, "sampling", METHODS)
    m = integer(m, "m", 1)
    if selection == "oob" and m >= n:
        raise ValueError(f"m = {m} leaves no out-of-bag samples out of n = {n}: use m < n")
    if m > n:
        raise ValueError(f"m = {m} exceeds the number of samples n = {n}")
    if selection == "kfold":
        integer(k, "k", 2, m)
    check_domain(U.min(axis=0), U.max(axis=0), "U column")
    if not np.isfinite(np.std(V)):
        raise ValueError("V overflows float64 (its spread is not finite): rescale the output")
    return m


def _checked_factory(
    kind: str, cands: list[Any], extrapolation: str, model_params: dict[str, Any]
) -> Factory:
    """The model factory of ``kind``, with every candidate's hyperparameters checked before
    any sampling or fitting (an error names the candidate)."""
    if not cands:
        raise ValueError("candidates is empty: give at least one degree (LPR) or kernel (Kriging)")
    make = factory_for(kind, extrapolation=extrapolation, **model_params)
    for cand in cands:
        try:
            make(cand)._check_params()
        except TypeError as exc:  # an unknown keyword in model_params
            raise ValueError(f"invalid model parameter for kind {kind!r}: {exc}") from None
        except ValueError as exc:
            raise type(exc)(f"candidate {candidate_label(cand)}: {exc}") from None
    return make


def _oob_errors(model: SurrogateModel, U: np.ndarray, V: np.ndarray) -> tuple[float, str, float]:
    """Paper error (and its kind) and normalised RMS error on the out-of-bag samples; NaN
    when there are none."""
    if not U.shape[0]:
        return float("nan"), "absolute", float("nan")
    pred = model.predict(U)
    err, err_kind = paper_error(pred, V)
    return err, err_kind, rms_normalised_error(pred, V)
