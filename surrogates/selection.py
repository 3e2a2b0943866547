"""Model and degree selection (paper section 3.4): out-of-bag error or k-fold cross-validation.

Both return a :class:`SelectionResult` holding the whole score table, not just the winner.
The score that decides is the RMS error on the held-out samples (units of the output);
the table also carries eq. 8/9 errors.
"""

from __future__ import annotations

import itertools
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from surrogates.metrics import average_absolute_error, rms_normalised_error
from surrogates.models import SurrogateModel, model_class
from surrogates.models.base import as_inputs, as_outputs
from surrogates.models.checks import UnderdeterminedFitWarning, random_seed

if TYPE_CHECKING:
    from surrogates.legendre_kfold import SharedFolds

Factory = Callable[[Any], SurrogateModel]
Progress = Callable[[int, int], None] | None


@dataclass
class SelectionResult:
    """Scores of every candidate; ``best`` is the candidate with the lowest ``rms``."""

    method: str
    table: list[dict[str, Any]] = field(default_factory=list)
    best: Any = None

    def at_cap(self) -> list[int]:
        """Inputs whose winning degree is the largest candidate degree of that input (the
        search range may be too small there); empty for non-degree candidates and for a
        single (fixed) degree."""
        degrees = [
            np.atleast_1d(np.asarray(r["candidate"]))
            for r in self.table
            if isinstance(r["candidate"], int | tuple) and not isinstance(r["candidate"], bool)
        ]
        if self.best is None or len(degrees) < 2 or len({d.size for d in degrees}) != 1:
            return []  # no degree search: nothing to widen
        top = np.max(degrees, axis=0)
        best = np.atleast_1d(np.asarray(self.best))
        if best.size != top.size:
            return []
        return [int(j) for j in np.flatnonzero(best == top)]

    def format(self) -> str:
        """The score table as aligned text; a last line flags a winner at the search cap."""
        lines = [f"{'candidate':>12} {'rms':>12} {'mae (eq.9)':>12} {'rel. rms':>10}"]
        for row in self.table:
            mark = "  <- best" if row["candidate"] == self.best else ""
            lines.append(
                f"{candidate_label(row['candidate']):>12} {row['rms']:12.4g} {row['mae']:12.4g} "
                f"{row['nrms']:10.3g}{mark}"
            )
        cap = self.at_cap()
        if cap:
            lines.append(
                f"warning: the winner sits at the largest candidate degree of input(s) {cap}; "
                "widen the search range (--max-degree on the command line, candidates= in Python)"
            )
        return "\n".join(lines)


#: largest default LPR degree per input for d ≤ 2 (and for d > 2)
DEFAULT_MAX_DEGREE = {2: 16, 3: 10}


def default_candidates(kind: str, n_inputs: int, max_degree: int | None = None) -> list[Any]:
    """Candidates searched by default.

    LPR: every per-input degree tuple up to ``max_degree`` (default 16) for d ≤ 2 (cheap: one
    lstsq each), equal degrees 1..max_degree (default 10) otherwise. Kriging: the two
    correlation kernels. :meth:`SelectionResult.at_cap` flags a winner at the top.
    """
    if max_degree is None:
        max_degree = DEFAULT_MAX_DEGREE[2 if n_inputs <= 2 else 3]
    if kind == "lpr":
        if n_inputs <= 2:
            return list(itertools.product(range(1, max_degree + 1), repeat=n_inputs))
        return list(range(1, max_degree + 1))
    if kind == "kriging":
        return ["gaussian", "matern52"]
    raise ValueError(f"unknown model kind {kind!r}")


def factory_for(kind: str, **params: Any) -> Factory:
    """Candidate → model factory; the candidate is LPR's ``degree`` or Kriging's ``kernel``."""
    cls = model_class(kind)
    key = "degree" if kind == "lpr" else "kernel"

    def make(candidate: Any) -> SurrogateModel:
        return cls(**{key: candidate, **params})

    return make


def _score(model: SurrogateModel, U: np.ndarray, V: np.ndarray) -> dict[str, float]:
    pred = model.predict(U)
    return {
        "rms": float(np.sqrt(np.mean((pred - V) ** 2))),
        "mae": average_absolute_error(pred, V),
        "nrms": rms_normalised_error(pred, V),
    }


def _fits(make: Factory, cand: Any, U: np.ndarray, V: np.ndarray) -> SurrogateModel | str:
    """Fit a candidate; the error message when it cannot be fitted or when its fit is not
    determined by the data (more terms than samples: the model's
    :class:`~surrogates.models.checks.UnderdeterminedFitWarning`, a refusal here)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnderdeterminedFitWarning)
        try:
            return make(cand).fit(U, V)
        except UnderdeterminedFitWarning as exc:
            return str(exc)
        except (ValueError, np.linalg.LinAlgError) as exc:
            return str(exc) or type(exc).__name__


_NAN = {"rms": np.nan, "mae": np.nan, "nrms": np.nan}


def _finish(method: str, table: list[dict[str, Any]]) -> SelectionResult:
    """The result; ``ValueError`` with each candidate's first error when none could be fitted.

    Failed rows carry their cause under ``"error"``."""
    if not table:
        raise ValueError("candidates is empty: give at least one degree or kernel")
    finite = [r for r in table if np.isfinite(r["rms"])]
    if not finite:
        causes = "; ".join(
            f"{candidate_label(r['candidate'])}: {r.get('error', 'non-finite score')}"
            for r in table[:5]
        )
        more = f" (and {len(table) - 5} more)" if len(table) > 5 else ""
        raise ValueError(f"no candidate could be fitted: {causes}{more}")
    best = min(finite, key=lambda r: r["rms"])["candidate"]
    return SelectionResult(method=method, table=table, best=best)


def select_oob(
    make: Factory,
    candidates: Iterable[Any],
    U_train: Any,
    V_train: Any,
    U_oob: Any,
    V_oob: Any,
    progress: Progress = None,
) -> SelectionResult:
    """Fit each candidate on the training samples and score it on the out-of-bag samples."""
    U_train = as_inputs(U_train, "U_train")
    V_train = as_outputs(V_train, U_train.shape[0], "V_train")
    U_oob = as_inputs(U_oob, "U_oob")
    V_oob = as_outputs(V_oob, U_oob.shape[0], "V_oob")
    cands = list(candidates)
    table = []
    for i, cand in enumerate(cands):
        model = _fits(make, cand, U_train, V_train)
        if isinstance(model, str):
            table.append({"candidate": cand, **_NAN, "error": model})
        else:
            table.append({"candidate": cand, **_score(model, U_oob, V_oob)})
        if progress:
            progress(i + 1, len(cands))
    return _finish("oob", table)


def kfold_indices(n: int, k: int = 10, seed: int | None = 0) -> list[np.ndarray]:
    """Split ``range(n)`` into ``k`` shuffled folds of near-equal size (seeded)."""
    if not 2 <= k <= n:
        raise ValueError(f"k must be between 2 and the number of samples ({n}), got {k}")
    perm = np.random.default_rng(random_seed(seed, "seed")).permutation(n)
    return [np.sort(f) for f in np.array_split(perm, k)]


def select_kfold(
    make: Factory,
    candidates: Iterable[Any],
    U: Any,
    V: Any,
    k: int = 10,
    seed: int | None = 0,
    progress: Progress = None,
) -> SelectionResult:
    """k-fold cross-validation: each candidate's score is pooled over the k held-out folds.

    Candidates that ``make`` builds as :class:`~surrogates.models.lpr.LegendreRegression` or
    :class:`~surrogates.passive.PassiveLegendreRegression` (those classes, not subclasses)
    are scored from one factorisation per fold shared by all of them
    (:mod:`surrogates.legendre_kfold`; the same scores to its ``SCORE_RTOL``); every other
    candidate is fitted on each fold.
    """
    U = as_inputs(U)
    V = as_outputs(V, U.shape[0])
    folds = kfold_indices(U.shape[0], k, seed)
    cands = list(candidates)
    shared = _shared_folds(make, cands, U, V, folds)
    table = []
    for i, cand in enumerate(cands):
        pred: np.ndarray | str | None = None if shared is None else shared.predictions(i)
        if pred is None:
            pred = _fold_predictions(make, cand, U, V, folds)
        row: dict[str, Any]
        if isinstance(pred, str):
            row = {**_NAN, "error": pred}
        else:
            row = {
                "rms": float(np.sqrt(np.mean((pred - V) ** 2))),
                "mae": average_absolute_error(pred, V),
                "nrms": rms_normalised_error(pred, V),
            }
        table.append({"candidate": cand, **row})
        if progress:
            progress(i + 1, len(cands))
    return _finish("kfold", table)


def _fold_predictions(
    make: Factory, cand: Any, U: np.ndarray, V: np.ndarray, folds: list[np.ndarray]
) -> np.ndarray | str:
    """Held-out predictions (n,) of ``cand`` fitted on each fold's training rows, or the
    error message of the first fold where it cannot be fitted."""
    pred = np.empty_like(V)
    for fold in folds:
        train = np.setdiff1d(np.arange(U.shape[0]), fold, assume_unique=True)
        model = _fits(make, cand, U[train], V[train])
        if isinstance(model, str):
            return model
        pred[fold] = model.predict(U[fold])
    return pred


def _shared_folds(
    make: Factory, cands: list[Any], U: np.ndarray, V: np.ndarray, folds: list[np.ndarray]
) -> SharedFolds | None:
    """:class:`surrogates.legendre_kfold.SharedFolds` of the candidates, or ``None`` when
    ``make`` builds no Legendre model (imported only then: it needs scipy)."""
    models: list[Any] = []
    for cand in cands:
        try:
            models.append(make(cand))
        except (ValueError, np.linalg.LinAlgError):
            models.append(None)  # the loop reports it
    if not any(getattr(type(m), "kind", None) in _SHARED_KINDS for m in models):
        return None
    from surrogates.legendre_kfold import SharedFolds as Shared

    return Shared.prepare(models, U, V, folds)


#: model kinds that :mod:`surrogates.legendre_kfold` may score (it checks the exact classes)
_SHARED_KINDS = ("lpr", "lpr_passive")


def candidate_label(cand: Any) -> str:
    """Short text of a candidate, e.g. ``(3, 5)`` → ``"3,5"``."""
    if isinstance(cand, Sequence) and not isinstance(cand, str):
        return ",".join(str(c) for c in cand)
    return str(cand)
