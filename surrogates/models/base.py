"""Common base of the surrogate models: domain bookkeeping and the extrapolation guard.

Every model learns on a training box ``[lower_, upper_]`` (one interval per input). Inputs
outside that box are handled by the model's ``extrapolation`` policy:

``"linear"`` (default)
    value and gradient at the nearest boundary point, extended linearly outwards
    (``F(u) ≈ F(u_b) + ∇F(u_b)·(u − u_b)``); finite for every finite input.
``"clip"``
    the input is clipped to the box (constant extension).
``"raise"``
    a :class:`ValueError` is raised naming the input column.

Each prediction of a point outside the box increments ``n_out_of_domain_``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

EXTRAPOLATION_POLICIES = ("linear", "clip", "raise")


def as_inputs(U: Any, name: str = "U") -> np.ndarray:
    """Return ``U`` as a finite float array of shape (n, d); 1-D input means d = 1."""
    U = np.asarray(U, dtype=float)
    if U.ndim == 1:
        U = U[:, None]
    if U.ndim != 2:
        raise ValueError(f"{name} must have shape (n, d), got {U.shape}")
    if U.shape[0] == 0:
        raise ValueError(f"{name} is empty")
    if not np.all(np.isfinite(U)):
        bad = np.unique(np.nonzero(~np.isfinite(U))[1])
        raise ValueError(f"{name} has non-finite values in column(s) {bad.tolist()}")
    return U


def as_outputs(V: Any, n: int, name: str = "V") -> np.ndarray:
    """Return ``V`` as a finite float array of shape (n,)."""
    V = np.asarray(V, dtype=float)
    if V.ndim == 2 and V.shape[1] == 1:
        V = V[:, 0]
    if V.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {V.shape}")
    if not np.all(np.isfinite(V)):
        rows = np.nonzero(~np.isfinite(V))[0][:5].tolist()
        raise ValueError(f"{name} has non-finite values at rows {rows}")
    return V


class SurrogateModel:
    """Base class: scikit-learn-like ``fit``/``predict`` with an extrapolation guard.

    Subclasses implement ``_fit(U, V)``, ``_predict_inside(U)`` (inputs inside the box),
    optionally ``_gradient_inside(U)``, and ``_state()`` / ``_set_state(d)`` for persistence.
    Hyperparameters are set in ``__init__``; learned state ends in an underscore.
    """

    kind: ClassVar[str] = "base"

    def __init__(self, extrapolation: str = "linear") -> None:
        self.extrapolation = extrapolation

    # ------------------------------------------------------------------ public API
    def fit(self, U: Any, V: Any) -> SurrogateModel:
        """Fit on inputs ``U`` (n, d) and outputs ``V`` (n,); returns ``self``."""
        if self.extrapolation not in EXTRAPOLATION_POLICIES:
            raise ValueError(
                f"extrapolation must be one of {EXTRAPOLATION_POLICIES}, got {self.extrapolation!r}"
            )
        U = as_inputs(U)
        V = as_outputs(V, U.shape[0])
        self.lower_ = U.min(axis=0)
        self.upper_ = U.max(axis=0)
        if np.any(self.upper_ <= self.lower_):
            col = int(np.nonzero(self.upper_ <= self.lower_)[0][0])
            raise ValueError(f"U column {col} is constant: the training domain has zero width")
        self.n_features_in_ = U.shape[1]
        self.n_out_of_domain_ = 0
        self._fit(U, V)
        return self

    def predict(self, U: Any) -> np.ndarray:
        """Predict outputs for ``U`` (n, d) → (n,), applying the extrapolation policy."""
        self._check_fitted()
        U = as_inputs(U)
        if U.shape[1] != self.n_features_in_:
            raise ValueError(
                f"U has {U.shape[1]} columns, the model was fitted on {self.n_features_in_}"
            )
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
            V[outside] += np.sum(G * (Uo - Uco), axis=1)
        return V

    @property
    def domain_(self) -> tuple[np.ndarray, np.ndarray]:
        """Training box ``(lower, upper)`` in input units."""
        self._check_fitted()
        return self.lower_, self.upper_

    def get_params(self) -> dict[str, Any]:
        """Hyperparameters as given to ``__init__``."""
        return {k: getattr(self, k) for k in self._param_names()}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary of hyperparameters and learned state."""
        self._check_fitted()
        return {
            "kind": self.kind,
            "params": _jsonable(self.get_params()),
            "domain": {"lower": self.lower_.tolist(), "upper": self.upper_.tolist()},
            "state": _jsonable(self._state()),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SurrogateModel:
        """Rebuild a fitted model from :meth:`to_dict` output."""
        for key in ("kind", "params", "domain", "state"):
            if key not in d:
                raise ValueError(f"model dictionary is missing the field {key!r}")
        if d["kind"] != cls.kind:
            raise ValueError(f"model kind is {d['kind']!r}, expected {cls.kind!r}")
        params = dict(d["params"])
        for k, v in params.items():
            if isinstance(v, list):
                params[k] = tuple(v)
        model = cls(**params)
        model.lower_ = np.asarray(d["domain"]["lower"], dtype=float)
        model.upper_ = np.asarray(d["domain"]["upper"], dtype=float)
        model.n_features_in_ = model.lower_.size
        model.n_out_of_domain_ = 0
        model._set_state(d["state"])
        return model

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"

    # ------------------------------------------------------------- for subclasses
    def _param_names(self) -> tuple[str, ...]:
        import inspect

        sig = inspect.signature(type(self).__init__)
        return tuple(p for p in sig.parameters if p != "self")

    def _check_fitted(self) -> None:
        if not hasattr(self, "lower_"):
            raise RuntimeError(f"{type(self).__name__} is not fitted: call fit(U, V) first")

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


def _jsonable(obj: Any) -> Any:
    """Convert numpy arrays/scalars inside ``obj`` to plain Python for JSON."""
    if isinstance(obj, dict):
        return {k: _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj
