"""The one base of the env batches (the batch contract of :mod:`railgym.envs.base`).

:class:`ArrayBatch` owns what every batch shares: the reset of one row through
``reset_many``, copying (pickling) without the views and compiled entry points that
``_link`` makes again, the event flags, the reward terms, the noisy float32 observation and
the ``(reward, terminated, truncated, info)`` outcome of one row. A batch declares its
arrays: the reward ``reward`` (n,), the reward terms ``_terms`` (n, terms) named by
``REWARD_TERMS``, the observation ``obs`` (n, n_obs), the flags ``_flags``, the truncation
``_truncated`` (n,) and the actions ``actions`` (n, n_act).

:class:`TrackBatch` adds what the track batches (vertical, vehicle) share: the per-episode
track class, speed, seed or profile, the whole-episode or chunked track arrays (a batch
declares ``_track()``, ``_fill`` and ``_episode_track``) and the operating-envelope check.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numba
import numpy as np

__all__ = ["ArrayBatch", "TrackBatch", "draw_tracks", "noisy_obs"]


def draw_tracks(rows: np.ndarray, move: Callable[[int], None]) -> None:
    """``move(i)`` for each sub-env ``i`` in ``rows`` (draw its track: a reset's, or in
    chunked mode a window again), on numba's number of threads: a track is two inverse FFTs
    of the episode, during which numpy releases the GIL, and each call writes only its own
    rows, so the result does not depend on the threads."""
    threads = min(numba.get_num_threads(), len(rows))
    if threads <= 1:
        for i in rows:
            move(int(i))
        return
    with ThreadPoolExecutor(threads) as pool:
        for _ in pool.map(move, [int(i) for i in rows]):
            pass


def noisy_obs(
    obs: np.ndarray, noise: float, rngs: list[np.random.Generator], i: int | None = None
) -> np.ndarray:
    """The observations ``obs`` (n, n_obs) as float32 with Gaussian sensor noise of standard
    deviation ``noise`` (in units of the normalised channels) drawn from the per-env ``rngs``;
    with ``i`` row ``i`` alone (n_obs,), its noise from ``rngs[0]``."""
    rows = obs if i is None else obs[i]
    if noise > 0:
        draws = [g.standard_normal(obs.shape[1]) for g in rngs]
        rows = rows + noise * (np.stack(draws) if i is None else draws[0])
    return rows.astype(np.float32)


class ArrayBatch:
    """Base of a batch of ``n`` systems stepped by one compiled call (see the module
    docstring for what a subclass declares)."""

    n: int
    cfg: Any
    #: float64 (n, n_act) the actions of the next step
    actions: np.ndarray
    reward: np.ndarray
    obs: np.ndarray
    _terms: np.ndarray
    _truncated: np.ndarray
    _flags: dict[str, np.ndarray]
    _args: tuple
    _step: Any
    #: names of the reward terms, the columns of ``_terms``
    REWARD_TERMS: tuple[str, ...] = ()
    #: attributes made again by :meth:`_link` after a copy (views, compiled entry points)
    _VIEWS: tuple[str, ...] = ("_args", "_step")

    def _link(self) -> None:
        """Views, flags and the compiled entry point (made again after a copy)."""
        raise NotImplementedError

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k not in self._VIEWS}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._link()

    def reset(self, i: int, rng: np.random.Generator, episode: tuple) -> None:
        """:meth:`reset_many` of the one system ``i`` with its generator ``rng``."""
        self.reset_many(np.array([i]), [rng], episode)

    def reset_many(self, idx: np.ndarray, rngs: list[np.random.Generator], episode: tuple) -> None:
        """New episodes of the systems ``idx``, each drawn with its generator of ``rngs``."""
        raise NotImplementedError

    def advance(self) -> None:
        """One control step of every system with :attr:`actions` (one compiled call)."""
        self._step(*self._args)

    def flags(self) -> dict[str, np.ndarray]:
        """Events that end the episode, (n,) bool each."""
        return self._flags

    def truncated(self) -> np.ndarray:
        """True where the episode reached its duration."""
        return self._truncated

    def reward_terms(self, i: int | None = None) -> dict[str, Any]:
        """Weighted reward terms of system ``i`` (floats) or of all ((n,) arrays); they sum to
        the reward."""
        if i is not None:
            return dict(zip(self.REWARD_TERMS, self._terms[i].tolist(), strict=True))
        return {key: self._terms[:, j].copy() for j, key in enumerate(self.REWARD_TERMS)}

    def observe(self, rngs: list[np.random.Generator], i: int | None = None) -> np.ndarray:
        """Observations (n, n_obs) float32, plus the sensor noise of ``cfg.sensor_noise`` (none
        without one) drawn from the per-env ``rngs``; with ``i`` system ``i``'s (n_obs,), its
        noise from ``rngs[0]``."""
        noise = getattr(self.cfg, "sensor_noise", 0.0)
        if i is not None and noise == 0.0:  # the single env's step: one row, no draws
            return self.obs[i].astype(np.float32)
        return noisy_obs(self.obs, noise, rngs, i)

    def info(self, i: int | None = None) -> dict[str, Any]:
        """The ``info`` of system ``i`` (Python numbers, arrays) or of all (arrays)."""
        raise NotImplementedError

    def outcome(self, i: int) -> tuple[float, bool, bool, dict[str, Any]]:
        """``(reward, terminated, truncated, info)`` of system ``i`` as the single env's step
        returns them: ``info`` with ``reward_terms`` and each flag set this step."""
        info = self.info(i)
        info["reward_terms"] = self.reward_terms(i)
        terminated = False
        for k, v in self.flags().items():
            if v.item(i):  # a Python bool: no NumPy scalar made
                info[k] = terminated = True
        truncated = not terminated and bool(self.truncated().item(i))
        return float(self.reward.item(i)), terminated, truncated, info


class TrackBatch(ArrayBatch):
    """An :class:`ArrayBatch` of vehicles, each on its own track (vertical, vehicle)."""

    window: int | None
    n_samples: int
    _envelope_check: Any

    def _episodes(self, n: int) -> None:
        """The per-episode arrays of ``n`` vehicles: what a track is drawn from (the seed of
        each FRA episode, the profile of each measured one), its class and speed (m/s), and
        whether it runs a measured or user profile."""
        self._seeds = np.zeros(n, np.int64)
        self._profiles: list[Any] = [None] * n
        self.track_class = np.zeros(n, np.int64)
        self.speed = np.zeros(n)
        self.measured = np.zeros(n, np.bool_)

    def _set_episode(
        self, i: int, rng: np.random.Generator, track_class: int, speed: float, profile: Any
    ) -> None:
        """Vehicle ``i``'s episode: class, speed (m/s) and profile; an FRA episode's seed
        drawn from ``rng``."""
        self.track_class[i], self.speed[i] = track_class, speed
        self.measured[i] = profile is not None
        self._profiles[i] = profile
        self._seeds[i] = 0 if profile is not None else int(rng.integers(2**63 - 1))

    def _start(self, i: int, rng: np.random.Generator, episode: tuple) -> None:
        """Vehicle ``i``'s new episode from ``episode`` (its draws from ``rng``)."""
        raise NotImplementedError

    def reset_many(self, idx: np.ndarray, rngs: list[np.random.Generator], episode: tuple) -> None:
        """New episodes of the vehicles ``idx`` with their ``rngs``: drawn one after another,
        the tracks synthesised on numba's threads (each into its own rows, so the values are
        those of one reset after another), each vehicle at rest at its track's start."""
        for i, rng in zip(idx, rngs, strict=True):
            self._start(i, rng, episode)
        draw_tracks(idx, self._draw_track)
        for i in idx:
            self.reset_state(i)

    def reset_state(self, i: int) -> None:
        """Vehicle ``i`` at rest at the start of its track."""
        raise NotImplementedError

    def _track(self) -> tuple[np.ndarray, np.ndarray]:
        """The held track arrays ``(z, zdot)`` (n, held), m and m/s."""
        raise NotImplementedError

    def _fill(self, i: int, start: int) -> None:
        """Chunked mode: vehicle ``i``'s window from episode sample ``start`` on."""
        raise NotImplementedError

    def _episode_track(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Vehicle ``i``'s whole episode track ``(z, zdot)`` drawn from its seed or profile."""
        raise NotImplementedError

    def _cover_step(self) -> None:
        """Chunked mode: move the windows the next control step would run past."""
        raise NotImplementedError

    def _draw_track(self, i: int) -> None:
        """Vehicle ``i``'s track from its episode's seed or profile: the whole track, or in
        chunked mode its first window."""
        if self.window is None:
            z, zdot = self._track()
            z[i], zdot[i] = self._episode_track(i)
        else:
            self._fill(i, 0)

    def track_arrays(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Vehicle ``i``'s whole episode track ``(z, zdot)`` (m, m/s): copies of the held
        arrays, or in chunked mode drawn again."""
        if self.window is None:
            z, zdot = self._track()
            return z[i].copy(), zdot[i].copy()
        return self._episode_track(i)

    def _outside_envelope(self, i: int) -> bool:
        """Whether vehicle ``i``'s episode is outside the operating envelope; warns the first
        time."""
        return self._envelope_check(
            int(self.track_class[i]), float(self.speed[i]), bool(self.measured[i])
        )

    def advance(self) -> None:
        """One control step of every vehicle with :attr:`actions` (one compiled call; in
        chunked mode the windows the step would run past are moved first)."""
        if self.window is not None:
            self._cover_step()
        self._step(*self._args)
