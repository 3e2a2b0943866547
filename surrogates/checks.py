"""The argument checks of every layer: one vocabulary, parameterised by the error raised.

Each check takes the value and its *field path* (``"speed"``, ``"damper.c_rebound"``,
``"reward_weights['force']"``), in that order, and returns the value in a canonical Python
type, or raises an error whose message starts with that path. The error class is the layer's:
:class:`Checks` binds the checks to two constructors ``error(field, message)`` (a bad value)
and ``type_error(field, message)`` (a value of the wrong type). ``surrogates`` binds them to
:class:`surrogates.models.checks.ModelFieldError`, ``railgym`` to
``railgym._checks.FieldError`` / ``FieldTypeError``; both expose the bound checks under
the names below, so that ``choice(value, field, options)`` reads the same everywhere.

Rules
-----
* Numbers: ``int``, ``float`` and numpy integer/floating scalars (and 0-d arrays of them) are
  accepted; ``bool``, ``numpy.bool_``, strings, complex numbers and ``None`` are rejected.
  Every number must be finite.
* Integers: Python or numpy integers, not bools and not floats.

Checks
------
``real(v, field)`` finite number → float; ``positive(v, field, max=None)``,
``non_negative(v, field, max=None)``, ``in_range(v, field, lo, hi, lo_open=False,
hi_open=False)`` → float; ``integer(v, field, min=None, max=None)`` → int; ``boolean(v,
field)``; ``choice(v, field, options)``; ``sequence(v, field, length=None)`` → tuple;
``mapping(v, field)``; ``numeric_array(v, field, shape=None)`` → float64 array (rejects bool,
complex, string and object data and non-finite values); ``random_seed(v, field)`` → a seed
``numpy.random.default_rng`` takes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from typing import Any

import numpy as np

__all__ = ["Checks", "ErrorFactory", "is_number"]

#: builds the exception of a failed check from the field path and the rest of the message
ErrorFactory = Callable[[str, str], Exception]


def is_number(value: Any) -> bool:
    """True for a Python or numpy real number (or a 0-d array of one), False for bools."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    return not isinstance(value, bool | np.bool_) and isinstance(
        value, int | float | np.integer | np.floating
    )


class Checks:
    """The checks (module docstring) raising ``error`` for bad values and ``type_error`` for
    values of the wrong type; a layer binds one instance and exports its methods."""

    def __init__(self, error: ErrorFactory, type_error: ErrorFactory) -> None:
        self.error = error
        self.type_error = type_error

    def real(self, value: Any, field: str) -> float:
        """A finite real number (numpy scalars accepted, bools and strings rejected)."""
        if not is_number(value):
            raise self.type_error(field, f"must be a number, got {value!r}")
        try:
            out = float(value)
        except OverflowError:  # a Python int beyond the float range
            raise self.error(field, f"must be finite, got {value!r}") from None
        if not math.isfinite(out):
            raise self.error(field, f"must be finite, got {value!r}")
        return out

    def in_range(
        self,
        value: Any,
        field: str,
        lo: float | None = None,
        hi: float | None = None,
        *,
        lo_open: bool = False,
        hi_open: bool = False,
    ) -> float:
        """A finite number in ``[lo, hi]`` (``(lo, …`` / ``…, hi)`` when open; None:
        unbounded)."""
        out = self.real(value, field)
        below = lo is not None and (out <= lo if lo_open else out < lo)
        above = hi is not None and (out >= hi if hi_open else out > hi)
        if below or above:
            left = "-inf" if lo is None else f"{lo:g}"
            right = "inf" if hi is None else f"{hi:g}"
            opening = "(" if lo_open or lo is None else "["
            closing = ")" if hi_open or hi is None else "]"
            raise self.error(field, f"must be in {opening}{left}, {right}{closing}, got {value!r}")
        return out

    def positive(self, value: Any, field: str, max: float | None = None) -> float:
        """A finite number ``> 0`` (and ``<= max`` when given)."""
        out = self.real(value, field)
        if out <= 0.0:
            raise self.error(field, f"must be positive, got {value!r}")
        if max is not None and out > max:
            raise self.error(field, f"must be at most {max:g}, got {value!r}")
        return out

    def non_negative(self, value: Any, field: str, max: float | None = None) -> float:
        """A finite number ``>= 0`` (and ``<= max`` when given)."""
        out = self.real(value, field)
        if out < 0.0:
            raise self.error(field, f"must be non-negative, got {value!r}")
        if max is not None and out > max:
            raise self.error(field, f"must be at most {max:g}, got {value!r}")
        return out

    def integer(
        self, value: Any, field: str, min: int | None = None, max: int | None = None
    ) -> int:
        """An integer (Python or numpy; not bool, not a float) in ``[min, max]``."""
        if isinstance(value, np.ndarray) and value.ndim == 0:
            value = value[()]
        if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
            raise self.type_error(field, f"must be an integer, got {value!r}")
        out = int(value)
        if min is not None and out < min:
            raise self.error(field, f"must be at least {min}, got {value!r}")
        if max is not None and out > max:
            raise self.error(field, f"must be at most {max}, got {value!r}")
        return out

    def boolean(self, value: Any, field: str) -> bool:
        """``True`` or ``False`` (numpy bools accepted; 0/1 and strings rejected)."""
        if not isinstance(value, bool | np.bool_):
            raise self.type_error(field, f"must be true or false, got {value!r}")
        return bool(value)

    def choice(self, value: Any, field: str, options: Iterable[Any]) -> Any:
        """One of ``options`` (compared with ``==``; bools never match numbers)."""
        opts = list(options)
        for o in opts:
            if type(value) is type(o) and value == o:
                return o
        if isinstance(value, str):
            for o in opts:
                if value == o:
                    return o
        raise self.error(field, f"must be one of {opts}, got {value!r}")

    def sequence(self, value: Any, field: str, length: int | None = None) -> tuple[Any, ...]:
        """A list, tuple or 1-D array (not a string or mapping), as a tuple of ``length``
        items."""
        if isinstance(value, str | bytes | Mapping) or not isinstance(
            value, list | tuple | np.ndarray
        ):
            raise self.type_error(field, f"must be a sequence, got {value!r}")
        items = tuple(value.tolist() if isinstance(value, np.ndarray) else value)
        if length is not None and len(items) != length:
            raise self.error(field, f"must have {length} items, got {len(items)}")
        return items

    def mapping(self, value: Any, field: str) -> Mapping[str, Any]:
        """A mapping (dict-like); anything else is a type error."""
        if not isinstance(value, Mapping):
            raise self.type_error(field, f"must be a mapping, got {type(value).__name__}")
        return value

    def numeric_array(
        self, value: Any, field: str, shape: tuple[int, ...] | None = None
    ) -> np.ndarray:
        """A finite float64 array of real numbers (ints and floats; not bool, complex or
        text)."""
        text = isinstance(value, str | bytes)
        arr = np.asarray(value, object) if text else np.asarray(value)
        if arr.dtype.kind not in "iuf":
            raise self.type_error(
                field, f"must hold real numbers, got dtype {arr.dtype} ({type(value).__name__})"
            )
        if shape is not None and arr.shape != shape:
            raise self.error(field, f"must have shape {shape}, got {arr.shape}")
        out = arr.astype(np.float64)
        if not np.all(np.isfinite(out)):
            raise self.error(field, "must be finite; got NaN or Inf")
        return out

    def random_seed(self, value: Any, field: str = "seed") -> Any:
        """``value`` if :func:`numpy.random.default_rng` takes it as documented: ``None``, a
        non-negative integer (not a bool), a sequence of them, or a numpy ``Generator``,
        ``BitGenerator`` or ``SeedSequence``."""
        if value is None or isinstance(
            value, np.random.Generator | np.random.BitGenerator | np.random.SeedSequence
        ):
            return value
        items = list(value) if isinstance(value, list | tuple) and value else [value]
        if all(
            not isinstance(i, bool | np.bool_) and isinstance(i, int | np.integer) and i >= 0
            for i in items
        ):
            return value
        raise self.error(
            field, f"must be None, a non-negative integer or a numpy Generator, got {value!r}"
        )
