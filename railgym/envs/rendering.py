"""Deprecated path of the rasteriser :mod:`railgym.envs.raster` and of the scenes
:func:`~railgym.envs.vertical.render.render_vertical` and
:func:`~railgym.envs.crash.render.render_crash`; kept for one version."""

from railgym.envs.crash.render import render_crash
from railgym.envs.raster import (
    BAR_ROWS,
    CRASH_COLORS,
    DISPLACEMENT_PX_PER_M,
    VERTICAL_COLORS,
    Color,
    bar_columns,
    canvas,
    draw_caption,
    draw_damper,
    draw_gauge,
    draw_line,
    draw_polyline,
    draw_progress_bar,
    draw_spring,
    fill_circle,
    fill_rect,
)
from railgym.envs.vertical.render import (
    SCHEMATIC_PX_PER_M,
    render_vertical,
)

__all__ = [
    "BAR_ROWS",
    "CRASH_COLORS",
    "Color",
    "DISPLACEMENT_PX_PER_M",
    "SCHEMATIC_PX_PER_M",
    "VERTICAL_COLORS",
    "bar_columns",
    "canvas",
    "draw_caption",
    "draw_damper",
    "draw_gauge",
    "draw_line",
    "draw_polyline",
    "draw_progress_bar",
    "draw_spring",
    "fill_circle",
    "fill_rect",
    "render_crash",
    "render_vertical",
]
