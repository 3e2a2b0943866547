"""``rgb_array`` frame of ``VerticalSuspension-v1``: the vertical 2-DOF vehicle (wheel on the
track, primary suspension, bogie, secondary air spring + damper + actuator, carbody), drawn
with the primitives of :mod:`railgym.envs.raster`. Track heights and displacements are drawn
at :data:`~railgym.envs.raster.DISPLACEMENT_PX_PER_M`, i.e. exaggerated x100 with respect to
the schematic vehicle scale of :data:`SCHEMATIC_PX_PER_M`. Horizontally the track window
``track_x`` spans the frame width."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from railgym.envs.raster import (
    DISPLACEMENT_PX_PER_M,
    REFERENCE_HEIGHT,
    VERTICAL_COLORS,
    Color,
    bar_columns,
    canvas,
    check_frame_size,
    draw_box,
    draw_caption,
    draw_damper,
    draw_gauge,
    draw_spring,
    draw_time_bar,
    draw_track,
    fill_circle,
    fill_rect,
    fill_spans,
    state_scalar,
    track_window,
)

__all__ = ["SCHEMATIC_PX_PER_M", "render_vertical"]

#: Schematic scale of the vertical vehicle's parts at a frame height of 400 px, px/m.
SCHEMATIC_PX_PER_M = 20.0


def _draw_secondary(
    img: np.ndarray,
    xc: float,
    body_bottom: float,
    bogie_top: float,
    force_ratio: float,
    col: Mapping[str, Color],
) -> None:
    """Secondary suspension between the carbody (row ``body_bottom``) and the bogie
    (``bogie_top``) centred at column ``xc``: air spring (two lobes), damper, and the actuator
    arrow and gauge (:func:`draw_gauge` under the progress bar, across the frame) of
    ``force_ratio`` = force / f_max."""
    h, w = img.shape[:2]
    ds = 0.10 * w
    lobe = 0.025 * w
    fill_spans(
        img,
        xc - ds,
        body_bottom,
        bogie_top,
        lambda u: lobe * (0.55 + 0.45 * np.abs(np.sin(2 * np.pi * u))),
        col["air_spring"],
    )
    draw_damper(img, xc + ds, body_bottom, bogie_top, col["damper"], 0.6 * lobe)
    ratio = float(np.clip(force_ratio, -1.0, 1.0))
    length = 0.45 * 0.14 * h * ratio
    arrow = col["actuator_push"] if ratio > 0 else col["actuator_pull"]
    x0, x1 = bar_columns(w)
    centre = (x0 + x1) // 2
    draw_gauge(img, centre, min(centre - x0, x1 - centre), ratio, col)
    if abs(length) >= 1.0:
        y_mid = 0.5 * (body_bottom + bogie_top)
        y_tip = y_mid - length
        head = min(0.4 * abs(length), 0.03 * h)
        y_neck = y_tip + math.copysign(head, length)
        fill_rect(img, xc - 2, y_mid, xc + 2, y_neck, arrow)
        fill_spans(img, xc, y_tip, y_neck, lambda u: 0.012 * w * u, arrow)


def render_vertical(state: Mapping[str, Any], width: int = 600, height: int = 400) -> np.ndarray:
    """Frame of the vertical vehicle model.

    Parameters
    ----------
    state : mapping with ``x1``, ``x2`` (bogie and carbody displacement, m, up positive),
        ``z`` (track height under the wheel, m), ``track_x`` (strictly increasing track
        positions around the vehicle, m), ``track_z`` (profile heights there, m),
        ``force_a`` (actuator force, N, positive pushes the carbody up) and ``f_max``
        (actuator force limit, N, > 0). Optional: ``s`` (vehicle position in ``track_x``, m;
        default the window's midpoint), ``time`` and ``duration`` (s, progress bar
        ``time / duration``; without ``duration`` the bar wraps every 10 s, without ``time``
        there is no bar), ``speed`` (m/s) and ``carbody_acc`` (m/s²), printed in the caption
        (:func:`draw_caption`) with the time and the displacement exaggeration factor.
    width, height : frame size, px.

    Returns
    -------
    ``(height, width, 3)`` uint8 image. The vehicle is centred horizontally; heights and
    displacements use :data:`DISPLACEMENT_PX_PER_M` x ``height / 400``. The actuator arrow
    points up for positive force, its length is ``|force_a| / f_max`` (capped at 1) of 45 %
    of the nominal secondary gap, green when pushing, red when pulling; a gauge labelled
    ``force`` below the progress bar (labelled ``time``) repeats ``force_a / f_max`` from its
    zero mark at the middle of the bar columns (:func:`bar_columns`; full scale: half their
    width).
    """
    check_frame_size(width, height)
    x1, x2, z = state_scalar(state, "x1"), state_scalar(state, "x2"), state_scalar(state, "z")
    force, f_max = state_scalar(state, "force_a"), state_scalar(state, "f_max")
    if f_max <= 0:
        raise ValueError(f"state['f_max'] must be > 0 N, got {f_max}")
    tx, tz = track_window(state)
    s = state_scalar(state, "s") if "s" in state else 0.5 * (tx[0] + tx[-1])
    col = VERTICAL_COLORS
    w, h = int(width), int(height)
    k = DISPLACEMENT_PX_PER_M * h / REFERENCE_HEIGHT
    img = canvas(w, h, col["background"])
    draw_time_bar(img, state, col, col["outline"])

    y_track0 = 0.82 * h
    draw_track(img, s, tx, tz, y_track0, k, col)

    # Geometry (px) at zero displacements, shifted by k * displacement.
    xc = 0.5 * w
    r_wheel = 0.045 * h
    y_wheel = y_track0 - k * z - r_wheel
    bogie_h, body_h = 0.06 * h, 0.22 * h
    y_bogie = y_track0 - r_wheel - 0.12 * h - 0.5 * bogie_h - k * x1
    y_body = y_track0 - r_wheel - 0.12 * h - bogie_h - 0.14 * h - 0.5 * body_h - k * x2
    bogie_bottom, bogie_top = y_bogie + 0.5 * bogie_h, y_bogie - 0.5 * bogie_h
    body_bottom = y_body + 0.5 * body_h

    # Primary suspension between axle and bogie, then the wheel and axle beam.
    dp, amp = 0.06 * w, 0.012 * w
    draw_spring(img, xc - dp, bogie_bottom, y_wheel, col["primary_spring"], 5, amp, 2)
    draw_damper(img, xc + dp, bogie_bottom, y_wheel, col["damper"], 0.9 * amp)
    fill_rect(img, xc - 1.3 * dp, y_wheel - 2, xc + 1.3 * dp, y_wheel + 2, col["wheel"])
    fill_circle(img, xc, y_wheel, r_wheel, col["wheel"])
    draw_box(img, xc, y_bogie, 0.30 * w, bogie_h, col["bogie"], col["outline"])

    _draw_secondary(img, xc, body_bottom, bogie_top, force / f_max, col)
    draw_box(img, xc, y_body, 0.80 * w, body_h, col["carbody"], col["outline"])
    draw_caption(img, state, col["outline"], DISPLACEMENT_PX_PER_M / SCHEMATIC_PX_PER_M)
    return img
