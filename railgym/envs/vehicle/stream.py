"""The streaming batch of ``VerticalVehicle-v3``: each vehicle's track generated inside the
compiled step (:mod:`railgym.track_stream`) and its comfort figures accumulated online
(:mod:`railgym.envs.vehicle.online_comfort`); memory per vehicle independent of the
episode's length.

:class:`VehicleStreamBatch` is :class:`~railgym.envs.vehicle.batch.VehicleBatch` with the
track arrays replaced by a window on the rear wheelset's time grid: before the kernel runs,
:func:`stream_step` makes each window hold the samples from the rear wheelset's ``k`` to the
front wheelset's position at the end of the step (the rear bogie's track is the front's past,
held in the same window; a window holds twice that span, so it slides once every span). A
measured or user profile is read as in the earlier versions (its whole episode held while it is
ridden) and copied into the window a step at a time.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from railgym import _checks as val
from railgym.envs.compiled import compiled_entry
from railgym.envs.track_shell import TRACK_BYTES
from railgym.envs.vehicle.batch import MIN_COMFORT_SAMPLES, VehicleBatch, control_step
from railgym.envs.vehicle.online_comfort import comfort_figures, comfort_step, new_comfort
from railgym.profile import profile_time_input
from railgym.track_stream import (
    new_stream_state,
    set_stream,
    stream_cover,
    stream_filter,
    stream_start,
)
from railgym.vehicles.vertical.kernels import PARALLEL_MIN

__all__ = ["VehicleStreamBatch", "stream_step"]


@njit(cache=True, _nrt=False)
def _fill(gen, v, end, n_sub, i):
    """Vehicle ``i``'s window (``v``: the kernel's
    :class:`~railgym.vehicles.vehicle.VehicleArrays`) holding its samples from ``k`` to the
    front wheelset's at the end of the step (``n_sub`` samples on), the new ones generated."""
    k = v.k[i]
    hi = int(math.floor(k + n_sub + v.off[i, 0])) + 2
    stream_cover(gen, i, v.z, v.zdot, v.start, end, k, hi)


@njit(cache=True, parallel=True)
def _fill_parallel(gen, v, end, measured, n_sub):
    for i in prange(v.z.shape[0]):
        if not measured[i]:
            _fill(gen, v, end, n_sub, i)


@njit(cache=True, error_model="numpy", _nrt=False)
def stream_step(
    gen,
    end,
    measured,
    comfort,
    comfort_cfg,
    kind,
    v,
    params,
    element,
    lpr,
    out,
    book,
    consts,
    damper,
):
    """The windows of every vehicle not on a measured profile filled for the step (on all
    threads from ``PARALLEL_MIN`` vehicles; each stream is its own, so the values do not
    depend on the threads), :func:`~railgym.envs.vehicle.batch.control_step` (arguments as
    there), then the online comfort figures."""
    n = v.z.shape[0]
    if n >= PARALLEL_MIN:
        _fill_parallel(gen, v, end, measured, consts.n_sub)
    else:
        for i in range(n):
            if not measured[i]:
                _fill(gen, v, end, consts.n_sub, i)
    control_step(kind, v, params, element, lpr, out, book, consts, damper)
    for i in range(n):
        comfort_step(comfort, comfort_cfg, out.acc, book.steps, i)


@njit(cache=True)
def _start_track(gen, v, end, i, chol):
    """Vehicle ``i``'s stream started (stationary state), its window cleared and the samples
    of its first observation generated."""
    stream_start(gen, i, chol)
    v.start[i] = end[i] = v.k[i] = 0
    _fill(gen, v, end, 0, i)


class VehicleStreamBatch(VehicleBatch):
    """:class:`~railgym.envs.vehicle.batch.VehicleBatch` on streamed track with online
    comfort figures (the module's docstring); ``track_arrays(i)`` returns the held window."""

    def _storage(self, n: int, sos: np.ndarray, rows: int) -> tuple[int, int, type]:
        cfg = self.cfg
        self.window = None
        self.gen = new_stream_state(n)
        #: int64 (n,) episode samples held up to (exclusive)
        self.end = np.zeros(n, np.int64)
        #: bool (n,) a measured profile: the window is filled by the batch
        self.on_profile = np.zeros(n, np.bool_)
        self.online, self.online_cfg = new_comfort(n, cfg.control_dt, cfg.duration)
        self._measured_tracks: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        width = 2 * (self.reach + cfg.n_sub + 4)
        if 16 * width * n > TRACK_BYTES:
            raise val.FieldError(
                "num_envs",
                f"of {n} needs {16 * width * n / 2**30:.2f} GiB of track windows ({width} "
                f"samples each: twice the wheelset span at {self.v_min:g} m/s), over the "
                f"{TRACK_BYTES / 2**30:g} GiB limit: use fewer sub-envs or a higher lowest speed",
            )
        return width, 0, np.float64

    def _link(self) -> None:
        super()._link()
        extra = (self.gen, self.end, self.on_profile, self.online, self.online_cfg)
        self._args = (*extra, *self._args)
        self._step = compiled_entry(stream_step, self._args)

    def _draw_track(self, i: int) -> None:
        """Nothing: :meth:`reset_state` starts the episode's stream (or reads its profile)."""

    def reset_state(self, i: int) -> None:
        """Vehicle ``i`` at rest at the start of its episode's track (the stream started
        again from its seed), its comfort figures cleared."""
        cfg, v = self.cfg, self.arrays
        speed = float(self.speed[i])
        profile = self._profiles[i]
        self.on_profile[i] = profile is not None
        for a in self.online:
            a[i] = 0.0
        if profile is not None:
            length = speed * cfg.n_steps * cfg.control_dt + self.span
            self._measured_tracks[i] = profile_time_input(
                profile, speed, cfg.dt, self.n_samples, length=length
            )
            v.k[i] = v.start[i] = self.end[i] = 0
            self._copy_measured(i)
        else:
            self._measured_tracks.pop(i, None)
            f = stream_filter(int(self.track_class[i]), cfg.band, speed * cfg.dt)
            rows = np.array([i])
            set_stream(self.gen, rows, f, speed, self._seeds[rows])
            _start_track(self.gen, v, self.end, i, f.chol)
        super().reset_state(i)

    def _copy_measured(self, i: int) -> None:
        """Vehicle ``i``'s window on its measured profile from its current sample ``k`` on."""
        z, zdot = self._measured_tracks[i]
        v = self.arrays
        k = int(v.k[i])
        m = min(v.z.shape[1], z.shape[0] - k)
        v.z[i, :m], v.zdot[i, :m] = z[k : k + m], zdot[k : k + m]
        v.start[i], self.end[i] = k, k + m

    def advance(self) -> None:
        """One control step of every vehicle (one compiled call: the windows filled, the
        kernel, the comfort figures); windows on measured profiles copied first."""
        if self._measured_tracks:
            for i in self._measured_tracks:
                self._copy_measured(i)
        self._step(*self._args)
        np.greater(self._outside_count, 0, out=self.outside)

    def comfort(self, i: int) -> dict[str, np.ndarray]:
        """The online comfort figures of vehicle ``i`` so far (zeros below
        :data:`~railgym.envs.vehicle.batch.MIN_COMFORT_SAMPLES` steps)."""
        steps = int(self.book.steps[i])
        return comfort_figures(self.online, self.online_cfg, i, steps, MIN_COMFORT_SAMPLES)

    def track_arrays(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Vehicle ``i``'s held window ``(z, zdot)`` (m, m/s) from the rear wheelset on."""
        v = self.arrays
        a, b = int(v.k[i] - v.start[i]), int(self.end[i] - v.start[i])
        return v.z[i, a:b].copy(), v.zdot[i, a:b].copy()

    def _render_track(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        v = self.arrays
        m = int(self.end[i] - v.start[i])
        return v.z[i, :m], np.arange(v.start[i], self.end[i])
