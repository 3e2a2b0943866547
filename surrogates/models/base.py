"""Common base of the surrogate models: domain bookkeeping and the extrapolation guard.

Every model learns on a training box ``[lower_, upper_]`` (one interval per input). Inputs
outside that box are handled by the model's ``extrapolation`` policy:

``"linear"`` (default)
    value and gradient at the nearest boundary point, extended linearly outwards
    (``F(u) ≈ F(u_b) + ∇F(u_b)·(u − u_b)``); finite wherever that line is representable in
    float64, otherwise (inputs of order 1e300) :meth:`SurrogateModel.predict` raises a
    :class:`ValueError` naming the row and column.
``"clip"``
    the input is clipped to the box (constant extension).
``"raise"``
    a :class:`ValueError` is raised naming the input column.

Each prediction of a point outside the box increments ``n_out_of_domain_``.
"""

from __future__ import annotations

import inspect
import warnings
from collections.abc import Callable
from typing import Any, ClassVar, Self

import numpy as np

from surrogates.models.checks import (
    DataConversionWarning,
    ModelFieldError,
    choice,
    field,
    field_array,
    not_fitted_error,
    sklearn_flavoured,
)

EXTRAPOLATION_POLICIES = ("linear", "clip", "raise")


def as_inputs(U: Any, name: str = "U", one_d: bool = True) -> np.ndarray:
    """Return ``U`` as a finite float array of shape (n, d).

    A 1-D ``U`` is one input column (d = 1) when ``one_d`` is true (the builder and the
    selection functions); the models' ``fit``/``predict``/``score`` pass ``one_d=False`` and
    refuse it, as scikit-learn's estimators do. The error messages carry the phrases
    scikit-learn's estimator checks look for (sparse, complex, NaN/inf, 1-D, 0 features)."""
    if hasattr(U, "toarray") or type(U).__module__.startswith("scipy.sparse"):
        raise TypeError(f"{name}: sparse input is not supported, pass a dense array")
    raw = np.asarray(U)
    if raw.dtype.kind == "c":
        raise ValueError(f"{name} must be an array of real numbers: Complex data not supported")
    if raw.dtype.kind == "O":  # numbers in an object array (e.g. from pandas) convert
        try:
            raw = raw.astype(float)
        except (TypeError, ValueError) as err:
            raise type(err)(f"{name} must be an array of real numbers: {err}") from None
    if raw.dtype.kind not in "iuf":
        raise ValueError(f"{name} must be an array of real numbers, got dtype {raw.dtype}")
    U = np.asarray(raw, dtype=float)
    if U.ndim == 1 and not one_d:
        raise ValueError(
            f"{name} must be 2-D (n_samples, n_features), got a 1-D array of shape {U.shape}: "
            f"Expected 2D array, got 1D array instead. Reshape your data either using "
            f"{name}.reshape(-1, 1) if your data has a single feature or {name}.reshape(1, -1) "
            "if it contains a single sample"
        )
    if U.ndim == 1:
        U = U[:, None]
    if U.ndim != 2:
        raise ValueError(f"{name} must have shape (n, d), got {U.shape}")
    if U.shape[0] == 0:
        raise ValueError(f"{name} is empty: 0 sample(s) (shape={U.shape})")
    if U.shape[1] == 0:
        raise ValueError(
            f"{name} has 0 feature(s) (shape={U.shape}) while a minimum of 1 is required."
        )
    if not np.all(np.isfinite(U)):
        bad = np.unique(np.nonzero(~np.isfinite(U))[1])
        raise ValueError(f"{name} has non-finite values (NaN or inf) in column(s) {bad.tolist()}")
    return U


def as_outputs(V: Any, n: int, name: str = "V") -> np.ndarray:
    """Return ``V`` as a finite float array of shape (n,)."""
    if V is None:
        raise ValueError(f"{name}: the model requires y to be passed, but the target y is None")
    V = np.asarray(V, dtype=float)
    if V.ndim == 2 and V.shape[1] == 1:
        warnings.warn(
            sklearn_flavoured(DataConversionWarning)(
                f"A column-vector y was passed when a 1d array was expected: {name} of shape "
                f"{V.shape} is used as ({n},)"
            ),
            stacklevel=3,
        )
        V = V[:, 0]
    if V.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {V.shape}")
    if not np.all(np.isfinite(V)):
        rows = np.nonzero(~np.isfinite(V))[0][:5].tolist()
        raise ValueError(f"{name} has non-finite values (NaN or inf) at rows {rows}")
    return V


class SurrogateModel:
    """Base class: scikit-learn-like ``fit``/``predict`` with an extrapolation guard.

    ``fit(X, y)``, ``predict(X)`` and ``score(X, y)`` take scikit-learn's names: ``X`` (n, d)
    holds the inputs U of the paper, ``y`` (n,) its outputs V. Subclasses implement
    ``_fit(U, V)`` (validated arrays), ``_predict_inside(U)`` (inputs inside the box),
    optionally ``_gradient_inside(U)``, ``_check_params()`` (validates the hyperparameters)
    and ``_state()`` / ``_set_state(d)`` for persistence.

    scikit-learn contract: ``__init__`` stores every hyperparameter exactly as given (it
    validates nothing), ``fit`` validates them, :meth:`get_params` / :meth:`set_params` work as
    in scikit-learn (so ``sklearn.base.clone`` works), learned state ends in an underscore,
    ``fit`` sets ``n_features_in_`` and ``predict``/``score`` refuse another column count, a
    1-D ``X`` is refused (one input is one column), :meth:`score` is the R² of a regressor and
    ``__sklearn_tags__`` declares a regressor, so ``Pipeline``, ``GridSearchCV``,
    ``cross_val_score`` and ``is_regressor`` work and ``check_estimator`` passes. scikit-learn
    itself is not needed (it is imported only when scikit-learn asks for the tags).
    """

    kind: ClassVar[str] = "base"
    #: feature names and units, attached by :func:`surrogates.io.load`
    features_: dict[str, Any]
    #: free-form metadata, attached by :func:`surrogates.io.load`
    metadata_: dict[str, Any]

    def __init__(self, extrapolation: str = "linear") -> None:
        self.extrapolation = extrapolation

    # ------------------------------------------------------------------ public API
    def fit(self, X: Any, y: Any) -> Self:
        """Fit the model on the training box of ``X``; returns ``self``.

        Parameters
        ----------
        X : array-like (n, d)
            Inputs U of the paper, input units (a 2-D array: one row per sample, one column
            per input; a single input is one column, ``u[:, None]``).
        y : array-like (n,)
            Outputs V of the paper, output units.

        Returns
        -------
        self
            Fitted, with ``lower_``/``upper_`` (training box) and ``n_features_in_`` set.

        Raises
        ------
        ModelFieldError
            An invalid hyperparameter (a ``ValueError``), checked before the data.
        ValueError
            Bad data: a 1-D ``X``, constant or overflowing input columns, non-finite values,
            too few samples for the model.
        """
        self._check_params()
        U = as_inputs(X, "X", one_d=False)
        V = as_outputs(y, U.shape[0], "y")
        if U.shape[0] < 2:
            raise ValueError(
                f"X has 1 sample (n_samples=1): a training domain needs at least 2 {U.shape}"
            )
        lower, upper = U.min(axis=0), U.max(axis=0)
        check_domain(lower, upper, "X column")
        if not np.isfinite(np.std(V)):
            raise ValueError("y overflows float64 (its spread is not finite): rescale the output")
        self.lower_, self.upper_ = lower, upper
        self.n_features_in_ = U.shape[1]
        self.n_out_of_domain_ = 0
        self._fit(U, V)
        return self

    def predict(self, X: Any) -> np.ndarray:
        """Predict the outputs at ``X``, applying the extrapolation policy outside the box.

        Parameters
        ----------
        X : array-like (n, d)
            Inputs U of the paper (2-D, ``d = n_features_in_`` columns), input units.

        Returns
        -------
        ndarray (n,)
            Outputs V of the paper, output units.
        """
        self._check_fitted()
        choice(self.extrapolation, "extrapolation", EXTRAPOLATION_POLICIES)  # set_params
        U = self._check_inputs(X)
        Uc = np.clip(U, self.lower_, self.upper_)
        outside = np.any(Uc != U, axis=1)
        n_out = int(outside.sum())
        if n_out == 0:
            return self._predict_inside(U)
        if self.extrapolation == "raise":
            cols = np.unique(np.nonzero(Uc != U)[1]).tolist()
            raise ValueError(
                f"{n_out} input(s) outside the training domain in column(s) {cols}; "
                f"domain lower={self.lower_.tolist()} upper={self.upper_.tolist()}"
            )
        self.n_out_of_domain_ += n_out
        V = self._predict_inside(Uc)
        if self.extrapolation == "linear":
            Uo, Uco = U[outside], Uc[outside]
            G = self._gradient_inside(Uco)
            with np.errstate(over="ignore", invalid="ignore"):
                V[outside] += np.sum(G * (Uo - Uco), axis=1)
            if not np.all(np.isfinite(V)):
                row = int(np.nonzero(~np.isfinite(V))[0][0])
                cols = np.nonzero(Uc[row] != U[row])[0].tolist()
                raise ValueError(
                    f"linear extrapolation overflows float64 at row {row} (column(s) {cols}, "
                    f"X = {U[row].tolist()}): the input is too far outside the training domain"
                )
        return V

    def score(self, X: Any, y: Any, sample_weight: Any = None) -> float:
        """Coefficient of determination R² of :meth:`predict` at ``X`` against ``y``, as
        scikit-learn's regressors (``1 − Σw(y − ŷ)² / Σw(y − ȳ_w)²``; a constant ``y`` gives
        1.0 when predicted exactly, else 0.0).

        Parameters
        ----------
        X : array-like (n, d)
            Inputs U of the paper (2-D, ``d = n_features_in_`` columns).
        y : array-like (n,)
            Outputs V of the paper.
        sample_weight : array-like (n,), optional
            Weight of each sample (default: equal weights).
        """
        pred = self.predict(X)
        V = as_outputs(y, pred.size, "y")
        w = (
            np.ones_like(V)
            if sample_weight is None
            else as_outputs(sample_weight, V.size, "sample_weight")
        )
        residual = float(np.sum(w * (V - pred) ** 2))
        total = float(np.sum(w * (V - np.average(V, weights=w)) ** 2))
        if total == 0.0:
            return 1.0 if residual == 0.0 else 0.0
        return 1.0 - residual / total

    def __sklearn_is_fitted__(self) -> bool:
        """Whether :meth:`fit` ran (scikit-learn's ``check_is_fitted``)."""
        return hasattr(self, "lower_")

    def __sklearn_tags__(self) -> Any:
        """scikit-learn's tags of a regressor on dense 2-D float input (needs scikit-learn,
        which calls it)."""
        from sklearn.utils import InputTags, RegressorTags, Tags, TargetTags

        return Tags(
            estimator_type="regressor",
            target_tags=TargetTags(required=True, single_output=True),
            transformer_tags=None,
            classifier_tags=None,
            regressor_tags=RegressorTags(),
            input_tags=InputTags(),
        )

    @property
    def domain_(self) -> tuple[np.ndarray, np.ndarray]:
        """Training box ``(lower, upper)`` in input units."""
        self._check_fitted()
        return self.lower_, self.upper_

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """Hyperparameters as given to ``__init__`` (``deep`` is accepted for scikit-learn;
        the models have no nested estimators)."""
        return {k: getattr(self, k) for k in self._param_names()}

    def set_params(self, **params: Any) -> SurrogateModel:
        """Set hyperparameters by name (validated at the next ``fit``); returns ``self``."""
        names = self._param_names()
        unknown = sorted(set(params) - set(names))
        if unknown:
            raise ValueError(
                f"invalid parameter(s) {unknown} for {type(self).__name__}; "
                f"valid parameters: {list(names)}"
            )
        for k, v in params.items():
            setattr(self, k, v)
        return self

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary of hyperparameters and learned state."""
        self._check_fitted()
        return {
            "kind": self.kind,
            "params": jsonable(self.get_params()),
            "domain": {"lower": self.lower_.tolist(), "upper": self.upper_.tolist()},
            "state": jsonable(self._state()),
        }

    @classmethod
    def from_dict(cls, d: Any) -> SurrogateModel:
        """Rebuild a fitted model from :meth:`to_dict` output.

        Every field is checked (types, shapes, finiteness, bounds); a bad one raises
        :class:`ModelFieldError` naming it, e.g. ``model.state.coef``. Hyperparameters missing
        from older files take their defaults.
        """
        kind = field(d, "kind", "model")
        if kind != cls.kind:
            raise ModelFieldError(f"model.kind is {kind!r}, expected {cls.kind!r}")
        raw = field(d, "params", "model")
        if not isinstance(raw, dict):
            raise ModelFieldError(f"model.params must be a JSON object, got {type(raw).__name__}")
        names = inspect.signature(cls.__init__).parameters
        unknown = sorted(k for k in raw if k not in names or k == "self")
        if unknown:
            raise ModelFieldError(f"model.params has unknown field(s) {unknown}")
        params = {k: tuple(v) if isinstance(v, list) else v for k, v in raw.items()}
        make: Callable[..., SurrogateModel] = cls
        model = make(**params)
        try:
            model._check_params()
        except ModelFieldError as exc:
            raise ModelFieldError(f"model.params.{exc}") from None
        dom = field(d, "domain", "model")
        lower = field_array(field(dom, "lower", "model.domain"), "model.domain.lower", (None,))
        upper = field_array(
            field(dom, "upper", "model.domain"), "model.domain.upper", (lower.size,)
        )
        if lower.size == 0:
            raise ModelFieldError("model.domain.lower must have at least one entry")
        check_domain(lower, upper, "model.domain column")
        model.lower_, model.upper_ = lower, upper
        model.n_features_in_ = lower.size
        model.n_out_of_domain_ = 0
        state = field(d, "state", "model")
        if not isinstance(state, dict):
            raise ModelFieldError(f"model.state must be a JSON object, got {type(state).__name__}")
        model._set_state(state)
        return model

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"

    # ------------------------------------------------------------- for subclasses
    @classmethod
    def _param_names(cls) -> tuple[str, ...]:
        sig = inspect.signature(cls.__init__)
        return tuple(p for p in sig.parameters if p != "self")

    def _check_params(self) -> None:
        """Validate the hyperparameters (:class:`ModelFieldError` naming the first bad one)."""
        choice(self.extrapolation, "extrapolation", EXTRAPOLATION_POLICIES)

    def _check_inputs(self, X: Any) -> np.ndarray:
        """``X`` as a float array (n, n_features_in_), scikit-learn's error otherwise (a 1-D
        ``X``, or a column count other than the fitted one)."""
        U = as_inputs(X, "X", one_d=False)
        if U.shape[1] != self.n_features_in_:
            raise ValueError(
                f"X has {U.shape[1]} columns: X has {U.shape[1]} features, but "
                f"{type(self).__name__} is expecting {self.n_features_in_} features as input "
                "(the columns it was fitted on)"
            )
        return U

    def _check_fitted(self) -> None:
        if not hasattr(self, "lower_"):
            raise not_fitted_error(f"{type(self).__name__} is not fitted: call fit(X, y) first")

    def _fit(self, U: np.ndarray, V: np.ndarray) -> None:
        raise NotImplementedError

    def _predict_inside(self, U: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _gradient_inside(self, U: np.ndarray) -> np.ndarray:
        """Gradient (n, d) at points inside the box; default: one-sided finite differences
        pointing into the box (step 1e-6 of the box width)."""
        width = self.upper_ - self.lower_
        G = np.empty_like(U)
        f0 = self._predict_inside(U)
        for j in range(U.shape[1]):
            h = 1e-6 * width[j]
            step = np.where(U[:, j] + h <= self.upper_[j], h, -h)
            Up = U.copy()
            Up[:, j] += step
            G[:, j] = (self._predict_inside(Up) - f0) / step
        return G

    def _state(self) -> dict[str, Any]:
        raise NotImplementedError

    def _set_state(self, d: dict[str, Any]) -> None:
        raise NotImplementedError


def check_domain(lower: np.ndarray, upper: np.ndarray, what: str) -> None:
    """Raise ``ValueError`` naming the first column where ``lower >= upper`` or the width
    ``upper − lower`` overflows float64."""
    with np.errstate(over="ignore"):
        width = upper - lower
    bad = ~(width > 0)
    if np.any(bad):
        col = int(np.nonzero(bad)[0][0])
        raise ModelFieldError(
            f"{what} {col} has lower {lower[col]!r} >= upper {upper[col]!r}: "
            "the training domain has zero width (constant column)"
        )
    if not np.all(np.isfinite(width)):
        col = int(np.nonzero(~np.isfinite(width))[0][0])
        raise ModelFieldError(
            f"{what} {col} spans [{lower[col]!r}, {upper[col]!r}], a width that overflows "
            "float64: rescale the input"
        )


def jsonable(obj: Any) -> Any:
    """Convert numpy arrays/scalars inside ``obj`` to plain Python for JSON."""
    if isinstance(obj, dict):
        return {k: jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj
