"""Readers (and writers) of LS-DYNA ASCII output: ``nodout``, ``rcforc``, ``glstat``.

LS-DYNA has no unit system of its own; ``units`` names the consistent set the model used and
every value is converted to SI once, on reading (:data:`UNIT_SYSTEMS`: ``"m-s-kg-N"``,
``"mm-s-t-N"``, ``"mm-ms-kg-kN"``, ``"mm-ms-g-N"``; an unknown name is a ``ValueError``).
Files are streamed line by line, so memory grows with the values kept, not with the file.

Layouts implemented (columns are 0-based character offsets, ``[a:b)``; ``nodout`` and
``glstat`` fields are parsed by offset, never by ``split()``, because wide numbers run
together; ``rcforc`` by its labels). Bytes that are not UTF-8 (a title written in another
encoding) read as U+FFFD; only numbers are parsed.

Common header
    title line, ``ls-dyna …`` version line, then optionally a legend block::

        {BEGIN LEGEND}
         Entity #        Title
              1     wall contact            (id [0:14), title from column 14)
        {END LEGEND}

    returned by :func:`read_legend`; everything before the first data block is skipped.

``nodout``
    one block per output time::

         n o d a l   p r i n t   o u t   f o r   t i m e  s t e p   N   ( at time 1.0000000E-03 )
        (blank)
         nodal point  x-disp     y-disp      z-disp      x-vel  …  x-coor      y-coor      z-coor
        <node lines>

    The time is the number between ``at time`` and ``)``. A node line holds the node id in
    ``[0:10)`` and twelve 12-character fields from column 10: ``x_disp y_disp z_disp``
    ``[10:46)``, ``x_vel y_vel z_vel`` ``[46:82)``, ``x_accl y_accl z_accl`` ``[82:118)``,
    ``x_coor y_coor z_coor`` ``[118:154)``. Blocks whose column header has ``x-rot`` (the
    rotational output that follows each translational block) are skipped. Every block must
    list the nodes of the first one, in the same order.
``rcforc``
    one line per contact side and output time::

          master          1 time 1.00000E-03  x  1.00000E+00  y  0.00000E+00  z  0.0000E+00 …

    parsed by its labels, not by columns, so that the widths of every LS-DYNA version read:
    the side (``master``/``slave``) and the contact id, then a value after each of the labels
    ``time``, ``x``, ``y``, ``z`` (``x_force``, ``y_force``, ``z_force``); ``mass`` and the
    moments ``mx``, ``my``, ``mz`` that some versions add are optional and ignored. Other
    lines (title, legend, blank) are skipped.
``glstat``
    one block per output time, each starting with `` dt of cycle …``, then one line per
    quantity: label ``[0:32)`` (words padded with dots), value ``[32:46)``, an optional
    suffix (``wall#  1``). Read are ``time``, ``time step``, ``kinetic energy``,
    ``internal energy``, ``spring and damper energy``, ``hourglass energy``,
    ``system damping energy``, ``sliding interface energy``, ``external work``,
    ``eroded kinetic energy``, ``eroded internal energy``, ``total energy`` and
    ``stonewall energy`` (summed over walls); other lines are ignored. A quantity is a channel
    when the first block has it and then every block must have it.

Numbers: Fortran ``E`` format; an exponent of three digits that lost its ``E``
(``1.2345-100``) is accepted. A truncated last block (the run stopped while writing: a
short line or fewer nodes) is dropped with a :class:`UserWarning`; anything else that does not
fit the layout is a ``ValueError`` naming the file, line and field.

``binout`` (:func:`read_binout`) is read through lasso-python (``lasso.dyna.Binout``, the
optional ``lsdyna`` extra; its pins conflict with common packages, so install it in its own
environment): the same three branches, from the LSDA variables ``nodout/{x,y,z}_displacement``
… ``_coordinate`` and ``ids``, ``rcforc/{x,y,z}_force``, ``ids`` and ``side`` (non-zero:
master), ``glstat/<quantity>`` with the channel names above, and each branch's ``time``.

:func:`write_nodout` and :func:`write_rcforc` write these layouts (with ``%12.4E`` and
``%12.5E`` fields as LS-DYNA's ``l2a`` does), for fixtures and round trips.
"""

from __future__ import annotations

import math
import re
import warnings
from array import array
from collections.abc import Iterable, Iterator, Mapping, Sequence
from numbers import Integral
from pathlib import Path
from typing import IO, NamedTuple, TextIO

import numpy as np

from surrogates.features import TimeHistory


class UnitSystem(NamedTuple):
    """SI value of one unit of length (m), time (s), mass (kg) and force (N)."""

    length: float
    time: float
    mass: float
    force: float

    @property
    def velocity(self) -> float:
        """SI value (m/s) of one velocity unit."""
        return self.length / self.time

    @property
    def acceleration(self) -> float:
        """SI value (m/s²) of one acceleration unit."""
        return self.length / self.time**2

    @property
    def energy(self) -> float:
        """SI value (J) of one energy unit (force × length)."""
        return self.force * self.length


#: consistent LS-DYNA unit sets (force = mass · length / time² in each)
UNIT_SYSTEMS: dict[str, UnitSystem] = {
    "m-s-kg-N": UnitSystem(1.0, 1.0, 1.0, 1.0),
    "mm-s-t-N": UnitSystem(1e-3, 1.0, 1e3, 1.0),
    "mm-ms-kg-kN": UnitSystem(1e-3, 1e-3, 1.0, 1e3),
    "mm-ms-g-N": UnitSystem(1e-3, 1e-3, 1e-3, 1.0),
}

NODOUT_HEADER = " n o d a l   p r i n t   o u t   f o r   t i m e  s t e p"
NODOUT_FIELDS = tuple(
    f"{axis}_{q}" for q in ("disp", "vel", "accl", "coor") for axis in ("x", "y", "z")
)
NODE_ID_WIDTH = 10
FIELD_WIDTH = 12
RCFORC_FIELDS = ("x_force", "y_force", "z_force")
#: largest magnitude of a value read: beyond it the conversion to SI (× up to 1e3) could
#: overflow, and no LS-DYNA output holds such a number
MAX_VALUE = 1e300
#: an rcforc data line starts with the side and the contact id, then the label ``time``
_RCFORC_HEAD = re.compile(r"\s*(master|slave)\s+(\d+)\s*(?=time)")
#: the labels that precede the values of an rcforc line (moments only in some versions)
_RCFORC_LABEL = re.compile(r"(?<![A-Za-z])(time|mass|mx|my|mz|x|y|z)(?![A-Za-z])")
_RCFORC_REQUIRED = ("time", "x", "y", "z")
GLSTAT_LABELS = {
    "time": "time",
    "time step": "time_step",
    "kinetic energy": "kinetic_energy",
    "internal energy": "internal_energy",
    "spring and damper energy": "spring_and_damper_energy",
    "hourglass energy": "hourglass_energy",
    "system damping energy": "system_damping_energy",
    "sliding interface energy": "sliding_interface_energy",
    "external work": "external_work",
    "eroded kinetic energy": "eroded_kinetic_energy",
    "eroded internal energy": "eroded_internal_energy",
    "total energy": "total_energy",
    "stonewall energy": "stonewall_energy",
}
_GLSTAT_LABEL_END = 32
_GLSTAT_VALUE_END = 46
_LOST_E = re.compile(r"^([-+]?[0-9.]+)([-+][0-9]{3})$")
NODOUT_COLUMNS = (
    " nodal point  x-disp     y-disp      z-disp      x-vel       y-vel       z-vel      "
    "x-accl      y-accl      z-accl      x-coor      y-coor      z-coor\n"
)
_AT_TIME = re.compile(r"\(\s*at time\s*(\S+?)\s*\)")


def unit_system(units: str) -> UnitSystem:
    """The :class:`UnitSystem` named ``units``; ``ValueError`` listing the known names."""
    if units not in UNIT_SYSTEMS:
        raise ValueError(
            f"units {units!r} is not a known LS-DYNA unit set; use one of {list(UNIT_SYSTEMS)}"
        )
    return UNIT_SYSTEMS[units]


def _number(text: str, where: str) -> float:
    """Float of a fixed-width field; ``where`` names file, line and field for the error."""
    s = text.strip()
    try:
        value = float(s)
    except ValueError:
        m = _LOST_E.match(s)
        if m is None:
            raise ValueError(f"{where}: {text!r} is not a number") from None
        value = float(f"{m.group(1)}E{m.group(2)}")
    if not math.isfinite(value):
        raise ValueError(f"{where}: value is {value}")
    if abs(value) > MAX_VALUE:
        raise ValueError(f"{where}: {value} is beyond ±{MAX_VALUE:g} (no output value is)")
    return value


def _open(path: Path) -> TextIO:
    """The ASCII file as text; bytes that are not UTF-8 (a title in another encoding) read as
    U+FFFD, so only the numbers, never a title, can make a line fail."""
    return path.open(encoding="utf-8", errors="replace")


def _node_ids(nodes: Iterable[int] | None) -> list[int] | None:
    """``nodes`` as a list of ids; a string or non-integer ids are a ``ValueError``."""
    if nodes is None:
        return None
    if isinstance(nodes, str | bytes) or not isinstance(nodes, Iterable):
        raise ValueError(f"nodes must be a list of node ids (integers), got {nodes!r}")
    ids = list(nodes)
    bad = [n for n in ids if isinstance(n, bool | np.bool_) or not isinstance(n, Integral)]
    if bad:
        raise ValueError(f"nodes must be node ids (integers), got {bad[0]!r} in {nodes!r}")
    return [int(n) for n in ids]


def _lines(fh: TextIO) -> Iterator[tuple[int, str]]:
    for lineno, line in enumerate(fh, start=1):
        yield lineno, line.rstrip("\r\n")


def read_legend(path: str | Path) -> dict[int, str]:
    """Entity id → title of the ``{BEGIN LEGEND}`` block of any ASCII file (empty if none)."""
    path = Path(path)
    out: dict[int, str] = {}
    with _open(path) as fh:
        inside = False
        for lineno, line in _lines(fh):
            if line.strip() == "{BEGIN LEGEND}":
                inside = True
            elif line.strip() == "{END LEGEND}":
                return out
            elif inside and line.strip() and not line.lstrip().startswith("Entity"):
                try:
                    entity = _number(line[:14], "")
                except ValueError:
                    raise ValueError(
                        f"{path}: line {lineno}: {line.strip()[:40]!r} is not a legend entry "
                        "(entity id in columns 1-14): the legend block has no {END LEGEND} "
                        "line before it"
                    ) from None
                out[int(entity)] = line[14:].strip()
            elif not inside and (line.startswith(NODOUT_HEADER) or "time" in line[19:24]):
                break
    if inside:
        raise ValueError(f"{path}: the legend block has no {{END LEGEND}} line")
    return out


def _check_time(path: Path, lineno: int, t: float, last: float | None, what: str) -> None:
    if last is not None and t <= last:
        raise ValueError(
            f"{path}: line {lineno}: {what} time {t} is not after the previous time {last}"
        )


def _truncated(path: Path, lineno: int, why: str) -> None:
    warnings.warn(f"{path}: truncated last block at line {lineno} ({why}); dropped", stacklevel=3)


# ------------------------------------------------------------------------------- nodout
class _NodoutBlock:
    """Values of one nodout block: time, node ids and one array of 12 fields per node."""

    def __init__(self, lineno: int, time: float, rotational: bool) -> None:
        self.lineno = lineno
        self.time = time
        self.rotational = rotational
        self.ids: list[int] = []
        self.values: list[Sequence[float]] = []
        self.short_line: int | None = None


def _nodout_blocks(path: Path, fh: TextIO, wanted: set[int] | None) -> Iterator[_NodoutBlock]:
    block: _NodoutBlock | None = None
    header_seen = False
    need = NODE_ID_WIDTH + FIELD_WIDTH * len(NODOUT_FIELDS)
    for lineno, line in _lines(fh):
        if line.startswith(NODOUT_HEADER):
            if block is not None:
                yield block
            m = _AT_TIME.search(line)
            if m is None:
                raise ValueError(f"{path}: line {lineno}: block header without '( at time … )'")
            t = _number(m.group(1), f"{path}: line {lineno}: block time")
            block = _NodoutBlock(lineno, t, rotational=False)
            header_seen = False
            continue
        if block is None or not line.strip():
            continue
        if not header_seen:
            if "nodal point" not in line:
                raise ValueError(f"{path}: line {lineno}: expected the 'nodal point' column header")
            header_seen = True
            block.rotational = "x-rot" in line
            continue
        if block.rotational or block.short_line is not None:
            continue
        where = f"{path}: line {lineno}"
        node = int(_number(line[:NODE_ID_WIDTH], f"{where}: node id (columns 1-10)"))
        if wanted is not None and node not in wanted:
            block.ids.append(node)
            block.values.append(())
            continue
        if len(line) < need:
            block.short_line = lineno
            continue
        vals = array("d")
        for k, name in enumerate(NODOUT_FIELDS):
            a = NODE_ID_WIDTH + FIELD_WIDTH * k
            field = f"{where}: field {name!r} (columns {a + 1}-{a + FIELD_WIDTH})"
            vals.append(_number(line[a : a + FIELD_WIDTH], field))
        block.ids.append(node)
        block.values.append(vals)
    if block is not None:
        yield block


def read_nodout(
    path: str | Path, nodes: Iterable[int] | None = None, units: str = "m-s-kg-N"
) -> dict[int, TimeHistory]:
    """Nodal time histories of an LS-DYNA ``nodout`` file, in SI.

    Parameters
    ----------
    path : the ASCII ``nodout`` file (layout in the module docstring).
    nodes : node ids to keep (default all); an id the file lacks is a ``ValueError``.
    units : the model's unit set (:data:`UNIT_SYSTEMS`).

    Returns
    -------
    node id → :class:`~surrogates.features.TimeHistory` with channels ``x_disp … z_disp`` (m),
    ``x_vel … z_vel`` (m/s), ``x_accl … z_accl`` (m/s²), ``x_coor … z_coor`` (m), on the
    block times (s).
    """
    us = unit_system(units)
    path = Path(path)
    ids = _node_ids(nodes)
    wanted = None if ids is None else set(ids)
    times = array("d")
    order: list[int] | None = None
    data: dict[int, list[array]] = {}
    pending: _NodoutBlock | None = None
    with _open(path) as fh:
        for block in _nodout_blocks(path, fh, wanted):
            if block.rotational:
                continue
            if pending is not None:
                raise ValueError(
                    f"{path}: line {pending.short_line or pending.lineno}: the block at time "
                    f"{pending.time} is incomplete but more blocks follow"
                )
            if order is None:
                order = block.ids
                if not order:
                    raise ValueError(f"{path}: line {block.lineno}: the first block has no nodes")
                missing = sorted((wanted or set()) - set(order))
                if missing:
                    raise ValueError(f"{path}: node(s) {missing} not in the file; it has {order}")
                keep = [n for n in order if wanted is None or n in wanted]
                data = {n: [array("d") for _ in NODOUT_FIELDS] for n in keep}
            if block.short_line is not None or block.ids != order:
                if block.ids != order[: len(block.ids)]:
                    raise ValueError(
                        f"{path}: line {block.lineno}: the block at time {block.time} lists "
                        f"nodes {block.ids[:5]}…, the first block {order[:5]}…"
                    )
                pending = block
                continue
            _check_time(path, block.lineno, block.time, times[-1] if times else None, "block")
            times.append(block.time)
            for node, vals in zip(block.ids, block.values, strict=True):
                if node in data:
                    for k, col in enumerate(data[node]):
                        col.append(vals[k])
    if order is None:
        raise ValueError(f"{path}: no 'n o d a l   p r i n t   o u t' block found")
    if pending is not None:
        _truncated(path, pending.short_line or pending.lineno, "incomplete node list")
    if len(times) < 2:
        raise ValueError(f"{path}: fewer than 2 complete blocks, no time history")
    scale = [us.length] * 3 + [us.velocity] * 3 + [us.acceleration] * 3 + [us.length] * 3
    unit = ["m"] * 3 + ["m/s"] * 3 + ["m/s^2"] * 3 + ["m"] * 3
    t = np.frombuffer(times, dtype=float) * us.time
    return {
        node: TimeHistory(
            t,
            {
                f: np.frombuffer(c, dtype=float) * s
                for f, c, s in zip(NODOUT_FIELDS, cols, scale, strict=True)
            },
            dict(zip(NODOUT_FIELDS, unit, strict=True)),
        )
        for node, cols in data.items()
    }


# ------------------------------------------------------------------------------- rcforc
def read_rcforc(path: str | Path, units: str = "m-s-kg-N") -> dict[tuple[str, int], TimeHistory]:
    """Contact force histories of an LS-DYNA ``rcforc`` file, in SI.

    Returns ``(side, contact id) → TimeHistory`` with side ``"master"`` or ``"slave"`` and
    channels ``x_force``, ``y_force``, ``z_force`` and ``resultant`` (N) on the times (s)
    of that contact side. A last line cut short is dropped with a warning; a force whose
    resultant overflows float64 is an error naming the file and line.
    """
    us = unit_system(units)
    path = Path(path)
    series: dict[tuple[str, int], list[array]] = {}
    line_of: dict[tuple[str, int], array] = {}
    short: int | None = None
    with _open(path) as fh:
        for lineno, line in _lines(fh):
            m = _RCFORC_HEAD.match(line)
            if m is None:
                continue
            if short is not None:
                raise ValueError(f"{path}: line {short}: line too short for the rcforc layout")
            where = f"{path}: line {lineno}"
            parts = _RCFORC_LABEL.split(line[m.end() :])
            fields = dict(zip(parts[1::2], (p.strip() for p in parts[2::2]), strict=True))
            if any(not fields.get(label) for label in _RCFORC_REQUIRED):
                short = lineno
                continue
            side = m.group(1)
            key = (side, int(_number(m.group(2), f"{where}: contact id")))
            vals = [
                _number(fields[label], f"{where}: field {name!r} (after the label {label!r})")
                for label, name in zip(_RCFORC_REQUIRED, ("time", *RCFORC_FIELDS), strict=True)
            ]
            cols = series.setdefault(key, [array("d") for _ in range(4)])
            line_of.setdefault(key, array("q")).append(lineno)
            _check_time(path, lineno, vals[0], cols[0][-1] if cols[0] else None, f"{key}")
            for col, v in zip(cols, vals, strict=True):
                col.append(v)
    if short is not None:
        _truncated(path, short, "line cut short")
    if not series:
        raise ValueError(f"{path}: no 'master'/'slave' contact force lines found")
    out = {}
    for key, cols in series.items():
        t, fx, fy, fz = (np.frombuffer(c, dtype=float) for c in cols)
        if t.size < 2:
            raise ValueError(f"{path}: line {line_of[key][0]}: contact {key} has one sample only")
        f = {n: v * us.force for n, v in zip(RCFORC_FIELDS, (fx, fy, fz), strict=True)}
        with np.errstate(over="ignore"):
            f["resultant"] = np.sqrt(f["x_force"] ** 2 + f["y_force"] ** 2 + f["z_force"] ** 2)
        _check_resultant(path, key, f, line_of[key])
        out[key] = TimeHistory(t * us.time, f, dict.fromkeys(f, "N"))
    return out


def _check_resultant(
    path: Path, key: tuple[str, int], f: dict[str, np.ndarray], lines: array
) -> None:
    """Refuse a resultant force that overflowed (``inf`` from finite components)."""
    bad = np.flatnonzero(~np.isfinite(f["resultant"]))
    if bad.size:
        k = int(bad[0])
        xyz = ", ".join(f"{f[n][k]:.6g}" for n in RCFORC_FIELDS)
        raise ValueError(
            f"{path}: line {lines[k]}: contact {key}: the resultant force of (x, y, z) = "
            f"({xyz}) N overflows float64 (√(x² + y² + z²) needs each below ~1e154 N): no "
            "contact force is this large; check the line (a misplaced exponent?) and the unit set"
        )


# ------------------------------------------------------------------------------- glstat
def _glstat_blocks(path: Path, fh: TextIO) -> Iterator[tuple[int, dict[str, float]]]:
    block: dict[str, float] | None = None
    start = 0
    for lineno, line in _lines(fh):
        if line.startswith(" dt of cycle"):
            if block:
                yield start, block
            block, start = {}, lineno
            continue
        if block is None or len(line) <= _GLSTAT_LABEL_END or "." not in line[:_GLSTAT_LABEL_END]:
            continue
        label = " ".join(line[:_GLSTAT_LABEL_END].replace(".", " ").split())
        name = GLSTAT_LABELS.get(label)
        if name is None:
            continue
        field = f"{path}: line {lineno}: field {label!r} (columns 33-46)"
        value = _number(line[_GLSTAT_LABEL_END:_GLSTAT_VALUE_END], field)
        block[name] = block.get(name, 0.0) + value if name == "stonewall_energy" else value
    if block:
        yield start, block


def read_glstat(path: str | Path, units: str = "m-s-kg-N") -> TimeHistory:
    """Global energies of an LS-DYNA ``glstat`` file, in SI (J; ``time_step`` in s).

    Channels: the quantities of :data:`GLSTAT_LABELS` present in the first block (at least
    ``kinetic_energy``, ``internal_energy`` and ``total_energy``), on the block times (s).
    A last block that lacks a quantity of the first is dropped with a warning.
    """
    us = unit_system(units)
    path = Path(path)
    names: list[str] | None = None
    cols: dict[str, array] = {}
    pending: int | None = None
    with _open(path) as fh:
        for lineno, block in _glstat_blocks(path, fh):
            if pending is not None:
                raise ValueError(f"{path}: line {pending}: block is incomplete but more follow")
            if names is None:
                names = list(block)
                for need in ("time", "kinetic_energy", "internal_energy", "total_energy"):
                    if need not in block:
                        raise ValueError(f"{path}: line {lineno}: the first block has no {need!r}")
                cols = {n: array("d") for n in names}
            if any(n not in block for n in names):
                pending = lineno
                continue
            _check_time(
                path, lineno, block["time"], cols["time"][-1] if cols["time"] else None, "block"
            )
            for n in names:
                cols[n].append(block[n])
    if names is None:
        raise ValueError(f"{path}: no ' dt of cycle' block found")
    if pending is not None:
        _truncated(path, pending, "quantities missing")
    t = np.frombuffer(cols.pop("time"), dtype=float) * us.time
    chans = {
        n: np.frombuffer(c, dtype=float) * (us.time if n == "time_step" else us.energy)
        for n, c in cols.items()
    }
    return TimeHistory(t, chans, {n: "s" if n == "time_step" else "J" for n in chans})


# ------------------------------------------------------------------------------- writers
def _fmt(x: float, width: int, digits: int) -> str:
    return f"{x:{width}.{digits}E}"


def _write_header(fh: IO[str], title: str, legend: Mapping[int, str] | None) -> None:
    fh.write(f" {title}\n                         ls-dyna (surrogates.lsdyna writer)\n")
    if legend:
        fh.write("\n{BEGIN LEGEND}\n Entity #        Title\n")
        for k, name in legend.items():
            fh.write(f"{k:9d}     {name}\n")
        fh.write("{END LEGEND}\n")


def write_nodout(
    path: str | Path,
    t: Sequence[float] | np.ndarray,
    nodes: Mapping[int, Mapping[str, np.ndarray]],
    *,
    legend: Mapping[int, str] | None = None,
    title: str = "railgym",
) -> Path:
    """Write ``nodout`` in the layout :func:`read_nodout` reads (values in the file's units).

    ``nodes``: node id → ``{field: (n,) array}`` for the fields of :data:`NODOUT_FIELDS`
    (missing fields are written as 0).
    """
    path = Path(path)
    with path.open("w") as fh:
        _write_header(fh, title, legend)
        zeros = np.zeros(len(t))
        for i, ti in enumerate(t):
            fh.write(f"\n\n\n{NODOUT_HEADER}{i + 1:8d}{'':30s}( at time{ti:14.7E} )\n\n")
            fh.write(NODOUT_COLUMNS)
            for node, fields in nodes.items():
                vals = "".join(_fmt(fields.get(f, zeros)[i], 12, 4) for f in NODOUT_FIELDS)
                fh.write(f"{node:10d}{vals}\n")
    return path


def write_rcforc(
    path: str | Path,
    t: Sequence[float] | np.ndarray,
    contacts: Mapping[tuple[str, int], Mapping[str, np.ndarray]],
    *,
    legend: Mapping[int, str] | None = None,
    title: str = "railgym",
) -> Path:
    """Write ``rcforc`` in the layout :func:`read_rcforc` reads (values in the file's units).

    ``contacts``: ``(side, id)`` → ``{"x_force", "y_force", "z_force": (n,) array}``.
    """
    path = Path(path)
    with path.open("w") as fh:
        _write_header(fh, title, legend)
        zeros = np.zeros(len(t))
        for i, ti in enumerate(t):
            for (side, cid), f in contacts.items():
                x, y, z = (f.get(n, zeros)[i] for n in RCFORC_FIELDS)
                fh.write(
                    f"  {side:6s}{cid:11d} time{ti:12.5E}  x {x:12.5E}  y {y:12.5E}  "
                    f"z {z:12.5E} mass {0.0:12.5E}\n"
                )
    return path


# ------------------------------------------------------------------------------- binout
class BinoutData(NamedTuple):
    """The branches of a ``binout`` as the ASCII readers return them (``None``: absent)."""

    nodout: dict[int, TimeHistory] | None
    rcforc: dict[tuple[str, int], TimeHistory] | None
    glstat: TimeHistory | None


_BINOUT_NODOUT = {
    f"{axis}_{q}": f"{axis}_{name}"
    for q, name in (
        ("disp", "displacement"),
        ("vel", "velocity"),
        ("accl", "acceleration"),
        ("coor", "coordinate"),
    )
    for axis in ("x", "y", "z")
}


def read_binout(
    path: str | Path, units: str = "m-s-kg-N", nodes: Iterable[int] | None = None
) -> BinoutData:
    """``nodout``, ``rcforc`` and ``glstat`` of an LS-DYNA ``binout`` (glob for ``binout*``
    families), in SI, with the channels of :func:`read_nodout`, :func:`read_rcforc` and
    :func:`read_glstat`. Needs lasso-python (the ``lsdyna`` extra); ``ImportError`` if absent.
    """
    try:
        from lasso.dyna import Binout  # type: ignore[import-not-found, unused-ignore]
    except ImportError as exc:
        raise ImportError(
            "read_binout needs lasso-python (pip install 'railgym[lsdyna]', best in its own "
            "environment: its pins conflict with common packages); or convert the binout to "
            "ASCII with LS-PrePost/l2a and use read_nodout/read_rcforc/read_glstat"
        ) from exc
    us = unit_system(units)
    try:
        b = Binout(str(path))
    except OSError as exc:
        raise ValueError(f"{path}: cannot open the binout ({exc})") from exc
    branches = set(b.read())

    def table(branch: str, name: str, n: int) -> np.ndarray:
        a = np.asarray(b.read(branch, name), dtype=float)
        return a.reshape(a.shape[0], n) if a.ndim < 2 else a

    nod = rc = gl = None
    if "nodout" in branches:
        ids = np.atleast_1d(np.asarray(b.read("nodout", "ids"), dtype=np.int64))
        t = np.asarray(b.read("nodout", "time"), dtype=float) * us.time
        chosen = _node_ids(nodes)
        wanted = ids if chosen is None else np.array(chosen, dtype=np.int64)
        missing = sorted(set(wanted.tolist()) - set(ids.tolist()))
        if missing:
            raise ValueError(f"{path}: node(s) {missing} not in the binout's nodout")
        scale = dict(
            zip(
                NODOUT_FIELDS,
                [us.length] * 3 + [us.velocity] * 3 + [us.acceleration] * 3 + [us.length] * 3,
                strict=True,
            )
        )
        unit = dict(
            zip(NODOUT_FIELDS, ["m"] * 3 + ["m/s"] * 3 + ["m/s^2"] * 3 + ["m"] * 3, strict=True)
        )
        cols = {f: table("nodout", _BINOUT_NODOUT[f], ids.size) * scale[f] for f in NODOUT_FIELDS}
        col = {int(n): int(np.flatnonzero(ids == n)[0]) for n in wanted}
        nod = {
            n: TimeHistory(t, {f: c[:, j] for f, c in cols.items()}, unit) for n, j in col.items()
        }
    if "rcforc" in branches:
        ids = np.atleast_1d(np.asarray(b.read("rcforc", "ids"), dtype=np.int64))
        sides = np.atleast_1d(np.asarray(b.read("rcforc", "side")))
        t = np.asarray(b.read("rcforc", "time"), dtype=float) * us.time
        f = {n: table("rcforc", n, ids.size) * us.force for n in RCFORC_FIELDS}
        rc = {}
        for j, (cid, side) in enumerate(zip(ids, sides, strict=True)):
            ch = {n: f[n][:, j] for n in RCFORC_FIELDS}
            ch["resultant"] = np.sqrt(sum(ch[n] ** 2 for n in RCFORC_FIELDS))
            rc[("master" if side else "slave", int(cid))] = TimeHistory(
                t, ch, dict.fromkeys(ch, "N")
            )
    if "glstat" in branches:
        t = np.asarray(b.read("glstat", "time"), dtype=float) * us.time
        ch = {}
        for n in GLSTAT_LABELS.values():
            try:
                a = np.asarray(b.read("glstat", n), dtype=float)
            except ValueError:  # lasso: no such variable
                continue
            if n != "time" and a.shape[:1] == t.shape:
                si = us.time if n == "time_step" else us.energy
                ch[n] = (a.sum(axis=1) if a.ndim == 2 else a) * si
        gl = TimeHistory(t, ch, {n: "s" if n == "time_step" else "J" for n in ch})
    return BinoutData(nod, rc, gl)
