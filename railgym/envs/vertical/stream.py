"""The streaming batch of ``VerticalSuspension-v3``: each vehicle's track generated inside the
compiled step, a control step at a time (:mod:`railgym.track_stream`), in a window of a few
control steps; memory per vehicle independent of the episode's length.

:class:`VerticalStreamBatch` is :class:`~railgym.envs.vertical.batch.VerticalBatch` with the
track arrays replaced by windows: before the kernel runs, :func:`stream_step` makes each
window hold the samples ``k .. k + n_sub`` of the step (``k`` its index into the window).
With ``wheelbase`` the leading wheelset's raw track is generated ahead into a second window and
the input is the mean of the two wheelsets' heights, the trailing one's a cubic Hermite value
between raw samples (:func:`~railgym.vehicles.vehicle.lanes.hermite`). A measured or user
profile is read as in the earlier versions (its whole episode held while it is ridden) and
copied into the window a step at a time.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit, prange

from railgym import _checks as val
from railgym.envs.compiled import compiled_entry
from railgym.envs.track_shell import TRACK_BYTES
from railgym.envs.vertical.batch import VerticalBatch, control_step
from railgym.profile import profile_time_input
from railgym.track_stream import (
    new_stream_state,
    seed_stream,
    set_stream,
    slide_window,
    stream_cover,
    stream_filter,
    stream_start,
)
from railgym.vehicles.vehicle.lanes import hermite
from railgym.vehicles.vertical.kernels import PARALLEL_MIN

__all__ = ["StreamArrays", "VerticalStreamBatch", "stream_step", "window_width"]


class StreamArrays(NamedTuple):
    """Per-vehicle windows of :func:`stream_step` (``n`` vehicles; their streams, of the
    leading wheelset's track, a :class:`~railgym.track_stream.StreamState`)."""

    start: np.ndarray  #: int64 (n,) episode sample of the input window's first column
    end: np.ndarray  #: int64 (n,) episode samples held up to (exclusive)
    measured: np.ndarray  #: bool (n,) a measured profile: the window is filled by the batch
    shift: np.ndarray  #: float64 (n,) wheelbase in samples (0: no wheelbase)
    raw_z: np.ndarray  #: float64 (n, R) leading wheelset's raw track, m (R = 1 unused)
    raw_zd: np.ndarray  #: float64 (n, R) its rate, m/s
    raw_start: np.ndarray  #: int64 (n,)
    raw_end: np.ndarray  #: int64 (n,)


def window_width(n_sub: int) -> int:
    """Columns of the input window: four control steps' samples (a slide every third step)."""
    return 4 * (n_sub + 1)


@njit(cache=True, _nrt=False)
def _fill(gen, g, z, zd, k, n_sub, dt, i):
    """Vehicle ``i``'s window holding its samples ``e .. e + n_sub`` (``e``: episode sample
    of ``k[i]``), the new ones generated; ``k[i]`` then indexes sample ``e``."""
    e = g.start[i] + k[i]
    hi = e + n_sub + 1
    d = g.shift[i]
    if d == 0.0:
        stream_cover(gen, i, z, zd, g.start, g.end, e, hi)
    else:
        slide_window(z, zd, g.start, g.end, i, e, hi)
        rhi = int(math.floor(hi - 1 + d)) + 2
        rz, rzd, rs = g.raw_z, g.raw_zd, g.raw_start
        stream_cover(gen, i, rz, rzd, rs, g.raw_end, e, rhi)
        s = g.start[i]
        for j in range(g.end[i], hi):
            zl, zdl = hermite(rz[i], rzd[i], j + d, dt, rs[i])
            z[i, j - s] = 0.5 * (rz[i, j - rs[i]] + zl)
            zd[i, j - s] = 0.5 * (rzd[i, j - rs[i]] + zdl)
        g.end[i] = max(g.end[i], hi)
    k[i] = e - g.start[i]


@njit(cache=True, parallel=True)
def _fill_parallel(gen, g, z, zd, k, n_sub, dt):
    for i in prange(z.shape[0]):
        if not g.measured[i]:
            _fill(gen, g, z, zd, k, n_sub, dt, i)


@njit(cache=True, _nrt=False)
def fill_windows(gen, g, z, zd, k, n_sub, dt):
    """:func:`_fill` of every vehicle not on a measured profile (on all threads from
    ``PARALLEL_MIN`` vehicles; each vehicle's stream is its own, so the values do not depend
    on the threads)."""
    if z.shape[0] >= PARALLEL_MIN:
        _fill_parallel(gen, g, z, zd, k, n_sub, dt)
        return
    for i in range(z.shape[0]):
        if not g.measured[i]:
            _fill(gen, g, z, zd, k, n_sub, dt, i)


@njit(cache=True, _nrt=False)
def stream_step(
    gen, g, state, z, zdot, action, force, params, lpr, damper, out, counters, result, consts, work
):
    """:func:`fill_windows` for the step, then
    :func:`~railgym.envs.vertical.batch.control_step` (arguments as there)."""
    fill_windows(gen, g, z, zdot, counters.k, consts.n_sub, consts.dt)
    control_step(
        state, z, zdot, action, force, params, lpr, damper, out, counters, result, consts, work
    )


@njit(cache=True)
def _start_track(gen, g, z, zd, k, dt, i, chol):
    """Vehicle ``i``'s stream started (stationary state), its window cleared and sample 0
    generated."""
    stream_start(gen, i, chol)
    g.start[i] = g.end[i] = g.raw_start[i] = g.raw_end[i] = 0
    k[i] = 0
    _fill(gen, g, z, zd, k, 0, dt, i)


class VerticalStreamBatch(VerticalBatch):
    """:class:`~railgym.envs.vertical.batch.VerticalBatch` on streamed track (the module's
    docstring); ``track_arrays(i)`` returns the held window."""

    def _track_storage(self, n: int) -> None:
        cfg = self.cfg
        self.window = None
        w = window_width(cfg.n_sub)
        self.z, self.zdot = np.zeros((n, w)), np.zeros((n, w))
        self.base = np.zeros(n, np.int64)
        self._measured_tracks: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.gen = new_stream_state(n)
        self.win = self._new_arrays(n, 1)

    def _new_arrays(self, n: int, raw: int) -> StreamArrays:
        """Zeroed :class:`StreamArrays` of ``n`` vehicles with raw windows of ``raw``
        columns."""
        f = np.zeros
        ints = [f(n, np.int64) for _ in range(4)]
        return StreamArrays(
            *ints[:2],
            f(n, np.bool_),
            f(n),
            f((n, raw)),
            f((n, raw)),
            *ints[2:],
        )

    def _link(self) -> None:
        super()._link()
        self._args = (self.gen, self.win, *self._args)
        self._step = compiled_entry(stream_step, self._args)

    def _raw_columns(self, speed: float) -> int:
        """Columns of the raw window for ``speed`` (m/s): twice the leading wheelset's reach
        over a step; 1 without a wheelbase."""
        cfg = self.cfg
        if cfg.wheelbase is None:
            return 1
        return 2 * (math.ceil(cfg.wheelbase / (speed * cfg.dt)) + cfg.n_sub + 4)

    def reset_many(
        self, idx: np.ndarray, rngs: list[np.random.Generator], episode: tuple[int, float, Any]
    ) -> None:
        """:meth:`VerticalBatch.reset_many` with streamed tracks: each FRA episode's stream
        seeded from ``rng`` as the earlier versions seed their tracks."""
        track_class, speed, profile = episode
        cfg, g = self.cfg, self.win
        raw = self._raw_columns(speed)
        if raw > g.raw_z.shape[1]:  # a lower speed than any before: wider raw windows
            if 16 * raw * self.n > TRACK_BYTES:
                raise val.FieldError(
                    "speed",
                    f"{speed:g} m/s needs windows of {raw} samples ahead of the trailing "
                    f"wheelset (wheelbase {cfg.wheelbase:g} m, dt {cfg.dt:g} s), "
                    f"{16 * raw * self.n / 2**30:.2f} GiB for {self.n} sub-envs, over the "
                    f"{TRACK_BYTES / 2**30:g} GiB limit: raise the speed or use fewer sub-envs",
                )
            self.win = g = g._replace(raw_z=np.zeros((self.n, raw)), raw_zd=np.zeros((self.n, raw)))
            self._link()
        for i, rng in zip(idx, rngs, strict=True):
            self.track_class[i], self.speed[i] = track_class, speed
            self.measured[i] = g.measured[i] = profile is not None
            self._seeds[i] = 0 if profile is not None else int(rng.integers(2**63 - 1))
            self._profiles[i] = profile
            self._measured_tracks.pop(int(i), None)
        if profile is None:
            f = stream_filter(track_class, cfg.band, speed * cfg.dt)
            set_stream(self.gen, idx, f, speed, self._seeds[idx])
            g.shift[idx] = 0.0 if cfg.wheelbase is None else cfg.wheelbase / (speed * cfg.dt)
        for i in idx:
            self.reset_state(int(i))

    def reset_state(self, i: int) -> None:
        """Vehicle ``i`` at rest at the start of its episode's track (the stream started
        again from its seed)."""
        g, cfg = self.win, self.cfg
        if self._profiles[i] is not None:
            z, zdot = profile_time_input(self._profiles[i], self.speed[i], cfg.dt, self.n_samples)
            self._measured_tracks[i] = (z, zdot)
            g.start[i] = g.end[i] = self.k[i] = 0
            self._copy_measured(i)
        else:
            self.gen.rng[i] = seed_stream(self._seeds[i])
            f = stream_filter(int(self.track_class[i]), cfg.band, self.speed[i] * cfg.dt)
            _start_track(self.gen, g, self.z, self.zdot, self.k, cfg.dt, i, f.chol)
        super().reset_state(i)

    def _copy_measured(self, i: int) -> None:
        """Vehicle ``i``'s window on its measured profile: samples ``e .. e + n_sub``."""
        z, zdot = self._measured_tracks[i]
        e = int(self.win.start[i] + self.k[i])
        m = min(self.z.shape[1], z.shape[0] - e)
        self.z[i, :m], self.zdot[i, :m] = z[e : e + m], zdot[e : e + m]
        self.win.start[i], self.win.end[i], self.k[i] = e, e + m, 0

    def advance(self) -> None:
        """One control step of every vehicle (one compiled call: the windows filled, then the
        kernel); windows on measured profiles copied first."""
        if self._measured_tracks:
            for i in self._measured_tracks:
                self._copy_measured(i)
        self._step(*self._args)

    def track_arrays(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Vehicle ``i``'s held window ``(z, zdot)`` (m, m/s), from the current sample on."""
        k, end = int(self.k[i]), int(self.win.end[i] - self.win.start[i])
        return self.z[i, k:end].copy(), self.zdot[i, k:end].copy()

    def copy_track(self, src: VerticalBatch) -> None:
        """Vehicle 0's episode set to ``src``'s vehicle 0's (the same class, speed and seed or
        profile: the same track), at rest at its start."""
        if not isinstance(src, VerticalStreamBatch):
            raise ValueError("the other env must stream its track too (both -v3)")
        s, g = src.win, self.win
        self.track_class[0], self.speed[0] = src.track_class[0], src.speed[0]
        self.measured[0] = g.measured[0] = src.measured[0]
        self._seeds[0], self._profiles[0] = src._seeds[0], src._profiles[0]
        for a, b in zip((*self.gen[2:], g.shift), (*src.gen[2:], s.shift), strict=True):
            a[0] = b[0]
        self.reset_state(0)

    def render_state(self, i: int) -> dict[str, Any]:
        """As :meth:`VerticalBatch.render_state`, the track drawn from the held window."""
        return self._render(i, self.track_arrays(i)[0], 0)
