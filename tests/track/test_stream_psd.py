"""The streamed FRA track (railgym.track_stream) has the class's PSD: a Welch estimate of a
long generated profile, independent of the generator's design, lies within ±1.5 dB of
railgym.track.fra_psd over the band (classes 1-6); the normals are standard normal and the
track is stationary from its first sample."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit
from scipy import signal, stats

from railgym.track import fra_psd
from railgym.track_stream import _normal, stream_filter, stream_profile, stream_psd

BAND = (1.0, 100.0)
#: the Welch estimate's band: the FRA band's wavenumbers 2π/100 .. 2π/1 rad/m
OMEGA_BAND = (2.0 * math.pi / BAND[1], 2.0 * math.pi / BAND[0])


def _welch_db(z: np.ndarray, dx: float, track_class: int) -> tuple[np.ndarray, np.ndarray]:
    """Welch PSD (one-sided, m²/(rad/m)) of ``z`` over the band, in dB re the class PSD:
    segments of 2 km (Hann, 50 % overlap, ~1 000 of them: the estimate's own scatter is
    about ±0.15 dB per bin)."""
    nper = int(round(2000.0 / dx))
    f, p = signal.welch(z, fs=1.0 / dx, nperseg=nper, detrend=False)
    omega, g = 2.0 * math.pi * f[1:], p[1:] / (2.0 * math.pi)
    inside = (omega >= OMEGA_BAND[0]) & (omega <= OMEGA_BAND[1])
    return omega[inside], 10.0 * np.log10(g[inside] / fra_psd(omega[inside], track_class))


@pytest.mark.parametrize("track_class", [1, 2, 3, 4, 5, 6])
def test_welch_psd_of_a_long_streamed_profile_is_the_class_psd(track_class: int) -> None:
    dx = 0.25
    _, z, _ = stream_profile(track_class, 1_000_000.0, dx, 100 + track_class, BAND)
    omega, db = _welch_db(z, dx, track_class)
    assert omega.size > 1000
    assert np.all(np.abs(db) < 1.5), (db.min(), db.max())
    # and within the design's own edge losses away from the edges
    middle = (omega > 3 * OMEGA_BAND[0]) & (omega < OMEGA_BAND[1] / 3)
    assert np.all(np.abs(db[middle]) < 0.8)


def test_psd_at_the_env_grid_and_the_slope() -> None:
    """At the grid of the default env (class 5, 40 m/s, 1 ms: 4 cm) the height's PSD holds,
    and the slope's PSD is Ω²·G (its samples are the exact derivative, not differences)."""
    dx = 0.04
    _, z, s = stream_profile(5, 200_000.0, dx, 9, BAND)
    _, db = _welch_db(z, dx, 5)
    assert np.all(np.abs(db) < 1.5)
    nper = int(round(500.0 / dx))
    f, p = signal.welch(s, fs=1.0 / dx, nperseg=nper, detrend=False)
    omega = 2.0 * math.pi * f[1:]
    inside = (omega >= OMEGA_BAND[0]) & (omega <= OMEGA_BAND[1])
    g = p[1:][inside] / (2.0 * math.pi)
    want = omega[inside] ** 2 * fra_psd(omega[inside], 5)
    assert np.all(np.abs(10.0 * np.log10(g / want)) < 1.5)


def test_design_psd_is_within_the_edge_losses() -> None:
    """The continuous process's PSD (the design) is G times gains ≤ 1 that lose at most
    0.55 dB inside the band."""
    omega = np.geomspace(*OMEGA_BAND, 400)
    for c in (1, 6):
        db = 10.0 * np.log10(stream_psd(omega, c, BAND) / fra_psd(omega, c))
        assert np.all(db <= 1e-9) and np.all(db > -0.55)


@njit
def _draw(n: int, seed: int) -> np.ndarray:
    rng = np.full(1, seed, np.uint64)
    out = np.empty(n)
    for k in range(n):
        out[k] = _normal(rng, 0)
    return out


def test_normals_are_standard_normal() -> None:
    a = _draw(2_000_000, 12345)
    assert abs(a.mean()) < 5 * (1 / math.sqrt(a.size))
    assert abs(a.var() - 1.0) < 5 * math.sqrt(2 / a.size)
    assert stats.kstest(a[:200_000], "norm").pvalue > 1e-3
    tail = np.mean(np.abs(a) > 3.5)  # the ziggurat's tail beyond its base layer
    assert tail == pytest.approx(2 * stats.norm.sf(3.5), rel=0.15)


def test_track_is_stationary_from_its_first_sample() -> None:
    """Over many seeds the first samples have the stationary variance (the filter starts in
    its stationary distribution, not at rest)."""
    dx = 0.1
    firsts = np.array([stream_profile(5, 1.0, dx, s, BAND)[1][0] for s in range(3000)])
    f = stream_filter(5, BAND, dx)
    var = float(f.cz @ (f.chol @ f.chol.T) @ f.cz)
    assert firsts.var() == pytest.approx(var, rel=0.1)
    _, z, _ = stream_profile(5, 300_000.0, dx, 1, BAND)
    assert z.var() == pytest.approx(var, rel=0.15)


def test_same_seed_same_track() -> None:
    a = stream_profile(4, 100.0, 0.05, 3)[1]
    b = stream_profile(4, 100.0, 0.05, 3)[1]
    c = stream_profile(4, 100.0, 0.05, 4)[1]
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
