"""Multibody time-history tables (Simpack, Adams, GENSYS exports) → :class:`TimeHistory` in SI.

:func:`read_table` reads a text table with one row per sample: CSV (``,`` or ``;``), tab- or
whitespace-separated, with a header row of column names and, optionally, a row of units or
units inside the names (``x1 [mm]``, ``x1 (mm)``, ``x1/mm``…: the last bracket pair is taken),
or per-column units given by the caller. Lines before ``header_row`` (an export preamble),
blank lines and lines starting with ``comment`` are skipped. Values are converted to SI once
with :data:`UNITS` (an unknown unit is an error naming the column), row by row.

Errors name the file, line and column: missing columns, non-numeric or non-finite cells, a
row with another number of fields than the header, a time that does not increase, an empty
file. A last row cut short (the export was interrupted) is dropped with a ``UserWarning``.

Recipe, multibody export → vertical element (see ``docs/data.md``)::

    th = read_table("bogie.txt", delimiter="whitespace", unit_row=1, time="Time")
    U, V = vertical_features_from(th, m2=..., x1="z_bogie", x2="z_body", v1=..., v2=..., a2=...)
    model, report = build(U, V)
"""

from __future__ import annotations

import io as _io
import re
import warnings
from array import array
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from surrogates.features import TimeHistory

#: unit → (SI factor, SI unit); also "-", "1" and "" (no unit)
UNITS: dict[str, tuple[float, str]] = {
    "m": (1.0, "m"),
    "cm": (1e-2, "m"),
    "mm": (1e-3, "m"),
    "um": (1e-6, "m"),
    "m/s": (1.0, "m/s"),
    "mm/s": (1e-3, "m/s"),
    "km/h": (1 / 3.6, "m/s"),
    "m/s^2": (1.0, "m/s^2"),
    "m/s2": (1.0, "m/s^2"),
    "m/s**2": (1.0, "m/s^2"),
    "mm/s^2": (1e-3, "m/s^2"),
    "mm/s2": (1e-3, "m/s^2"),
    "g": (9.80665, "m/s^2"),
    "N": (1.0, "N"),
    "kN": (1e3, "N"),
    "MN": (1e6, "N"),
    "s": (1.0, "s"),
    "ms": (1e-3, "s"),
    "kg": (1.0, "kg"),
    "t": (1e3, "kg"),
    "rad": (1.0, "rad"),
    "deg": (np.pi / 180.0, "rad"),
    "Pa": (1.0, "Pa"),
    "kPa": (1e3, "Pa"),
    "bar": (1e5, "Pa"),
    "-": (1.0, ""),
    "1": (1.0, ""),
    "": (1.0, ""),
}
DELIMITERS = {",": ",", ";": ";", "tab": "\t", "whitespace": None}
_NAME_UNIT = re.compile(r"^(.*?)\s*[\[(]([^\[\]()]*)[\])]\s*$")


def _text(path: Path) -> str:
    """The file's text (UTF-8, a byte-order mark skipped); not UTF-8: ValueError naming the
    file and line."""
    raw = path.read_bytes()
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ValueError(f"{path}: line {line}: not UTF-8 text ({exc.reason})") from None


def _split(line: str, sep: str | None) -> list[str]:
    return [f.strip() for f in (line.split() if sep is None else line.split(sep))]


def _detect(header: str) -> str | None:
    for sep in (",", ";", "\t"):
        if sep in header:
            return sep
    return None


def _si(unit: str, column: str, where: str) -> tuple[float, str]:
    u = unit.strip()
    if u not in UNITS:
        raise ValueError(
            f"{where}: unit {unit!r} of column {column!r} is not known; known units: "
            f"{sorted(k for k in UNITS if k)}"
        )
    return UNITS[u]


def to_si(
    columns: Mapping[str, np.ndarray], units: Mapping[str, str], where: str
) -> tuple[dict[str, np.ndarray], dict[str, str], dict[str, float]]:
    """``columns`` converted to SI as :func:`read_table` converts (the factors of
    :data:`UNITS`): the columns, their SI units and the factors applied (those other than 1).

    A column without a unit, or with a unit :data:`UNITS` does not list (an SI unit such as
    ``N/m``), is kept as it is; a value that overflows in SI is a ``ValueError`` naming
    ``where`` and the column.
    """
    out, si_units, factors = dict(columns), dict(units), {}
    for name, unit in units.items():
        if name not in columns or unit.strip() not in UNITS:
            continue
        factor, si = _si(unit, name, where)
        if factor != 1.0:
            with np.errstate(over="ignore"):  # reported below, naming the column
                values = np.asarray(columns[name], dtype=float) * factor
            if not np.all(np.isfinite(values)):
                raise ValueError(f"{where}: column {name!r} overflows when converted to SI")
            out[name], factors[name] = values, factor
        si_units[name] = si or unit
    return out, si_units, factors


def _header(
    line: str, delimiter: str | None, where: str
) -> tuple[list[str], str | None, dict[str, str]]:
    """Column names, separator and the units given inside the names (``x1 [mm]``) of the
    header line."""
    sep = DELIMITERS[delimiter] if delimiter is not None else _detect(line)
    names: list[str] = []
    file_units: dict[str, str] = {}
    for field in _split(line, sep):
        m = _NAME_UNIT.match(field)
        name = m.group(1) if m else field
        if m:
            file_units[name] = m.group(2)
        names.append(name)
    if not any(names):
        raise ValueError(f"{where}: empty header row")
    dups = sorted({n for n in names if names.count(n) > 1})
    if dups:
        raise ValueError(f"{where}: duplicate column name(s) {dups}")
    return names, sep, file_units


def _unit_row(line: str, sep: str | None, names: list[str], where: str) -> dict[str, str]:
    """Column → unit of the unit row (brackets around a unit are dropped)."""
    cells = _split(line, sep)
    if len(cells) != len(names):
        raise ValueError(f"{where}: the unit row has {len(cells)} fields, the header {len(names)}")
    return {n: u.strip("[]()") for n, u in zip(names, cells, strict=True)}


class _Columns:
    """The kept columns of a table (time first): header positions, SI factors and the values
    read so far, with the checks of each data row."""

    def __init__(
        self, path: Path, names: list[str], chosen: list[str], units: Mapping[str, str], where: str
    ) -> None:
        self.path = path
        self.width = len(names)
        self.chosen = chosen
        self.pos = [names.index(c) for c in chosen]
        si = [_si(units.get(c, ""), c, where) for c in chosen]
        self.scale = [f for f, _ in si]
        self.si_units = {c: u for c, (_, u) in zip(chosen, si, strict=True) if u}
        self.values = [array("d") for _ in chosen]
        self.short: int | None = None  # line of a row cut short (only the last may be)
        self.last_t: float | None = None

    def add(self, line: str, sep: str | None, lineno: int) -> None:
        """Append the data row ``line``: every kept cell a finite number, finite in SI, the
        time increasing; a short row is kept aside (an error unless it is the last)."""
        path = self.path
        if self.short is not None:
            raise ValueError(f"{path}: line {self.short} has fewer fields than the header")
        cells = _split(line, sep)
        if len(cells) < self.width:
            self.short = lineno
            return
        if len(cells) > self.width:
            raise ValueError(
                f"{path}: line {lineno} has {len(cells)} fields, the header has {self.width}"
            )
        for col, p, name, f in zip(self.values, self.pos, self.chosen, self.scale, strict=True):
            col.append(_cell(cells[p], f, name, f"{path}: line {lineno}"))
        t = self.values[0][-1]
        if self.last_t is not None and t <= self.last_t:
            raise ValueError(
                f"{path}: line {lineno}: time {t} does not increase (previous {self.last_t})"
            )
        self.last_t = t

    def history(self) -> TimeHistory:
        """The columns in SI as a :class:`TimeHistory` (the first one the time)."""
        data = [
            np.frombuffer(c, dtype=float) * s for c, s in zip(self.values, self.scale, strict=True)
        ]
        self.si_units.pop(self.chosen[0], None)
        return TimeHistory(
            data[0], dict(zip(self.chosen[1:], data[1:], strict=True)), self.si_units
        )


def _cell(text: str, factor: float, name: str, where: str) -> float:
    """The number in a data cell, finite and finite after the SI factor ``factor``."""
    try:
        v = float(text)
    except ValueError:
        raise ValueError(f"{where}: column {name!r}: {text!r} is not a number") from None
    if not np.isfinite(v):
        raise ValueError(f"{where}: column {name!r}: value is {v}")
    if not np.isfinite(v * factor):
        raise ValueError(
            f"{where}: column {name!r}: {v} overflows when converted to SI (× {factor:g})"
        )
    return v


def _chosen(path: Path, names: list[str], time: str, columns: Sequence[str] | None) -> list[str]:
    """The time column and the kept channels, each present in the header."""
    if time not in names:
        raise ValueError(f"{path}: no time column {time!r}; the header has {names}")
    keep = [n for n in names if n != time] if columns is None else list(columns)
    missing = [c for c in keep if c not in names]
    if missing:
        raise ValueError(f"{path}: missing column(s) {missing}; the header has {names}")
    return [time, *keep]


def _line_number(value: object, field: str) -> int:
    """A 0-based line number: an integer >= 0 (``ValueError`` naming ``field``)."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
        raise ValueError(
            f"{field} must be a 0-based line number (an integer >= 0: 0 is the first line), "
            f"got {value!r}"
        )
    return int(value)


def read_table(
    path: str | Path,
    *,
    delimiter: str | None = None,
    header_row: int = 0,
    unit_row: int | None = None,
    units: Mapping[str, str] | None = None,
    time: str = "t",
    columns: Sequence[str] | None = None,
    comment: str | None = "#",
) -> TimeHistory:
    """Read a time-history table into a :class:`TimeHistory` in SI.

    Parameters
    ----------
    path : the text file.
    delimiter : ``","``, ``";"``, ``"tab"``, ``"whitespace"`` or ``None`` (detected from the
        header line: ``,`` then ``;`` then tab, else whitespace).
    header_row : 0-based line number of the column names (earlier lines are skipped), an
        integer >= 0.
    unit_row : 0-based line number of a row of units (``None``: none, or units in the names),
        after ``header_row``.
    units : column → unit, overriding the file's (default: the file's, else SI assumed).
    time : name of the time column (strictly increasing; converted to s).
    columns : channels to keep (default every column but the time).
    comment : lines starting with it (after leading blanks) are skipped: a non-empty string,
        or ``None`` to skip none.
    """
    path = Path(path)
    if delimiter is not None and delimiter not in DELIMITERS:
        raise ValueError(f"delimiter must be one of {list(DELIMITERS)} or None, got {delimiter!r}")
    header_row = _line_number(header_row, "header_row")
    if unit_row is not None:
        unit_row = _line_number(unit_row, "unit_row")
    if comment is not None and (not isinstance(comment, str) or not comment.strip()):
        raise ValueError(
            f"comment must be the non-empty prefix of comment lines (e.g. '#'), or None to skip "
            f"no line; got {comment!r} (an empty prefix would skip every line, a blank one none)"
        )
    if unit_row is not None and unit_row <= header_row:
        raise ValueError(f"unit_row ({unit_row}) must come after header_row ({header_row})")
    names: list[str] | None = None
    sep: str | None = None
    file_units: dict[str, str] = {}
    table: _Columns | None = None
    with _io.StringIO(_text(path)) as fh:
        for i, raw in enumerate(fh):
            lineno = i + 1
            line = raw.rstrip("\r\n")
            if i < header_row:
                continue
            if names is None:  # i == header_row
                names, sep, file_units = _header(line, delimiter, f"{path}: line {lineno}")
            elif i == unit_row:
                file_units.update(_unit_row(line, sep, names, f"{path}: line {lineno}"))
            elif line.strip() and not (comment and line.lstrip().startswith(comment)):
                if table is None:  # first data row: fix the columns and their SI factors
                    where = f"{path}: line {(header_row if unit_row is None else unit_row) + 1}"
                    chosen = _chosen(path, names, time, columns)
                    table = _Columns(
                        path, names, chosen, {**file_units, **dict(units or {})}, where
                    )
                table.add(line, sep, lineno)
    if names is None:
        raise ValueError(f"{path}: empty file, expected a header row at line {header_row + 1}")
    if table is None or len(table.values[0]) < 2:
        raise ValueError(f"{path}: fewer than 2 data rows")
    if table.short is not None:
        warnings.warn(f"{path}: last row (line {table.short}) is cut short; dropped", stacklevel=2)
    return table.history()
