"""Checks of arguments, configs and YAML files: one rule set, errors that name the field.

Every helper takes the value and its *field path* (``"speed"``, ``"damper.c_rebound"``,
``"reward_weights['force']"``) and returns the value in a canonical Python type, or raises
:class:`FieldError` (a ``ValueError``) whose message starts with that path. Wrong types raise
:class:`FieldTypeError`, which is also a ``TypeError``.

Rules
-----
* The checks of values (numbers, integers, choices, sequences, arrays, seeds) are those of
  :mod:`surrogates.checks`, the one vocabulary of every layer (``choice(value, field,
  options)`` here and in ``surrogates``), bound here to :class:`FieldError` and
  :class:`FieldTypeError`.
* Ranges are checked on the value the caller uses: read the raw (file) value with
  :func:`real`, convert it to SI, then check the SI value with :func:`in_range` (or use
  :meth:`Fields.quantity`, which does all three, so that ``1e307 t`` is reported as an
  overflow instead of becoming an infinite mass).
* "Name or path" (:func:`resolve_yaml`): an argument is a file when it ends in ``.yaml`` /
  ``.yml`` and names an existing file; otherwise it must be a packaged name (letters, digits,
  ``_``, ``-``). The working directory is never searched for a bare name, so a folder or file
  named like a packaged config never changes what is loaded.

API
---
``real(v, field)`` finite number → float; ``positive(v, field, max=None)``,
``non_negative(v, field, max=None)``, ``in_range(v, field, lo, hi, lo_open=False,
hi_open=False)`` → float; ``integer(v, field, min=None, max=None)`` → int; ``boolean(v,
field)``; ``choice(v, field, options)``; ``sequence(v, field, length=None)`` → tuple;
``mapping(v, field)``; ``numeric_array(v, field, shape=None)`` → float64 array (rejects bool,
complex, string and object data and non-finite values); ``random_seed(v, field)``;
``resolve_yaml(arg, field,
package, folder)`` → (text, source); ``load_yaml(text, source)`` → data (syntax errors name the
source and line); :class:`Fields` reads a YAML mapping section by section::

    f = Fields(data, "vehicle")                 # the mapping and its path
    m1 = f.positive("m1")                       # "vehicle.m1 must be positive, got -1"
    area = f.quantity("A_v", 1e-4, lo=0.0, lo_open=True)
    sub = f.section("damper")                   # Fields of data["damper"], path vehicle.damper
    f.done()                                    # unknown keys → "unknown field vehicle.x"
"""

from __future__ import annotations

import math
import re
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from surrogates.checks import Checks

__all__ = [
    "FieldError",
    "FieldTypeError",
    "Fields",
    "Yaml12Loader",
    "boolean",
    "choice",
    "in_range",
    "integer",
    "load_yaml",
    "mapping",
    "non_negative",
    "numeric_array",
    "positive",
    "random_seed",
    "real",
    "resolve_yaml",
    "sequence",
]

YAML_SUFFIXES = (".yaml", ".yml")
_NAME = re.compile(r"[A-Za-z0-9_-]+")


class FieldError(ValueError):
    """Invalid value; ``field`` is the path of the offending field.

    ``FieldError(field, message)`` reads "``field`` ``message``" (``full=True``: ``message``
    alone). With one argument, as code that re-raises ``type(e)(text)`` calls it (gymnasium's
    ``make``), the argument is the whole message and ``field`` its first word.
    """

    def __init__(self, field: str, message: str | None = None, *, full: bool = False) -> None:
        if message is None:
            message, full = field, True
            field = field.split(" ", 1)[0]
        super().__init__(message if full else f"{field} {message}")
        self.field = field


class FieldTypeError(FieldError, TypeError):
    """Value of the wrong type (also a ``TypeError``)."""


#: the checks of :mod:`surrogates.checks` (one vocabulary for every layer), raising
#: :class:`FieldError` / :class:`FieldTypeError`
_CHECKS = Checks(FieldError, FieldTypeError)
real = _CHECKS.real
in_range = _CHECKS.in_range
positive = _CHECKS.positive
non_negative = _CHECKS.non_negative
integer = _CHECKS.integer
boolean = _CHECKS.boolean
choice = _CHECKS.choice
sequence = _CHECKS.sequence
mapping = _CHECKS.mapping
numeric_array = _CHECKS.numeric_array
random_seed = _CHECKS.random_seed


#: a YAML 1.2 float: a fraction, an exponent or both, signs optional (``2.4e6``, ``1e-3``,
#: ``-2E+5``, ``.5``); PyYAML's YAML 1.1 resolver reads ``2.4e6`` and ``1e-3`` as strings
_YAML12_FLOAT = re.compile(
    r"""^[-+]?(?:[0-9][0-9_]*\.[0-9_]*(?:[eE][-+]?[0-9]+)?
    |[0-9][0-9_]*[eE][-+]?[0-9]+
    |\.[0-9][0-9_]*(?:[eE][-+]?[0-9]+)?)$""",
    re.X,
)


class Yaml12Loader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that also reads YAML 1.2 floats (:data:`_YAML12_FLOAT`) as
    numbers, the base of every YAML loader of railgym."""


Yaml12Loader.add_implicit_resolver("tag:yaml.org,2002:float", _YAML12_FLOAT, list("-+0123456789."))


class _UniqueKeyLoader(Yaml12Loader):
    """``yaml.SafeLoader`` that refuses a key given twice in one mapping (PyYAML keeps the
    last silently)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":  # ``<<: *anchor``; its keys may be
                continue  # overridden by the mapping's own
            key = self.construct_object(key_node, deep=deep)
            try:
                first = seen.get(key)
                seen.setdefault(key, key_node.start_mark.line + 1)
            except TypeError:  # an unhashable key: construct_mapping reports it
                continue
            if first is not None:
                raise yaml.constructor.ConstructorError(
                    None,
                    None,
                    f"key {key!r} given twice (first on line {first})",
                    key_node.start_mark,
                )
        return super().construct_mapping(node, deep=deep)


def load_yaml(text: str, source: str) -> Any:
    """``yaml.safe_load`` whose syntax errors name ``source`` and the line; a key given twice
    in one mapping is an error too, and YAML 1.2 floats (``2.4e6``) are numbers."""
    try:
        return yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506  (a SafeLoader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = f", line {mark.line + 1}" if mark is not None else ""
        raise FieldError(source, f"is not valid YAML{line}: {exc.problem}") from None
    except yaml.YAMLError as exc:
        raise FieldError(source, f"is not valid YAML: {exc}") from None


def resolve_yaml(arg: Any, field: str, package: str, folder: tuple[str, ...]) -> tuple[str, str]:
    """Text and source label of a "name or path" argument (rule in the module docstring).

    Parameters
    ----------
    arg : packaged name (``"manchester"``) or path of a ``.yaml`` / ``.yml`` file.
    field : argument name for the error messages.
    package, folder : where packaged files live, e.g. ``"railgym"``, ``("configs", "vehicles")``.
    """
    if not isinstance(arg, str | Path):
        raise FieldTypeError(field, f"must be a name or a YAML path, got {arg!r}")
    text = str(arg)
    if not text:
        raise FieldError(field, "is empty; give a packaged name or a YAML path")
    base = resources.files(package).joinpath(*folder)
    if text.endswith(YAML_SUFFIXES):
        path = Path(text)
        if path.is_dir():
            raise FieldError(field, f"{field} {text!r} is a folder, expected a file", full=True)
        if not path.is_file():
            raise FieldError(field, f"{field} file {text!r} does not exist", full=True)
        try:
            return path.read_text(encoding="utf-8"), text
        except (OSError, UnicodeDecodeError) as exc:
            raise FieldError(field, f"file {text!r} cannot be read: {exc}") from None
    names = sorted(p.name[:-5] for p in base.iterdir() if p.name.endswith(".yaml"))
    if not _NAME.fullmatch(text) or text not in names:
        if Path(text).is_dir():
            raise FieldError(
                field,
                f"{field} {text!r} is a folder, expected a YAML file or a packaged name",
                full=True,
            )
        raise FieldError(
            field,
            f"unknown {field} {text!r}: not a packaged name {names}, and a file path must "
            "end in .yaml or .yml",
            full=True,
        )
    return base.joinpath(f"{text}.yaml").read_text(encoding="utf-8"), f"{text}.yaml"


class Fields:
    """Reader of one YAML mapping with its field path; records which keys were read."""

    def __init__(self, data: Any, path: str) -> None:
        self.data = mapping(data, path)
        self.path = path
        self._read: set[str] = set()

    def field(self, key: str) -> str:
        """Path of ``key`` in this mapping."""
        return f"{self.path}.{key}" if self.path else key

    def get(self, key: str, default: Any = ...) -> Any:
        """Raw value of ``key``; missing without a ``default`` raises."""
        self._read.add(key)
        if key not in self.data:
            if default is ...:
                raise FieldError(self.field(key), "is missing")
            return default
        return self.data[key]

    def real(self, key: str) -> float:
        """Finite number at ``key``."""
        return real(self.get(key), self.field(key))

    def positive(self, key: str, max: float | None = None) -> float:
        """Positive number at ``key``."""
        return positive(self.get(key), self.field(key), max)

    def non_negative(self, key: str, max: float | None = None) -> float:
        """Non-negative number at ``key``."""
        return non_negative(self.get(key), self.field(key), max)

    def in_range(self, key: str, lo: float | None, hi: float | None, **open_: bool) -> float:
        """Number at ``key`` in a range (see :func:`in_range`)."""
        return in_range(self.get(key), self.field(key), lo, hi, **open_)

    def integer(self, key: str, min: int | None = None, max: int | None = None) -> int:
        """Integer at ``key``."""
        return integer(self.get(key), self.field(key), min, max)

    def quantity(
        self,
        key: str,
        factor: float,
        lo: float | None = None,
        hi: float | None = None,
        **open_: bool,
    ) -> float:
        """Number at ``key`` times ``factor`` (unit conversion), range checked after it.

        Finiteness is checked on the raw value and again after the conversion (overflow).
        """
        raw = self.real(key)
        si = raw * factor
        if not math.isfinite(si):
            raise FieldError(self.field(key), f"overflows after unit conversion, got {raw!r}")
        return in_range(si, self.field(key), lo, hi, **open_)

    def text(self, key: str) -> str:
        """Non-empty string at ``key``."""
        value = self.get(key)
        if not isinstance(value, str) or not value:
            raise FieldTypeError(self.field(key), f"must be a non-empty string, got {value!r}")
        return value

    def section(self, key: str) -> Fields:
        """:class:`Fields` of the mapping at ``key``."""
        return Fields(self.get(key), self.field(key))

    def done(self) -> None:
        """Raise on keys that were never read (typos, unknown fields)."""
        for key in self.data:
            if key not in self._read:
                path = self.field(str(key))
                raise FieldError(path, f"unknown field {path}", full=True)
