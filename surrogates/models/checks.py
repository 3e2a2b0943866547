"""Checks of hyperparameters and of saved model fields, each error naming its field.

Used by the models' ``fit`` (hyperparameters) and ``from_dict`` (every saved field), so that
a bad argument or a damaged or hostile model file ends in one :class:`ModelFieldError` that
says which field is wrong, never in an exception from deep inside numpy or a huge allocation.
"""

from __future__ import annotations

import functools
import math
import sys
import warnings
from numbers import Integral
from typing import Any, TypeVar, cast

import numpy as np

from surrogates.checks import Checks, is_number

#: largest Legendre degree accepted in a hyperparameter or a saved exponent (bounds memory)
MAX_DEGREE = 200

#: a class
T = TypeVar("T")


class ModelFieldError(ValueError):
    """A hyperparameter or a saved model field is invalid; the message names the field."""


class NotFittedError(RuntimeError, ValueError, AttributeError):
    """``predict`` (or another method that needs a fitted model) before ``fit``; a
    ``ValueError`` and ``AttributeError`` as scikit-learn's ``NotFittedError``."""


class DataConversionWarning(UserWarning):
    """An input was converted (a column vector of outputs), as scikit-learn's warning."""


class UnderdeterminedFitWarning(UserWarning):
    """A Legendre fit with more terms than samples: its coefficients are not determined by
    the data and the minimum-norm solution is returned. The degree searches of
    :mod:`surrogates.selection` treat it as a refusal and skip the candidate."""


#: most terms of a Legendre fit with fewer samples than terms (solved by minimum norm); a fit
#: with more is refused, as is a determined fit whose data cannot hold its terms (bounds the
#: design matrix of a fit on a few samples)
MAX_UNDERDETERMINED_TERMS = 1000


def underdetermined_fit(n: int, T: int, what: str) -> None:
    """Check a Legendre fit of ``T`` terms on ``n < T`` samples: warn
    (:class:`UnderdeterminedFitWarning`) that it is solved by minimum norm, or raise
    ``ValueError`` beyond :data:`MAX_UNDERDETERMINED_TERMS` terms; ``what`` names the
    hyperparameters (``degree=5``)."""
    need = f"X has {n} samples but {what} needs at least {T} (one per term)"
    if T > MAX_UNDERDETERMINED_TERMS:
        raise ValueError(
            f"{need}; a fit with fewer samples than terms is solved by minimum norm only up "
            f"to {MAX_UNDERDETERMINED_TERMS} terms"
        )
    warnings.warn(
        UnderdeterminedFitWarning(
            f"{need} to be determined: the least-squares coefficients of smallest norm are "
            "returned, one of many that fit the samples as well (lower the degree or add "
            "samples for a determined fit)"
        ),
        stacklevel=4,
    )


@functools.cache
def _with_sklearn(ours: Any, theirs: Any) -> Any:
    return type(ours.__name__, (ours, theirs), {"__module__": __name__})


def sklearn_flavoured(ours: type[T]) -> type[T]:
    """``ours``, or once scikit-learn is imported a subclass of ``ours`` and of the class of
    the same name in ``sklearn.exceptions``, so that code catching scikit-learn's class
    catches ours (surrogates itself never imports scikit-learn)."""
    sklearn_exceptions = sys.modules.get("sklearn.exceptions")
    theirs = getattr(sklearn_exceptions, ours.__name__, None)
    if theirs is None:
        return ours
    out: type[T] = _with_sklearn(cast(Any, ours), theirs)
    return out


def not_fitted_error(message: str) -> NotFittedError:
    """A :class:`NotFittedError` (also scikit-learn's once it is imported)."""
    return sklearn_flavoured(NotFittedError)(message)


def _model_error(field: str, message: str) -> ModelFieldError:
    return ModelFieldError(f"{field} {message}")


#: the checks of :mod:`surrogates.checks` (the vocabulary railgym uses too), raising
#: :class:`ModelFieldError` for bad values and values of the wrong type alike
_CHECKS = Checks(_model_error, _model_error)
real = _CHECKS.real
positive = _CHECKS.positive
non_negative = _CHECKS.non_negative
integer = _CHECKS.integer
boolean = _CHECKS.boolean
choice = _CHECKS.choice
random_seed = _CHECKS.random_seed


def real_or_nan(value: Any, field: str) -> float:
    """A real number as :func:`real`, or NaN (a saved statistic that may be undefined)."""
    if is_number(value) and math.isnan(float(value)):
        return math.nan
    return real(value, field)


def legendre_degree(degree: Any, field: str = "degree") -> int | tuple[int, ...]:
    """A degree in ``0..MAX_DEGREE`` or a non-empty tuple/list of them (one per input)."""
    if isinstance(degree, (tuple, list)):
        if not degree:
            raise ModelFieldError(f"{field} must not be empty")
        return tuple(integer(x, f"{field}[{i}]", 0, MAX_DEGREE) for i, x in enumerate(degree))
    if isinstance(degree, (bool, np.bool_)) or not isinstance(degree, Integral):
        raise ModelFieldError(
            f"{field} must be a non-negative int or a tuple of them (one per input), got {degree!r}"
        )
    return integer(degree, field, 0, MAX_DEGREE)


def field_array(
    value: Any,
    field: str,
    shape: tuple[int | None, ...],
    integer: bool = False,
    low: float | None = None,
    strict: bool = False,
    high: float | None = None,
) -> np.ndarray:
    """A saved array field as float64 (int64 with ``integer``), checked for type and shape.

    ``shape`` gives the expected shape, ``None`` for a free length. Values must be finite
    numbers (JSON ``NaN``/``Infinity`` and bools are rejected), ``>= low`` (``> low`` with
    ``strict``) when ``low`` is given and ``<= high`` when ``high`` is given.
    """
    if isinstance(value, (str, bytes, dict)) or value is None:
        raise ModelFieldError(f"{field} must be an array of numbers, got {type(value).__name__}")
    if _has_bool(value):
        raise ModelFieldError(f"{field} must hold numbers, got true/false")
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError) as exc:
        raise ModelFieldError(f"{field} must be a rectangular array of numbers ({exc})") from None
    if arr.ndim == 0 and len(shape) > 0:
        raise ModelFieldError(f"{field} must be an array of shape {_shape_text(shape)}")
    if arr.dtype.kind not in "iuf" or (integer and arr.dtype.kind == "f" and arr.size):
        want = "integers" if integer else "numbers"
        raise ModelFieldError(f"{field} must hold {want}, got dtype {arr.dtype}")
    if arr.ndim != len(shape) or any(
        s is not None and s != a for s, a in zip(shape, arr.shape, strict=True)
    ):
        raise ModelFieldError(f"{field} has shape {arr.shape}, expected {_shape_text(shape)}")
    out = arr.astype(np.int64 if integer else np.float64)
    if not integer and not np.all(np.isfinite(out)):
        raise ModelFieldError(f"{field} has non-finite values (NaN or Inf)")
    if low is not None and out.size and (np.any(out <= low) if strict else np.any(out < low)):
        raise ModelFieldError(f"{field} must be {'>' if strict else '>='} {low} everywhere")
    if high is not None and out.size and np.any(out > high):
        raise ModelFieldError(f"{field} must be <= {high} everywhere, got {out.max()}")
    return out


def field(d: Any, key: str, path: str) -> Any:
    """``d[key]`` of a JSON object, :class:`ModelFieldError` naming ``path.key`` if absent."""
    if not isinstance(d, dict):
        raise ModelFieldError(f"{path} must be a JSON object, got {type(d).__name__}")
    if key not in d:
        raise ModelFieldError(f"{path} is missing the field {key!r}")
    return d[key]


def _has_bool(value: Any) -> bool:
    """True if the nested lists ``value`` hold a bool (numpy would read it as 0 or 1)."""
    if isinstance(value, (bool, np.bool_)):
        return True
    if isinstance(value, (list, tuple)):
        return any(_has_bool(v) for v in value)
    return False


def _shape_text(shape: tuple[int | None, ...]) -> str:
    inner = ", ".join("n" if s is None else str(s) for s in shape)
    return f"({inner},)" if len(shape) == 1 else f"({inner})"
