"""``rgb_array`` frame of ``VerticalVehicle-v1``: bending carbody, two pitching bogies, four
wheelsets on the track profile (primitives of :mod:`railgym.envs.raster`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from railgym.envs.raster import (
    DISPLACEMENT_PX_PER_M,
    VERTICAL_COLORS,
    canvas,
    draw_caption,
    draw_gauge,
    draw_line,
    draw_polyline,
    draw_progress_bar,
    draw_spring,
    fill_circle,
)

_KEYS = (
    "track_x",
    "track_z",
    "body_x",
    "body_z",
    "bogie_x",
    "bogie_z",
    "bogie_pitch",
    "wheel_x",
    "wheel_z",
    "force",
    "f_max",
)


def render_vehicle(state: Mapping[str, Any], width: int = 800, height: int = 400) -> np.ndarray:
    """Frame ``(height, width, 3)`` uint8 of the whole vehicle.

    ``state`` (from ``VehicleBatch.render_state``): positions from the carbody centre (m)
    ``track_x`` (increasing, spans the frame), ``body_x``, ``bogie_x`` (2,), ``wheel_x`` (4,);
    heights (m, up) ``track_z``, ``body_z`` (carbody floor line, bending and pitch
    included), ``bogie_z`` (2,), ``wheel_z`` (4,); ``bogie_pitch`` (2,) rad; actuator
    ``force`` (2,) N and ``f_max`` N; optional ``time`` and ``duration`` s (progress bar),
    ``speed`` m/s and ``carbody_acc`` m/s² (centre floor point), printed in the caption with
    the time and the exaggeration of heights over lengths.
    Horizontal scale: ``track_x`` over the width; heights and displacements at
    ``DISPLACEMENT_PX_PER_M · height/400`` (exaggerated), each part drawn at its nominal
    height plus its displacement. The progress bar (labelled ``time``) along the top; under it
    an actuator gauge centred above each bogie (labelled ``front force``, ``rear force``:
    the bogie at the larger position is the front), filled from its zero mark by
    ``force/f_max`` of its half-width (8 % of the frame width), green to the right pushing the
    carbody up, red to the left pulling (:func:`~railgym.envs.raster.draw_gauge`).
    """
    arr = _state_arrays(state, width, height)
    w, h = int(width), int(height)
    col = VERTICAL_COLORS
    tx = arr["track_x"]
    r_wheel = 0.04 * h
    y_rail = 0.85 * h
    y_bogie0 = y_rail - 2 * r_wheel - 0.08 * h
    k = DISPLACEMENT_PX_PER_M * h / 400.0
    g = _Geometry(tx[0], w / (tx[-1] - tx[0]), k, y_bogie0, y_bogie0 - 0.14 * h)
    img = canvas(w, h, col["background"])
    if "time" in state and "duration" in state and float(state["duration"]) > 0:
        frac = float(state["time"]) / float(state["duration"])
        draw_progress_bar(img, frac, col, col["outline"])

    # track: ground under the exaggerated profile, rail on top
    cols = np.arange(w) + 0.5
    y_prof = y_rail - g.k * np.interp(tx[0] + cols / g.sx, tx, arr["track_z"])
    rows = np.arange(h)[:, None] + 0.5
    img[rows >= y_prof[None, :]] = col["ground"]
    img[(rows >= y_prof[None, :]) & (rows < y_prof[None, :] + 3)] = col["rail"]

    _draw_running_gear(img, arr, g, y_rail, r_wheel)
    _draw_carbody(img, arr, g)
    _draw_secondaries(img, arr, g)
    draw_caption(img, state, col["outline"], g.k / g.sx)  # vertical over horizontal scale
    return img


class _Geometry(NamedTuple):
    """Scales of a frame: lengths ``sx`` px/m from ``x0``, heights ``k`` px/m (exaggerated);
    rows of the bogies (``y_bogie0``) and of the carbody floor at zero displacement."""

    x0: float
    sx: float
    k: float
    y_bogie0: float
    y_floor0: float

    def px(self, x: Any) -> Any:
        """Column of the position ``x`` (m)."""
        return (np.asarray(x) - self.x0) * self.sx


def _state_arrays(state: Mapping[str, Any], width: int, height: int) -> dict[str, np.ndarray]:
    """The keys of :data:`_KEYS` as finite float arrays; the frame at least 64 px."""
    for key in _KEYS:
        if key not in state:
            raise ValueError(f"render state is missing {key!r}")
    arr = {k: np.asarray(state[k], dtype=float) for k in _KEYS}
    for k, v in arr.items():
        if not np.all(np.isfinite(v)):
            raise ValueError(f"render state {k!r} must be finite")
    if int(width) < 64 or int(height) < 64:
        raise ValueError(f"width and height must be >= 64 px, got {width} x {height}")
    return arr


def _draw_running_gear(
    img: np.ndarray, arr: dict[str, np.ndarray], g: _Geometry, y_rail: float, r_wheel: float
) -> None:
    """Wheels on the rail with their primary springs, and the pitched bogie frames."""
    col = VERTICAL_COLORS
    k = g.k
    for j, (xw, zw) in enumerate(zip(g.px(arr["wheel_x"]), arr["wheel_z"], strict=True)):
        yw = y_rail - r_wheel - k * zw
        fill_circle(img, xw, yw, r_wheel, col["wheel"])
        i = j // 2
        e = 1.0 if j % 2 == 0 else -1.0
        xb_m = arr["wheel_x"][j] - arr["bogie_x"][i]
        yb = g.y_bogie0 - k * (arr["bogie_z"][i] + xb_m * arr["bogie_pitch"][i])
        draw_spring(
            img, xw - 0.15 * e * r_wheel, yb, yw, col["primary_spring"], 4, 0.25 * r_wheel, 2
        )
    # bogie frames: beams through the wheelset points, pitched
    h = img.shape[0]
    b = 0.5 * abs(arr["wheel_x"][0] - arr["wheel_x"][1])
    for i in range(2):
        xs = arr["bogie_x"][i] + np.array([-1.3 * b, 1.3 * b])
        ys = g.y_bogie0 - k * (arr["bogie_z"][i] + (xs - arr["bogie_x"][i]) * arr["bogie_pitch"][i])
        draw_polyline(img, g.px(xs), ys, col["bogie"], int(0.035 * h))


def _draw_carbody(img: np.ndarray, arr: dict[str, np.ndarray], g: _Geometry) -> None:
    """The carbody: a band above its (bent, pitched) floor line."""
    col = VERTICAL_COLORS
    h, w = img.shape[:2]
    cols = np.arange(w) + 0.5
    rows = np.arange(h)[:, None] + 0.5
    bx = arr["body_x"]
    floor = g.y_floor0 - g.k * np.interp(g.x0 + cols / g.sx, bx, arr["body_z"])
    inside = (g.x0 + cols / g.sx >= bx[0]) & (g.x0 + cols / g.sx <= bx[-1])
    body_h = 0.3 * h
    mask = inside[None, :] & (rows <= floor[None, :]) & (rows >= floor[None, :] - body_h)
    img[mask] = col["carbody"]
    draw_polyline(img, g.px(bx), g.y_floor0 - g.k * arr["body_z"], col["outline"], 2)


def _draw_secondaries(img: np.ndarray, arr: dict[str, np.ndarray], g: _Geometry) -> None:
    """Secondary suspension (air spring, damper) at each bogie and its actuator gauge above."""
    col = VERTICAL_COLORS
    h, w = img.shape[:2]
    bx = arr["body_x"]
    f_max = float(arr["f_max"])
    front = int(np.argmax(arr["bogie_x"]))
    for i in range(2):
        xb = float(g.px(arr["bogie_x"][i]))
        yb = g.y_bogie0 - g.k * arr["bogie_z"][i] - 0.02 * h
        yf = g.y_floor0 - g.k * np.interp(arr["bogie_x"][i], bx, arr["body_z"])
        draw_spring(img, xb - 0.02 * w, yf, yb, col["air_spring"], 3, 0.01 * w, 2)
        ratio = float(np.clip(arr["force"][i] / f_max, -1.0, 1.0)) if f_max > 0 else 0.0
        draw_line(img, xb + 0.02 * w, yb, xb + 0.02 * w, yf, col["damper"], 2)
        label = "front force" if i == front else "rear force"
        draw_gauge(img, round(xb), round(0.08 * w), ratio, col, label)
