"""Streaming FRA vertical track: a shaping filter driven by white noise, O(1) per sample.

The FRA vertical spectrum G(Ω) = k·A·Ω_c² / (Ω²(Ω² + Ω_c²)) (one-sided, m²/(rad/m), Ω in rad/m)
is |H(iΩ)|²·q/π of the spatial filter H(s) = 1/(s(s + Ω_c)) driven by white noise of intensity
q = π·k·A·Ω_c² (m²·rad/m per m): a first-order lag (the slope) and an integrator (the height).
It is band-limited to the wavelength band (λ_min, λ_max) by two factors,

    H(s) = s / ((s² + √2·ω_l·s + ω_l²)(s + Ω_c)) · ω_h / (s + ω_h),

a second-order Butterworth high-pass at ω_l = :data:`HP_FACTOR` · 2π/λ_max (it cancels the
integrator, so the process is stationary) and a first-order low-pass at ω_h = :data:`LP_FACTOR`
· 2π/λ_min. Inside the band the PSD of the process is G·|HP|²·|LP|², at most 0.53 dB below G
at the long edge and 0.46 dB at the short one (:func:`stream_psd`); docs/envs/vertical.md
gives the RMS.

Discretisation at the spatial step ds (m): the white noise is replaced by impulses of
independent weights √(q·ds)·ξ_j, ξ_j ~ N(0, 1), one per step, applied just after each sample,

    x_{j+1} = Φ·x_j + Φ·B·√(q·ds)·ξ_j,   Φ = exp(A·ds),   z_j = C·x_j,   (dz/dx)_j = C·A·x_j.

An impulse train of independent weights has the flat spectrum q at every frequency, so the
filter's continuous output has the PSD q·|H|²/π exactly and the samples are its values (aliased
as a measured signal is); the relative degree 3 of H makes both the height and the slope
continuous (C·B = C·A·B = 0). One normal variate per sample, drawn in the compiled step from a
per-track splitmix64 stream (ziggurat). The state starts in the
stationary distribution of the recursion (discrete Lyapunov equation), so the track is
stationary from its first sample.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numba import njit
from scipy import linalg, signal

from railgym import _checks as val
from railgym.track import class_parameters

__all__ = [
    "HP_FACTOR",
    "LP_FACTOR",
    "N_STATES",
    "StreamFilter",
    "StreamState",
    "new_stream_state",
    "set_stream",
    "seed_stream",
    "stream_filter",
    "stream_profile",
    "stream_psd",
    "slide_window",
    "stream_cover",
    "stream_samples",
    "stream_start",
]

#: high-pass corner / lowest band frequency 2π/λ_max
HP_FACTOR = 0.6
#: low-pass corner / highest band frequency 2π/λ_min
LP_FACTOR = 3.0
#: states of the shaping filter
N_STATES = 4


class StreamFilter(NamedTuple):
    """The discretised shaping filter of one track class, band and step ds (read-only arrays).

    Attributes
    ----------
    phi : (4, 4) state transition exp(A·ds).
    gain : (4,) impulse input Φ·B·√(q·ds), m.
    cz : (4,) output row of the height z, m per state unit.
    cs : (4,) output row of the slope dz/dx.
    chol : (4, 4) Cholesky factor of the stationary state covariance.
    """

    phi: np.ndarray
    gain: np.ndarray
    cz: np.ndarray
    cs: np.ndarray
    chol: np.ndarray


class StreamState(NamedTuple):
    """Per-track generator state and filter of ``n`` streamed tracks (the rows of
    :class:`StreamFilter`'s arrays for each track's class, band, step and speed)."""

    x: np.ndarray  #: float64 (n, 4) shaping-filter state
    rng: np.ndarray  #: uint64 (n,) splitmix64 state
    phi: np.ndarray  #: float64 (n, 4, 4) transition
    gain: np.ndarray  #: float64 (n, 4) impulse input, m
    cz: np.ndarray  #: float64 (n, 4) height row
    cs: np.ndarray  #: float64 (n, 4) rate row: the slope row times the speed (m/s)


def new_stream_state(n: int) -> StreamState:
    """Zeroed :class:`StreamState` of ``n`` tracks."""
    f = np.zeros
    m = N_STATES
    return StreamState(f((n, m)), f(n, np.uint64), f((n, m, m)), f((n, m)), f((n, m)), f((n, m)))


def set_stream(
    gen: StreamState, idx: np.ndarray, f: StreamFilter, speed: float, seeds: Sequence[int]
) -> None:
    """Tracks ``idx`` of ``gen`` given the filter ``f`` at ``speed`` (m/s: rates in m/s) and
    their streams seeded with ``seeds`` (non-negative ints, :func:`seed_stream`)."""
    gen.phi[idx], gen.gain[idx], gen.cz[idx], gen.cs[idx] = f.phi, f.gain, f.cz, f.cs * speed
    gen.rng[idx] = [seed_stream(s) for s in seeds]


def _continuous(
    track_class: int, band: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """``(A, B, C, q)`` of the continuous shaping filter (controllable canonical form)."""
    p = class_parameters(track_class)
    w_l = HP_FACTOR * 2.0 * math.pi / band[1]
    w_h = LP_FACTOR * 2.0 * math.pi / band[0]
    num = [w_h, 0.0]
    den = np.polymul(
        np.polymul([1.0, math.sqrt(2.0) * w_l, w_l * w_l], [1.0, p.omega_c]), [1.0, w_h]
    )
    a, b, c, _ = signal.tf2ss(num, den)
    return a, b[:, 0], c[0], math.pi * p.k * p.a_v * p.omega_c**2


def _check(track_class: int, band: tuple[float, float]) -> tuple[float, float]:
    class_parameters(track_class)
    try:
        lo, hi = (val.positive(w, "band") for w in band)
    except (TypeError, ValueError):
        raise ValueError(f"band must be a (min, max) wavelength pair in m, got {band!r}") from None
    if not lo < hi:
        raise ValueError(f"band must satisfy min < max wavelength, got {band!r}")
    return lo, hi


def stream_psd(omega: np.ndarray, track_class: int, band: tuple[float, float]) -> np.ndarray:
    """One-sided PSD (m²/(rad/m)) of the continuous streamed process at Ω (rad/m, > 0):
    the class's vertical G times the high- and low-pass gains."""
    lo, hi = _check(track_class, band)
    a, b, c, q = _continuous(track_class, (lo, hi))
    w = np.asarray(omega, dtype=np.float64)
    h = np.array([c @ np.linalg.solve(1j * x * np.eye(N_STATES) - a, b) for x in w.ravel()])
    return (q * np.abs(h) ** 2 / math.pi).reshape(w.shape)


@lru_cache(maxsize=256)
def _filter(track_class: int, band: tuple[float, float], ds: float) -> StreamFilter:
    a, b, c, q = _continuous(track_class, band)
    phi = linalg.expm(a * ds)
    gain = phi @ b * math.sqrt(q * ds)
    cov = linalg.solve_discrete_lyapunov(phi, np.outer(gain, gain))
    chol = np.linalg.cholesky(0.5 * (cov + cov.T))
    out = StreamFilter(phi, gain, c.copy(), c @ a, chol)
    for arr in out:
        arr.setflags(write=False)
    return out


def stream_filter(track_class: int, band: tuple[float, float], ds: float) -> StreamFilter:
    """The :class:`StreamFilter` of FRA ``track_class`` (vertical), wavelength ``band`` (m)
    and spatial step ``ds`` (m, > 0); cached."""
    lo, hi = _check(track_class, band)
    return _filter(int(track_class), (float(lo), float(hi)), val.positive(ds, "ds"))


_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)


@njit(cache=True, _nrt=False)
def _splitmix(rng, i):
    """Next splitmix64 value (uint64) of stream ``rng[i]``, the stream advanced."""
    s = rng[i] + _GOLDEN
    rng[i] = s
    s = (s ^ (s >> _S30)) * _M1
    s = (s ^ (s >> _S27)) * _M2
    return s ^ (s >> _S31)


@njit(cache=True, _nrt=False)
def _uniform(rng, i):
    """Next splitmix64 value of stream ``rng[i]`` as a float in (0, 1]."""
    return (float(_splitmix(rng, i) >> _S11) + 1.0) * (1.0 / 9007199254740992.0)


def _ziggurat_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(kn, wn, fn)`` of Marsaglia and Tsang's ziggurat for the normal density, 128 layers
    on 32-bit signed integers (J. Stat. Softw. 5(8), 2000)."""
    m1 = 2147483648.0
    dn = tn = 3.442619855899
    vn = 9.91256303526217e-3
    kn, wn, fn = np.zeros(128, np.int64), np.zeros(128), np.zeros(128)
    q = vn / math.exp(-0.5 * dn * dn)
    kn[0], kn[1] = int(dn / q * m1), 0
    wn[0], wn[127] = q / m1, dn / m1
    fn[0], fn[127] = 1.0, math.exp(-0.5 * dn * dn)
    for i in range(126, 0, -1):
        dn = math.sqrt(-2.0 * math.log(vn / dn + math.exp(-0.5 * dn * dn)))
        kn[i + 1] = int(dn / tn * m1)
        tn = dn
        fn[i] = math.exp(-0.5 * dn * dn)
        wn[i] = dn / m1
    return kn, wn, fn


_KN, _WN, _FN = _ziggurat_tables()
_ZIG_R = 3.442619855899
_S32, _MASK = np.uint64(32), np.uint64(127)


@njit(cache=True, _nrt=False)
def _normal(rng, i):
    """Next standard normal of track ``i`` (ziggurat on the high 32 bits of one splitmix64
    value; the tails and wedges, about 2 % of the draws, take more)."""
    while True:
        hi = _splitmix(rng, i) >> _S32
        iz = int(hi & _MASK)
        hz = int(hi) - 2147483648
        if abs(hz) < _KN[iz]:
            return hz * _WN[iz]
        x = hz * _WN[iz]
        if iz == 0:  # the tail beyond r
            while True:
                t = -math.log(_uniform(rng, i)) / _ZIG_R
                y = -math.log(_uniform(rng, i))
                if y + y >= t * t:
                    return _ZIG_R + t if hz > 0 else -_ZIG_R - t
        if _FN[iz] + _uniform(rng, i) * (_FN[iz - 1] - _FN[iz]) < math.exp(-0.5 * x * x):
            return x


@njit(cache=True)
def stream_start(gen, i, chol):
    """Track ``i``'s state drawn from the stationary distribution (``chol``: its Cholesky
    factor) with normals of its stream (``gen``: :class:`StreamState`)."""
    x, rng = gen.x, gen.rng
    n = x.shape[1]
    xi = np.empty(n)
    for j in range(n):
        xi[j] = _normal(rng, i)
    for r in range(n):
        acc = 0.0
        for j in range(r + 1):
            acc += chol[r, j] * xi[j]
        x[i, r] = acc


@njit(cache=True, _nrt=False)
def stream_samples(gen, i, z, zd, j0, j1):
    """Samples ``j0 .. j1 - 1`` of track ``i`` of ``gen`` (:class:`StreamState`) into
    ``z[i]`` (m) and ``zd[i]`` (m/s, or the slope for a unit speed), its state advanced one
    step ds per sample."""
    x, rng, phi, gain, cz, cs = gen
    x0, x1, x2, x3 = x[i, 0], x[i, 1], x[i, 2], x[i, 3]
    for j in range(j0, j1):
        z[i, j] = cz[i, 0] * x0 + cz[i, 1] * x1 + cz[i, 2] * x2 + cz[i, 3] * x3
        zd[i, j] = cs[i, 0] * x0 + cs[i, 1] * x1 + cs[i, 2] * x2 + cs[i, 3] * x3
        e = _normal(rng, i)
        y0 = phi[i, 0, 0] * x0 + phi[i, 0, 1] * x1 + phi[i, 0, 2] * x2 + phi[i, 0, 3] * x3
        y1 = phi[i, 1, 0] * x0 + phi[i, 1, 1] * x1 + phi[i, 1, 2] * x2 + phi[i, 1, 3] * x3
        y2 = phi[i, 2, 0] * x0 + phi[i, 2, 1] * x1 + phi[i, 2, 2] * x2 + phi[i, 2, 3] * x3
        y3 = phi[i, 3, 0] * x0 + phi[i, 3, 1] * x1 + phi[i, 3, 2] * x2 + phi[i, 3, 3] * x3
        x0 = y0 + gain[i, 0] * e
        x1 = y1 + gain[i, 1] * e
        x2 = y2 + gain[i, 2] * e
        x3 = y3 + gain[i, 3] * e
    x[i, 0], x[i, 1], x[i, 2], x[i, 3] = x0, x1, x2, x3


@njit(cache=True, _nrt=False)
def slide_window(z, zd, start, end, i, lo, hi):
    """Window row ``i`` (``z[i, 0]`` is track sample ``start[i]``, samples up to ``end[i] - 1``
    held) moved to start at sample ``lo`` when sample ``hi - 1`` lies beyond it (the held
    samples from ``lo`` on kept); needs ``start[i] <= lo`` and ``hi - lo <= width``."""
    if hi - start[i] <= z.shape[1]:
        return
    shift = lo - start[i]
    for j in range(max(end[i] - lo, 0)):
        z[i, j] = z[i, j + shift]
        zd[i, j] = zd[i, j + shift]
    start[i] = lo
    end[i] = max(end[i], lo)


@njit(cache=True, _nrt=False)
def stream_cover(gen, i, z, zd, start, end, lo, hi):
    """Window row ``i`` holding track samples ``lo .. hi - 1`` (:func:`slide_window`), the
    samples from ``end[i]`` to ``hi - 1`` generated (:func:`stream_samples`)."""
    slide_window(z, zd, start, end, i, lo, hi)
    if hi > end[i]:
        s = start[i]
        stream_samples(gen, i, z, zd, end[i] - s, hi - s)
        end[i] = hi


def seed_stream(seed: int) -> np.uint64:
    """The splitmix64 state of a track seeded with ``seed`` (a non-negative int)."""
    return np.uint64(int(seed) & 0xFFFFFFFFFFFFFFFF)


def stream_profile(
    track_class: int,
    length: float,
    dx: float,
    seed: int | np.random.Generator | None,
    band: tuple[float, float] = (1.0, 100.0),
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A streamed FRA vertical profile ``(x, z, dzdx)`` on x_j = j·dx from 0 to at most
    ``length`` (m, m, dimensionless): the samples the streaming envs generate for a track of
    this class, band and step, its seed drawn as theirs (one integer from
    ``np.random.default_rng(seed)``)."""
    length = val.positive(length, "length")
    dx = val.positive(dx, "dx")
    f = stream_filter(track_class, band, dx)
    n = math.floor(length / dx + 1e-9) + 1
    rng = np.random.default_rng(val.random_seed(seed, "seed"))
    gen = new_stream_state(1)
    set_stream(gen, np.zeros(1, np.int64), f, 1.0, [int(rng.integers(2**63 - 1))])
    z, s = np.empty((1, n)), np.empty((1, n))
    stream_start(gen, 0, f.chol)
    stream_samples(gen, 0, z, s, 0, n)
    return np.arange(n) * dx, z[0], s[0]
