"""Deprecated path of the rasteriser :mod:`railgym.envs.raster` and of the scenes
:func:`~railgym.envs.vertical.render.render_vertical` and
:func:`~railgym.envs.crash.render.render_crash`; kept for one version."""

from railgym.envs import raster
from railgym.envs.crash import render as crash_render
from railgym.envs.crash.render import *  # noqa: F403
from railgym.envs.raster import *  # noqa: F403
from railgym.envs.vertical import render as vertical_render
from railgym.envs.vertical.render import *  # noqa: F403

__all__ = [*raster.__all__, *vertical_render.__all__, *crash_render.__all__]
