"""``rgb_array`` frame of ``TrainCrash-v1``: cars running towards a rigid wall at ``+x``, drawn
to scale, with their crush zones shortened by the crush (primitives of
:mod:`railgym.envs.raster`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from railgym.envs.raster import (
    CRASH_COLORS,
    canvas,
    check_frame_size,
    draw_caption,
    draw_time_bar,
    fill_circle,
    fill_rect,
    state_scalar,
    state_vector,
)

__all__ = ["render_crash"]


def render_crash(state: Mapping[str, Any], width: int = 800, height: int = 300) -> np.ndarray:
    """Frame of a train running towards a rigid wall at ``+x``, drawn to scale.

    Parameters
    ----------
    state : mapping with ``positions`` (undeformed front-end position of each car, m; car 0
        leads), ``lengths`` (car lengths, m, > 0), ``crush`` (crush of each zone, m: zone 0 is
        the lead car's front at the wall, zone ``i`` the interface between car ``i - 1`` and
        car ``i``; negative values, i.e. open gaps, count as zero), ``stroke`` (available
        stroke of each zone, m, >= 0) and ``wall_x`` (wall face, m). Optional: ``view``
        (``(x_min, x_max)``, m, the horizontal window; default fits the train and the wall),
        ``time`` and ``duration`` (s, progress bar as in
        :func:`~railgym.envs.vertical.render.render_vertical`) and
        ``speed`` (m/s, of the lead car), printed in the caption (:func:`draw_caption`).
    width, height : frame size, px.

    Returns
    -------
    ``(height, width, 3)`` uint8 image. Zone ``i`` is drawn at the front of car ``i`` from
    ``positions[i] - stroke[i]`` to the deformed front ``positions[i] - crush[i]``; with crush
    beyond the stroke the front is drawn at ``positions[i] - crush[i]`` with a 3 px red zone.
    """
    check_frame_size(width, height)
    pos = state_vector(state, "positions")
    n = pos.size
    lengths = state_vector(state, "lengths", n)
    crush = np.maximum(state_vector(state, "crush", n), 0.0)
    stroke = state_vector(state, "stroke", n)
    wall_x = state_scalar(state, "wall_x")
    if np.any(lengths <= 0):
        raise ValueError("state['lengths'] must be > 0 m")
    if np.any(stroke < 0) or np.any(stroke > lengths):
        raise ValueError("state['stroke'] must lie in [0, lengths] m")
    if "view" in state:
        view = np.asarray(state["view"], dtype=float)
        if view.shape != (2,) or not np.all(np.isfinite(view)) or view[1] <= view[0]:
            raise ValueError("state['view'] must be (x_min, x_max) m with x_max > x_min")
        x_min, x_max = float(view[0]), float(view[1])
    else:
        x_min = float(min(np.min(pos - lengths), wall_x))
        x_max = float(max(np.max(pos), wall_x))
        margin = 0.05 * max(x_max - x_min, 1.0)
        x_min, x_max = x_min - margin, x_max + margin
    col = CRASH_COLORS
    w, h = int(width), int(height)
    sx = w / (x_max - x_min)

    def px(x: Any) -> Any:
        return (x - x_min) * sx

    img = canvas(w, h, col["background"])
    draw_time_bar(img, state, col, col["wall"])
    y_rail = 0.78 * h
    fill_rect(img, 0, y_rail, w, y_rail + 3, col["rail"])
    fill_rect(img, px(wall_x), 0.15 * h, px(wall_x) + 0.02 * w, y_rail + 3, col["wall"])

    r_wheel = 0.035 * h
    car_bottom = y_rail - 2 * r_wheel
    car_top = car_bottom - 0.30 * h
    for i in range(n):
        rear, front = pos[i] - lengths[i], pos[i] - crush[i]
        zone_start = pos[i] - stroke[i]
        fill_rect(img, px(rear), car_top, px(min(zone_start, front)), car_bottom, col["car"])
        if crush[i] > stroke[i]:
            fill_rect(img, px(front) - 3, car_top, px(front), car_bottom, col["zone_overloaded"])
        else:
            fill_rect(img, px(zone_start), car_top, px(front), car_bottom, col["zone"])
        for xw in (rear + 0.12 * lengths[i], pos[i] - 0.12 * lengths[i]):
            fill_circle(img, px(xw), y_rail - r_wheel, r_wheel, col["wheel"])
    draw_caption(img, state, col["wall"])
    return img
