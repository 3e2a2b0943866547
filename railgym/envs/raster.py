"""Dependency-free rasteriser for the environments' ``render_mode="rgb_array"``.

numpy only (no display, no pygame, no matplotlib). A canvas is an ``(H, W, 3)`` ``uint8``
array; coordinates are pixels (floats allowed) with ``x`` to the right and ``y`` downwards,
pixel ``(row j, column i)`` covering ``[i, i + 1) x [j, j + 1)``. Every primitive clips at
the canvas borders, so any finite or infinite coordinate is safe; NaN raises ``ValueError``.

The scenes build on the primitives, each in its env's folder: ``render_vertical``
(:mod:`railgym.envs.vertical.render`), ``render_vehicle`` (:mod:`railgym.envs.vehicle.render`)
and ``render_crash`` (:mod:`railgym.envs.crash.render`). Track heights and displacements are
drawn at :data:`DISPLACEMENT_PX_PER_M` (2 px per mm at the reference height of 400 px, scaled
with the frame height).

Every bar on a frame carries its label in the bitmap font (:mod:`railgym.envs.text`), left
of the bar: ``time`` for the progress bar along the top, ``force`` for an actuator gauge
under it (:data:`BAR_ROWS`, :func:`draw_progress_bar`, :func:`draw_gauge`).

Colours of the scene parts are in :data:`VERTICAL_COLORS` and :data:`CRASH_COLORS`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from railgym.envs.text import draw_text, text_width

__all__ = [
    "BAR_ROWS",
    "CRASH_COLORS",
    "DISPLACEMENT_PX_PER_M",
    "REFERENCE_HEIGHT",
    "VERTICAL_COLORS",
    "bar_columns",
    "canvas",
    "check_frame_size",
    "draw_box",
    "draw_caption",
    "draw_damper",
    "draw_gauge",
    "draw_line",
    "draw_polyline",
    "draw_progress_bar",
    "draw_spring",
    "draw_time_bar",
    "draw_track",
    "fill_circle",
    "fill_rect",
    "fill_spans",
    "state_scalar",
    "state_vector",
    "track_window",
]

Color = Sequence[int]

#: Vertical drawing scale of track heights and displacements at a frame height of
#: :data:`REFERENCE_HEIGHT`, px/m.
DISPLACEMENT_PX_PER_M = 2000.0
#: px, the frame height at which the scales are given
REFERENCE_HEIGHT = 400.0
#: rows ``(top, bottom)`` (px, edges) of the frames' bars: the progress bar (``"time"``) and
#: the actuator gauges (``"force"``); each bar's label is drawn left of it, centred on its rows
BAR_ROWS = {"time": (3.0, 8.0), "force": (11.0, 16.0)}
#: px: left margin of the bar labels, gap between a label and its bar
_LABEL_X, _LABEL_GAP = 4, 4
_FAR = 1e9  # coordinates are clamped to +-_FAR px before any arithmetic (handles inf)

VERTICAL_COLORS: dict[str, tuple[int, int, int]] = {
    "background": (236, 242, 250),
    "ground": (160, 138, 110),
    "rail": (90, 90, 96),
    "wheel": (55, 55, 66),
    "primary_spring": (205, 125, 30),
    "damper": (75, 75, 85),
    "bogie": (115, 125, 140),
    "outline": (35, 35, 45),
    "air_spring": (30, 30, 34),
    "actuator_push": (30, 160, 70),
    "actuator_pull": (210, 45, 45),
    "carbody": (40, 90, 170),
    "bar_back": (205, 205, 210),
    "bar_front": (85, 85, 95),
}

CRASH_COLORS: dict[str, tuple[int, int, int]] = {
    "background": (236, 242, 250),
    "rail": (90, 90, 96),
    "wall": (70, 70, 76),
    "car": (40, 90, 170),
    "wheel": (55, 55, 66),
    "zone": (235, 170, 40),
    "zone_overloaded": (215, 30, 30),
    "bar_back": (205, 205, 210),
    "bar_front": (85, 85, 95),
}


# --------------------------------------------------------------------------- primitives
def _check_img(img: np.ndarray) -> None:
    if not (
        isinstance(img, np.ndarray)
        and img.ndim == 3
        and img.shape[2] == 3
        and img.dtype == np.uint8
    ):
        raise ValueError("img must be a numpy uint8 array of shape (H, W, 3)")


def _rgb(color: Color) -> np.ndarray:
    if len(color) != 3 or not all(0 <= v <= 255 for v in color):
        raise ValueError(f"color must be 3 values in 0..255, got {color!r}")
    return np.array(color, dtype=np.uint8)


def _coords(name: str, *values: float) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    if np.isnan(v).any():
        raise ValueError(f"{name}: coordinates must not be NaN")
    return np.clip(v, -_FAR, _FAR)


def _paint(region: np.ndarray, rgb: np.ndarray) -> None:
    """Set every pixel of a ``(h, w, 3)`` view to ``rgb``: one row, then row copies.

    About 60x faster than broadcasting a 3-vector over the whole view.
    """
    if region.shape[0]:
        region[0] = rgb
        region[1:] = region[0]


def canvas(width: int, height: int, color: Color = (255, 255, 255)) -> np.ndarray:
    """New ``(height, width, 3)`` uint8 image filled with ``color``."""
    if int(width) < 1 or int(height) < 1:
        raise ValueError(f"width and height must be >= 1 px, got {width} x {height}")
    img = np.empty((int(height), int(width), 3), dtype=np.uint8)
    _paint(img, _rgb(color))
    return img


def fill_rect(img: np.ndarray, x0: float, y0: float, x1: float, y1: float, color: Color) -> None:
    """Fill the pixels whose centres lie in the rectangle spanned by two corners (px)."""
    _check_img(img)
    xa, xb, ya, yb = _coords("fill_rect", x0, x1, y0, y1)
    h, w = img.shape[:2]
    i0 = max(math.ceil(min(xa, xb) - 0.5), 0)
    i1 = min(math.floor(max(xa, xb) - 0.5), w - 1)
    j0 = max(math.ceil(min(ya, yb) - 0.5), 0)
    j1 = min(math.floor(max(ya, yb) - 0.5), h - 1)
    if i0 <= i1 and j0 <= j1:
        _paint(img[j0 : j1 + 1, i0 : i1 + 1], _rgb(color))


def _raster_segments(
    img: np.ndarray,
    x0: np.ndarray,
    y0: np.ndarray,
    x1: np.ndarray,
    y1: np.ndarray,
    color: Color,
    width: int,
) -> None:
    """Draw straight segments (arrays of endpoints, px), clipped first (Liang-Barsky).

    Each clipped segment is sampled at most 1 px apart along its major axis; a ``width`` x
    ``width`` px square is stamped at every sample.
    """
    if int(width) < 1:
        raise ValueError(f"width must be >= 1 px, got {width}")
    width = int(width)
    rgb = _rgb(color)
    h, w = img.shape[:2]
    d = np.stack((x1 - x0, y1 - y0))
    p = np.concatenate((-d, d))
    q = np.stack((x0 + width, y0 + width, w + width - x0, h + width - y0))
    with np.errstate(divide="ignore", invalid="ignore"):
        r = q / p
    t0 = np.maximum(np.where(p < 0, r, 0.0).max(axis=0), 0.0)
    t1 = np.minimum(np.where(p > 0, r, 1.0).min(axis=0), 1.0)
    keep = (t0 <= t1) & ~((p == 0) & (q < 0)).any(axis=0)
    if not keep.any():
        return
    t0, t1, d = t0[keep], t1[keep], d[:, keep]
    start = np.stack((x0[keep], y0[keep])) + t0 * d
    d = (t1 - t0) * d
    n = np.ceil(np.abs(d).max(axis=0)).astype(np.intp) + 1
    seg = np.repeat(np.arange(n.size), n)
    t = (np.arange(seg.size) - (np.cumsum(n) - n)[seg]) / np.maximum(n - 1, 1)[seg]
    pts = start[:, seg] + t * d[:, seg]
    if width > 1:
        o = np.arange(width) - 0.5 * (width - 1)
        stamp = np.stack((np.tile(o, width), np.repeat(o, width)))
        pts = (pts[:, :, None] + stamp[:, None, :]).reshape(2, -1)
    ix, iy = np.floor(pts).astype(np.intp)
    inside = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
    img[iy[inside], ix[inside]] = rgb


def draw_line(
    img: np.ndarray,
    x0: float,
    y0: float,
    x1: float,
    y1: float,
    color: Color,
    width: int = 1,
) -> None:
    """Straight line from ``(x0, y0)`` to ``(x1, y1)`` (px), ``width`` px thick."""
    _check_img(img)
    c = _coords("draw_line", x0, y0, x1, y1)
    _raster_segments(img, c[0:1], c[1:2], c[2:3], c[3:4], color, width)


def draw_polyline(img: np.ndarray, xs: Any, ys: Any, color: Color, width: int = 1) -> None:
    """Open polyline through the points ``(xs[k], ys[k])`` (px), all segments in one pass."""
    _check_img(img)
    x = np.asarray(xs, dtype=float)
    y = np.asarray(ys, dtype=float)
    if x.ndim != 1 or x.size < 2:
        raise ValueError(f"xs must be a 1-D array of >= 2 points, got shape {x.shape}")
    if y.shape != x.shape:
        raise ValueError(f"ys must have the shape of xs {x.shape}, got {y.shape}")
    if np.isnan(x).any() or np.isnan(y).any():
        raise ValueError("draw_polyline: coordinates must not be NaN")
    x, y = np.clip(x, -_FAR, _FAR), np.clip(y, -_FAR, _FAR)
    _raster_segments(img, x[:-1], y[:-1], x[1:], y[1:], color, width)


def draw_spring(
    img: np.ndarray,
    x: float,
    y_top: float,
    y_bottom: float,
    color: Color,
    coils: int = 6,
    amplitude: float = 6,
    width: int = 1,
) -> None:
    """Vertical zig-zag spring on the axis ``x`` between ``y_top`` and ``y_bottom`` (px).

    Straight leads take 10 % of the length at each end; between them the line swings
    ``coils`` times to ``x - amplitude`` and ``x + amplitude``.
    """
    if int(coils) < 1:
        raise ValueError(f"coils must be >= 1, got {coils}")
    xc, yt, yb = _coords("draw_spring", x, y_top, y_bottom)
    n = 2 * int(coils)
    swing = np.arange(n)
    frac = np.concatenate(([0.0, 0.1], 0.1 + 0.8 * (swing + 0.5) / n, [0.9, 1.0]))
    offset = np.concatenate(
        ([0.0, 0.0], np.where(swing % 2 == 0, -amplitude, amplitude), [0.0, 0.0])
    )
    draw_polyline(img, xc + offset, yt + frac * (yb - yt), color, width)


def draw_damper(
    img: np.ndarray,
    x: float,
    y_top: float,
    y_bottom: float,
    color: Color,
    half_width: float = 5,
    width: int = 2,
) -> None:
    """Vertical damper on the axis ``x``: open cylinder at ``y_bottom``, rod from ``y_top`` (px).

    The cylinder takes the lower 60 % of the length, the piston sits 40 % from the top.
    """
    _check_img(img)
    xc, yt, yb = _coords("draw_damper", x, y_top, y_bottom)
    y_mouth = yt + 0.4 * (yb - yt)
    y_rim = yt + 0.3 * (yb - yt)
    hw = float(half_width)
    # cylinder: left wall, bottom, right wall; rod; piston
    x0 = np.array([xc - hw, xc - hw, xc + hw, xc, xc - 0.7 * hw])
    y0 = np.array([y_rim, yb, yb, yt, y_mouth])
    x1 = np.array([xc - hw, xc + hw, xc + hw, xc, xc + 0.7 * hw])
    y1 = np.array([yb, yb, y_rim, y_mouth, y_mouth])
    _raster_segments(img, x0, y0, x1, y1, color, width)


def fill_circle(img: np.ndarray, cx: float, cy: float, r: float, color: Color) -> None:
    """Fill the pixels whose centres lie within ``r`` px of ``(cx, cy)``."""
    _check_img(img)
    x, y, rr = _coords("fill_circle", cx, cy, r)
    h, w = img.shape[:2]
    i0, i1 = max(math.floor(x - rr), 0), min(math.ceil(x + rr), w - 1)
    j0, j1 = max(math.floor(y - rr), 0), min(math.ceil(y + rr), h - 1)
    if i0 > i1 or j0 > j1:
        return
    u = np.arange(i0, i1 + 1) + 0.5 - x
    v = np.arange(j0, j1 + 1)[:, None] + 0.5 - y
    img[j0 : j1 + 1, i0 : i1 + 1][u * u + v * v <= rr * rr] = _rgb(color)


def fill_spans(
    img: np.ndarray, x: float, y_top: float, y_bottom: float, half_width: Any, color: Color
) -> None:
    """Fill, row by row, the span ``x +- half_width(s)`` with ``s`` in [0, 1] from top to bottom."""
    h, w = img.shape[:2]
    ya, yb = min(y_top, y_bottom), max(y_top, y_bottom)
    j0, j1 = max(math.ceil(ya - 0.5), 0), min(math.floor(yb - 0.5), h - 1)
    if j0 > j1 or yb <= ya:
        return
    rows = np.arange(j0, j1 + 1) + 0.5
    hw = half_width((rows - y_top) / (y_bottom - y_top))
    cols = np.arange(w) + 0.5
    mask = np.abs(cols[None, :] - x) <= hw[:, None]
    img[j0 : j1 + 1][mask] = _rgb(color)


def draw_box(
    img: np.ndarray,
    xc: float,
    yc: float,
    bw: float,
    bh: float,
    fill: Color,
    outline: Color,
    border: float = 2.0,
) -> None:
    """Filled box centred at ``(xc, yc)`` of ``bw`` x ``bh`` px with a ``border`` px outline."""
    fill_rect(img, xc - bw / 2, yc - bh / 2, xc + bw / 2, yc + bh / 2, outline)
    fill_rect(
        img,
        xc - bw / 2 + border,
        yc - bh / 2 + border,
        xc + bw / 2 - border,
        yc + bh / 2 - border,
        fill,
    )


def bar_columns(width: int) -> tuple[int, int]:
    """Columns ``(x0, x1)`` (px, edges) of the full-width bars of a frame ``width`` px wide:
    after the longest label (``time``, ``force``) to 4 px from the right edge."""
    x0 = _LABEL_X + max(text_width(label) for label in BAR_ROWS) + _LABEL_GAP
    return x0, max(int(width) - 4, x0 + 1)


def _bar_label(
    img: np.ndarray, text: str, x_end: float, rows: tuple[float, float], color: Color
) -> None:
    """``text`` ending ``_LABEL_GAP`` px left of column ``x_end``, centred on ``rows``."""
    y = 0.5 * (rows[0] + rows[1]) - 3.5  # the glyphs are 7 px high
    draw_text(img, x_end - _LABEL_GAP - text_width(text), y, text, color)


def draw_progress_bar(
    img: np.ndarray, frac: float, colors: Mapping[str, Color], text_color: Color
) -> None:
    """The progress bar along the top edge (rows :data:`BAR_ROWS` ``["time"]``, columns
    :func:`bar_columns`) filled to ``frac`` (clipped to [0, 1]), labelled ``time``."""
    rows = BAR_ROWS["time"]
    x0, x1 = bar_columns(img.shape[1])
    fill_rect(img, x0, rows[0], x1, rows[1], colors["bar_back"])
    fill_rect(
        img, x0, rows[0], x0 + min(max(frac, 0.0), 1.0) * (x1 - x0), rows[1], colors["bar_front"]
    )
    _bar_label(img, "time", x0, rows, text_color)


def draw_gauge(
    img: np.ndarray,
    centre: int,
    half: int,
    ratio: float,
    colors: Mapping[str, Color],
    label: str = "force",
) -> None:
    """An actuator gauge on the rows :data:`BAR_ROWS` ``["force"]``: a track of ``half`` px
    each side of the column edge ``centre`` with a 1 px zero mark, filled from it by
    ``ratio`` (force / f_max, clipped to [−1, 1]) of ``half``, to the right in
    ``actuator_push`` for a positive ratio, to the left in ``actuator_pull``; ``label`` left of
    the track (in ``outline``)."""
    rows = BAR_ROWS["force"]
    ratio = float(np.clip(ratio, -1.0, 1.0))
    fill_rect(img, centre - half, rows[0], centre + half, rows[1], colors["bar_back"])
    fill_rect(img, centre, rows[0] - 1, centre + 1, rows[1] + 1, colors["outline"])
    color = colors["actuator_push"] if ratio > 0 else colors["actuator_pull"]
    if ratio != 0.0:
        fill_rect(img, centre, rows[0], centre + ratio * half, rows[1], color)
    _bar_label(img, label, centre - half, rows, colors["outline"])


def draw_time_bar(
    img: np.ndarray, state: Mapping[str, Any], colors: Mapping[str, Color], text_color: Color
) -> None:
    """:func:`draw_progress_bar` of ``time / duration`` (``duration`` defaults to 10 s,
    wrapping); nothing without ``state["time"]``."""
    if "time" not in state:
        return
    t = state_scalar(state, "time")
    duration = state_scalar(state, "duration") if "duration" in state else 10.0
    if duration <= 0:
        raise ValueError(f"state['duration'] must be > 0 s, got {duration}")
    frac = min(t / duration, 1.0) if "duration" in state else (t % duration) / duration
    draw_progress_bar(img, frac, colors, text_color)


def draw_caption(
    img: np.ndarray, state: Mapping[str, Any], color: Color, exaggeration: float | None = None
) -> None:
    """One line of text below the progress bar with what ``state`` holds of: ``time`` (s),
    ``speed`` (m/s, printed in km/h), ``carbody_acc`` (m/s²) and the displacement
    ``exaggeration`` factor of the drawing."""
    parts = []
    if "time" in state:
        parts.append(f"t {state_scalar(state, 'time'):.3f} s")
    if "speed" in state:
        parts.append(f"v {3.6 * state_scalar(state, 'speed'):.0f} km/h")
    if "carbody_acc" in state:
        parts.append(f"a {state_scalar(state, 'carbody_acc'):+.2f} m/s2")
    if exaggeration is not None:
        parts.append(f"displ x{exaggeration:.0f}")
    scale = max(1, img.shape[0] // 300)
    draw_text(img, 6, 20, "   ".join(parts), color, scale)


# --------------------------------------------------------------------------- state access
def state_scalar(state: Mapping[str, Any], key: str) -> float:
    """``state[key]`` as a finite float (``ValueError`` naming ``key`` otherwise)."""
    if key not in state:
        raise ValueError(f"state is missing key '{key}'")
    try:
        v = float(state[key])
    except (TypeError, ValueError):
        raise ValueError(f"state['{key}'] must be a real number, got {state[key]!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"state['{key}'] must be finite, got {v}")
    return v


def state_vector(state: Mapping[str, Any], key: str, size: int | None = None) -> np.ndarray:
    """``state[key]`` as a finite non-empty 1-D float array, of ``size`` entries if given."""
    if key not in state:
        raise ValueError(f"state is missing key '{key}'")
    v = np.asarray(state[key], dtype=float)
    if v.ndim != 1 or v.size == 0:
        raise ValueError(f"state['{key}'] must be a non-empty 1-D array, got shape {v.shape}")
    if size is not None and v.size != size:
        raise ValueError(f"state['{key}'] must have {size} entries, got {v.size}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"state['{key}'] must be finite")
    return v


def check_frame_size(width: int, height: int) -> None:
    """``ValueError`` unless the frame is at least 16 x 16 px."""
    if int(width) < 16 or int(height) < 16:
        raise ValueError(f"width and height must be >= 16 px, got {width} x {height}")


def track_window(state: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """``track_x`` (strictly increasing, >= 2 points) and ``track_z`` of ``state``."""
    tx = state_vector(state, "track_x")
    tz = state_vector(state, "track_z", tx.size)
    if tx.size < 2 or np.any(np.diff(tx) <= 0):
        raise ValueError("state['track_x'] must be strictly increasing with >= 2 points")
    return tx, tz


def draw_track(
    img: np.ndarray,
    s: float,
    tx: np.ndarray,
    tz: np.ndarray,
    y_track0: float,
    k: float,
    col: Mapping[str, Color],
) -> None:
    """The track around position ``s`` (m) across the frame: ground below the profile
    (heights ``k`` px/m above the row ``y_track0``), its top 3 px drawn as the rail."""
    h, w = img.shape[:2]
    cols = np.arange(w) + 0.5
    track_pos = s + (cols - 0.5 * w) * (tx[-1] - tx[0]) / w
    y_prof = y_track0 - k * np.interp(track_pos, tx, tz)
    top = int(np.floor(np.clip(y_prof.min(), 0, h)))
    bottom = min(int(np.ceil(np.clip(y_prof.max(), 0, h))) + 3, h)
    _paint(img[bottom:], _rgb(col["ground"]))
    rows = np.arange(top, bottom)[:, None] + 0.5
    band = img[top:bottom]
    band[rows >= y_prof[None, :]] = col["ground"]
    band[(rows >= y_prof[None, :]) & (rows < y_prof[None, :] + 3)] = col["rail"]
