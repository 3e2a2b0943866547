"""Measured or user-given vertical track profiles: reading, checking, resampling.

A profile is a pair ``(x, z)``: positions along the track (m, strictly increasing) and the
vertical irregularity there (m). It is read from a CSV file with two columns ``x, z``
(an optional header row naming them; ``#`` starts a comment line), checked (finite values,
strictly increasing ``x``, enough length for the run) and resampled by a not-a-knot cubic
spline, which also gives the slope ``dz/dx``. Nothing is clipped or detrended: what the
file holds is what the vehicle rides on, starting at its first position.
"""

from __future__ import annotations

import csv
import io
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from railgym import _checks as val

#: fewest points accepted in a profile
MIN_POINTS = 4
#: largest median point spacing, m: a track profile is sampled every 0.1–1 m, and the ride
#: needs wavelengths down to 1 m (a profile in mm read as m has spacings of 100 m and more)
MAX_SPACING = 5.0
#: largest irregularity about the profile's straight line (least squares), m: measured track
#: irregularities are a few cm (a profile in mm read as m reaches metres)
MAX_IRREGULARITY = 0.5
_HEADER = re.compile(r"[xz]\s*(?:\[\s*(\w+)\s*\])?")


def read_profile_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a profile CSV (columns ``x`` m, ``z`` m); errors name the file and line.

    Returns
    -------
    x, z : float64 arrays, checked by :func:`check_profile`.
    """
    path = Path(path)
    if path.is_dir():
        raise val.FieldError(
            "profile", f"profile {str(path)!r} is a folder, not a CSV file", full=True
        )
    if not path.is_file():
        raise val.FieldError("profile", f"profile file {str(path)!r} does not exist", full=True)
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8-sig")  # a byte-order mark, as spreadsheets write, is skipped
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ValueError(f"{path}:{line}: not UTF-8 text ({exc.reason})") from None
    xs: list[float] = []
    zs: list[float] = []
    lines: list[int] = []
    for line_no, row in enumerate(csv.reader(io.StringIO(text, newline="")), start=1):
        cells = [c.strip() for c in row]
        if not cells or not any(cells) or cells[0].startswith("#"):
            continue
        if len(cells) != 2:
            raise ValueError(f"{path}:{line_no}: expected 2 columns (x, z), got {len(cells)}")
        if not xs and all(_HEADER.fullmatch(c.lower()) for c in cells):  # header
            if any(_HEADER.fullmatch(c.lower())[1] not in (None, "m") for c in cells):
                raise ValueError(f"{path}:{line_no}: columns x, z must be in m, got {row!r}")
            continue
        try:
            x, z = float(cells[0]), float(cells[1])
        except ValueError:
            raise ValueError(
                f"{path}:{line_no}: not a number in {row!r} (columns x, z in m)"
            ) from None
        xs.append(x)
        zs.append(z)
        lines.append(line_no)
    x_arr, z_arr = np.array(xs), np.array(zs)
    check_profile(x_arr, z_arr, source=str(path), lines=lines)
    return x_arr, z_arr


def load_profile(profile: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """A profile argument checked: ``None`` (no profile), a CSV path or an ``(x, z)`` pair (m)."""
    if profile is None:
        return None
    if isinstance(profile, str | Path):
        return read_profile_csv(profile)
    if not (isinstance(profile, tuple | list) and len(profile) == 2):
        raise val.FieldTypeError(
            "profile", "must be None, a CSV path or a pair (x, z) of arrays in m", full=False
        )
    return check_profile(profile[0], profile[1], source="profile")


def _real_array(value: Any, label: str) -> np.ndarray:
    """``value`` as a float64 array; bools, strings, complex and ragged data are type errors."""
    try:
        arr = np.asarray(value) if not isinstance(value, str | bytes) else np.asarray(value, object)
    except ValueError:  # ragged nesting
        arr = np.asarray(None, object)
    if arr.dtype.kind not in "iuf":
        raise val.FieldTypeError(
            label,
            f"{label} must be an array of real numbers, got dtype {arr.dtype}",
            full=True,
        )
    return arr.astype(np.float64)


def check_profile(
    x: Any, z: Any, source: str = "profile", lines: list[int] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Validate a profile; the error (a ``ValueError``; a ``TypeError`` too for data that are
    not real numbers) names ``source`` and the line (or index) at fault."""
    x, z = (_real_array(v, f"{source}: {name}") for name, v in (("x", x), ("z", z)))
    if x.ndim != 1 or x.shape != z.shape:
        raise val.FieldError(
            source,
            f"{source}: x and z must be 1-D of equal length, got {x.shape}, {z.shape}",
            full=True,
        )
    if x.size < MIN_POINTS:
        raise val.FieldError(
            source, f"{source}: needs at least {MIN_POINTS} points, got {x.size}", full=True
        )

    def where(i: int) -> str:
        return f"line {lines[i]}" if lines is not None else f"index {i}"

    for name, arr in (("x", x), ("z", z)):
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise ValueError(f"{source}: {name} is not finite ({arr[bad[0]]}) at {where(bad[0])}")
    step = np.diff(x)
    bad = np.flatnonzero(step <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise ValueError(
            f"{source}: x must be strictly increasing; x = {x[i]} m at {where(i)} follows "
            f"x = {x[i - 1]} m"
        )
    spacing = float(np.median(step))
    if spacing > MAX_SPACING:
        raise ValueError(
            f"{source}: median point spacing {spacing:.4g} m is above {MAX_SPACING:g} m; x and z "
            "must be in m (a profile in mm?)"
        )
    deviation = np.abs(z - np.polyval(np.polyfit(x - x[0], z, 1), x - x[0]))
    k = int(np.argmax(deviation))
    if deviation[k] > MAX_IRREGULARITY:
        raise ValueError(
            f"{source}: z departs {deviation[k]:.4g} m from the profile's straight line at "
            f"{where(k)}, above {MAX_IRREGULARITY:g} m; z must be an irregularity in m (a "
            "profile in mm?)"
        )
    return x, z


def resample_profile(
    x: Any, z: Any, dx: float, n: int, source: str = "profile", length: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Profile height (m) and slope on ``x[0] + j·dx``, ``j = 0..n−1`` (cubic spline).

    ValueError when the profile is shorter than ``length`` (m, the run's documented length;
    default ``(n − 1)·dx``), naming both lengths; samples beyond the profile repeat its end.
    """
    x, z = check_profile(x, z, source)
    if not (math.isfinite(dx) and dx > 0):
        raise ValueError(f"dx must be a positive number of metres, got {dx!r}")
    need = (n - 1) * dx if length is None else length
    have = float(x[-1] - x[0])
    if have < need * (1.0 - 1e-12):
        raise ValueError(
            f"{source}: too short: it covers {have:.3f} m, the run needs {need:.3f} m "
            "(speed × duration, plus the wheelset span for the whole vehicle)"
        )
    spline = CubicSpline(x, z)
    grid = np.minimum(x[0] + dx * np.arange(n), x[-1])
    return spline(grid), spline(grid, 1)


def profile_time_input(
    profile: tuple[Any, Any],
    speed: float,
    dt: float,
    n: int,
    source: str = "profile",
    length: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Track height ``z(v·k·dt)`` (m) and rate ``v·z'`` (m/s) of a profile, ``k = 0..n−1``;
    ``length`` as in :func:`resample_profile`."""
    if not (math.isfinite(speed) and speed > 0):
        raise ValueError(f"speed must be a positive number in m/s, got {speed!r}")
    z, slope = resample_profile(profile[0], profile[1], speed * dt, n, source, length)
    return z, speed * slope
