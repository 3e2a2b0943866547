"""American (FRA) track irregularity spectra and random track inputs.

The class table (``railgym/configs/track/fra.yaml``) is converted to SI once, when first loaded.
Conventions: Ω is the spatial angular frequency in rad/m, PSDs are one-sided in m²/(rad/m),
bands are given as wavelength intervals in m. Random profiles are harmonic sums with
deterministic amplitudes and uniform random phases,

    z(x) = Σ_k √(2·G(Ω_k)·ΔΩ)·cos(Ω_k·x + φ_k),  φ_k ~ U(0, 2π),

evaluated on a uniform grid by one inverse real FFT (Ω_k = k·ΔΩ, ΔΩ = 2π/(N·Δx)); slopes come
from the same harmonics, multiplied by iΩ_k, not from finite differences.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from importlib.resources import files
from pathlib import Path
from typing import Any, Literal, NamedTuple

import numpy as np

from railgym import _checks as val

__all__ = [
    "EPISODE_DURATION",
    "TrackClassParameters",
    "TrackInput",
    "class_parameters",
    "class_speed",
    "fra_profile",
    "fra_profile_window",
    "fra_profile_with_slope",
    "fra_psd",
    "load_fra_table",
    "track_time_input",
    "track_time_window",
]

#: s, the default episode of the track envs (their ``duration``) and of the reference FMUs'
#: default experiment
EPISODE_DURATION = 20.0

Kind = Literal["vertical", "alignment", "crosslevel"]
KINDS: tuple[str, ...] = ("vertical", "alignment", "crosslevel")

#: Units the YAML table must state, and the factor converting each to SI.
_UNITS: dict[str, tuple[str, float]] = {
    "A_v": ("cm^2*rad/m", 1e-4),
    "A_a": ("cm^2*rad/m", 1e-4),
    "Omega_s": ("rad/m", 1.0),
    "Omega_c": ("rad/m", 1.0),
    "max_speed": ("km/h", 1.0 / 3.6),
}

#: The synthesis period N·Δx is at least this many longest wavelengths (lowest harmonic index
#: >= 4). Each harmonic carries the PSD integrated over its frequency bin (clipped to the band),
#: so the variance equals the band integral for any period.
_MIN_PERIODS = 4
#: Gauss–Legendre nodes and weights on [−1/2, 1/2] for the per-bin PSD integral
_GL_X, _GL_W = (0.5 * a for a in np.polynomial.legendre.leggauss(5))


@dataclass(frozen=True)
class TrackClassParameters:
    """FRA spectrum parameters of one track class, in SI units.

    Attributes
    ----------
    track_class : FRA class number (1-6).
    k : dimensionless spectrum constant (0.25).
    a_v, a_a : roughness constants of profile and alignment, m²·rad/m.
    omega_s, omega_c : cut-off spatial frequencies, rad/m.
    max_speed : maximum passenger speed, m/s.
    verified : False where the values come from secondary sources only (classes 1, 2).
    """

    track_class: int
    k: float
    a_v: float
    a_a: float
    omega_s: float
    omega_c: float
    max_speed: float
    verified: bool


class TrackInput(NamedTuple):
    """Track input sampled in time at t_k = k·dt (float64 arrays; unpacks as ``t, z, zdot``).

    Attributes
    ----------
    t : times, s.
    z : irregularity under the vehicle, m.
    zdot : its time derivative v·dz/dx, m/s.
    """

    t: np.ndarray
    z: np.ndarray
    zdot: np.ndarray


#: largest internal grid of one synthesised profile (samples); the FFT work arrays of a
#: profile at the limit take about 1.5 GiB
MAX_SAMPLES = 2**26


def _parse_table(data: Any, source: str = "FRA table") -> dict[int, TrackClassParameters]:
    """Validate a loaded FRA table mapping and convert it to SI (values finite before the
    conversion, positive after it)."""
    if not isinstance(data, Mapping):
        raise ValueError(f"{source} must be a mapping with keys k, units, classes")
    root = val.Fields(data, "")
    k = root.positive("k")
    units = root.get("units")
    if not isinstance(units, Mapping):
        raise ValueError("units must be a mapping of field -> unit string")
    for name, (unit, _) in _UNITS.items():
        if units.get(name) != unit:
            raise ValueError(f"units.{name} must be {unit!r}, got {units.get(name)!r}")
    classes = root.get("classes")
    if not isinstance(classes, Mapping) or not classes:
        raise ValueError("classes must be a non-empty mapping of class number -> parameters")
    table: dict[int, TrackClassParameters] = {}
    for key, row in classes.items():
        if isinstance(key, bool) or not isinstance(key, int):
            raise ValueError(f"classes key must be an integer track class, got {key!r}")
        f = val.Fields(row, f"classes.{key}")
        si = {
            name: f.quantity(name, factor, 0.0, None, lo_open=True)
            for name, (_, factor) in _UNITS.items()
        }
        verified = val.boolean(f.get("verified", False), f.field("verified"))
        table[key] = TrackClassParameters(
            track_class=key,
            k=k,
            a_v=si["A_v"],
            a_a=si["A_a"],
            omega_s=si["Omega_s"],
            omega_c=si["Omega_c"],
            max_speed=si["max_speed"],
            verified=verified,
        )
    return table


@lru_cache(maxsize=1)
def _packaged_table() -> dict[int, TrackClassParameters]:
    text = files("railgym").joinpath("configs", "track", "fra.yaml").read_text(encoding="utf-8")
    return _parse_table(val.load_yaml(text, "fra.yaml"))


def load_fra_table(path: str | Path | None = None) -> dict[int, TrackClassParameters]:
    """Load and validate an FRA class table, converting it to SI.

    Parameters
    ----------
    path : YAML file in the format of ``railgym/configs/track/fra.yaml``; None loads the
        packaged table (cached).

    Returns
    -------
    Mapping track class -> :class:`TrackClassParameters`.
    """
    if path is None:
        return dict(_packaged_table())
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise val.FieldError("path", f"{source!r} cannot be read: {exc}") from None
    return _parse_table(val.load_yaml(text, source), source)


def class_parameters(track_class: int) -> TrackClassParameters:
    """SI parameters of FRA ``track_class`` (an integer 1-6)."""
    table = _packaged_table()
    if isinstance(track_class, bool) or not isinstance(track_class, int | np.integer):
        raise val.FieldTypeError(
            "track_class",
            f"must be an integer, one of {sorted(table)}, got {type(track_class).__name__} "
            f"{track_class!r}",
        )
    if int(track_class) not in table:
        raise ValueError(f"track_class must be one of {sorted(table)}, got {track_class!r}")
    return table[int(track_class)]


def class_speed(track_class: int) -> float:
    """Default (maximum passenger) speed of FRA ``track_class``, m/s."""
    return class_parameters(track_class).max_speed


def _check_kind(kind: str) -> None:
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")


def _psd(omega: np.ndarray, p: TrackClassParameters, kind: str) -> np.ndarray:
    """One-sided PSD in m²/(rad/m) at positive Ω (rad/m); no validation."""
    w2 = omega * omega
    wc2 = p.omega_c * p.omega_c
    if kind == "crosslevel":
        return 4.0 * p.k * p.a_v * wc2 / ((w2 + wc2) * (w2 + p.omega_s * p.omega_s))
    a = p.a_v if kind == "vertical" else p.a_a
    return p.k * a * wc2 / (w2 * (w2 + wc2))


def fra_psd(omega: Any, track_class: int, kind: Kind = "vertical") -> np.ndarray | float:
    """One-sided FRA irregularity PSD.

    Parameters
    ----------
    omega : spatial angular frequency Ω, rad/m (scalar or array, finite and > 0).
    track_class : FRA class 1-6.
    kind : "vertical" (profile), "alignment" or "crosslevel".

    Returns
    -------
    PSD in m²/(rad/m), same shape as ``omega`` (a float for scalar input).
    """
    p = class_parameters(track_class)
    _check_kind(kind)
    w = np.asarray(omega, dtype=np.float64)
    if not np.all(np.isfinite(w) & (w > 0.0)):
        raise ValueError("omega must be finite and > 0 rad/m")
    out = _psd(w, p, kind)
    return float(out) if out.ndim == 0 else out


def _check_band(band: Any) -> tuple[float, float]:
    try:
        lo, hi = band
    except (TypeError, ValueError):
        raise ValueError(f"band must be a (min, max) wavelength pair in m, got {band!r}") from None
    lo = val.positive(lo, "band")
    hi = val.positive(hi, "band")
    if not lo < hi:
        raise ValueError(f"band must satisfy min < max wavelength, got {band!r}")
    return lo, hi


def _bin_power(
    omega: np.ndarray, d_omega: float, p: TrackClassParameters, kind: str, band: tuple[float, float]
) -> np.ndarray:
    """∫ G dΩ over each bin [Ω_k − ΔΩ/2, Ω_k + ΔΩ/2] clipped to the wavelength band, m²."""
    lo = np.maximum(omega - 0.5 * d_omega, 2.0 * math.pi / band[1])
    hi = np.minimum(omega + 0.5 * d_omega, 2.0 * math.pi / band[0])
    width = np.maximum(hi - lo, 0.0)
    nodes = 0.5 * (lo + hi)[:, None] + width[:, None] * _GL_X[None, :]
    return width * (_psd(nodes, p, kind) @ _GL_W)


class _Plan(NamedTuple):
    """What a synthesis does not draw: the FFT length, the harmonics ``k_lo..k_hi`` (slice
    ``ks``), their scaled amplitudes ``0.5·N·a_k`` (m), the wheelbase factor (or None) and
    ``iΩ_k`` (rad/m); read-only arrays, cached per grid."""

    n_fft: int
    ks: slice
    scaled: np.ndarray
    shift_factor: np.ndarray | None
    i_omega: np.ndarray


@lru_cache(maxsize=64)
def _plan(
    p: TrackClassParameters,
    kind: str,
    band: tuple[float, float],
    dx: float,
    n_needed: int,
    shift: float,
) -> _Plan:
    """The phase-independent part of :func:`_synthesise` (cached: an env redraws a window of
    the same grid many times)."""
    n_min = max(n_needed, math.ceil(_MIN_PERIODS * band[1] / dx))
    if n_min > MAX_SAMPLES:
        raise ValueError(
            f"the track needs {n_min} samples (length or duration·speed, band, dx or dt), over "
            f"the limit of {MAX_SAMPLES}; shorten the duration or raise the shortest wavelength"
        )
    n_fft = 1 << (n_min - 1).bit_length()
    period = n_fft * dx
    d_omega = 2.0 * math.pi / period
    k_lo = math.ceil(period / band[1] - 1e-9)
    k_hi = math.floor(period / band[0] + 1e-9)
    omega = np.arange(k_lo, k_hi + 1) * d_omega
    amp = np.sqrt(2.0 * _bin_power(omega, d_omega, p, kind, band))
    factor = 0.5 * (1.0 + np.exp(1j * omega * shift)) if shift > 0.0 else None
    plan = _Plan(n_fft, slice(k_lo, k_hi + 1), 0.5 * n_fft * amp, factor, 1j * omega)
    for a in (plan.scaled, plan.shift_factor, plan.i_omega):
        if a is not None:
            a.setflags(write=False)
    return plan


def _synthesise(
    p: TrackClassParameters,
    kind: str,
    band: tuple[float, float],
    dx: float,
    n_needed: int,
    rng: np.random.Generator,
    shift: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Harmonic sum and its slope on x_j = j·dx, j = 0..N-1 (N >= n_needed, power of two).

    With ``shift`` > 0 (m) returns the mean of the profile at x and x + shift, done exactly as a
    per-harmonic phase factor (1 + exp(iΩ_k·shift))/2.
    """
    plan = _plan(p, kind, band, dx, n_needed, shift)
    ks = plan.ks
    phase = rng.uniform(0.0, 2.0 * math.pi, size=plan.scaled.size)
    coef = np.zeros(plan.n_fft // 2 + 1, dtype=np.complex128)
    coef[ks] = plan.scaled * np.exp(1j * phase)
    if plan.shift_factor is not None:
        coef[ks] *= plan.shift_factor
    z = np.fft.irfft(coef, n=plan.n_fft)
    coef[ks] *= plan.i_omega
    dzdx = np.fft.irfft(coef, n=plan.n_fft)
    return z, dzdx


def fra_profile_with_slope(
    track_class: int,
    length: float,
    dx: float,
    seed: int | np.random.Generator | None,
    band: tuple[float, float] = (1.0, 100.0),
    *,
    kind: Kind = "vertical",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random FRA irregularity profile with its exact (spectral) slope.

    Parameters
    ----------
    track_class : FRA class 1-6.
    length : profile length, m.
    dx : sample spacing, m; must be below half the shortest wavelength.
    seed : seed or generator for the random phases (``np.random.default_rng(seed)``).
    band : (min, max) wavelength band, m.
    kind : "vertical", "alignment" or "crosslevel".

    Returns
    -------
    x : positions j·dx from 0 to at most ``length``, m.
    z : irregularity, m.
    dzdx : slope dz/dx, dimensionless.

    Notes
    -----
    The profile is the start of one period of a harmonic sum whose period N·dx is the next power
    of two of samples covering both ``length`` and 4 longest wavelengths; each harmonic's
    amplitude carries the PSD integrated over its frequency bin.
    """
    z, dzdx, dx = _profile(track_class, length, dx, seed, band, kind)
    n = z.shape[0]
    return np.arange(n) * dx, z, dzdx


def _profile(
    track_class: int,
    length: float,
    dx: float,
    seed: int | np.random.Generator | None,
    band: tuple[float, float],
    kind: str,
    window: tuple[int, int] | None = None,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Checked arguments of :func:`fra_profile_with_slope`, then ``(z, dzdx, dx)``: the
    profile's samples, all or those of ``window = (start, count)`` (copies)."""
    p = class_parameters(track_class)
    _check_kind(kind)
    length = val.positive(length, "length")
    dx = val.positive(dx, "dx")
    lo, hi = _check_band(band)
    if not dx < 0.5 * lo:
        raise ValueError(f"dx must be below half the shortest wavelength {lo} m, got {dx}")
    if not dx <= length:
        raise ValueError(f"length must be at least dx, got {length}")
    n = math.floor(length / dx + 1e-9) + 1
    start, count = (0, n) if window is None else (int(window[0]), int(window[1]))
    if start < 0 or count < 1 or start + count > n:
        raise ValueError(f"window {start}..{start + count - 1} is outside the samples 0..{n - 1}")
    z, dzdx = _synthesise(
        p, kind, (lo, hi), dx, n, np.random.default_rng(val.random_seed(seed, "seed"))
    )
    cut = slice(start, start + count)
    return z[cut].copy(), dzdx[cut].copy(), dx


def fra_profile_window(
    track_class: int,
    length: float,
    dx: float,
    seed: int | np.random.Generator | None,
    start: int,
    count: int,
    band: tuple[float, float] = (1.0, 100.0),
    *,
    kind: Kind = "vertical",
) -> tuple[np.ndarray, np.ndarray]:
    """Samples ``start .. start + count - 1`` of :func:`fra_profile_with_slope`'s ``(z,
    dzdx)`` (m, dimensionless), bit for bit the same values (arguments as there); the whole
    period is synthesised again (two inverse FFTs) and the window copied out."""
    z, dzdx, _ = _profile(track_class, length, dx, seed, band, kind, (start, count))
    return z, dzdx


def fra_profile(
    track_class: int,
    length: float,
    dx: float,
    seed: int | np.random.Generator | None,
    band: tuple[float, float] = (1.0, 100.0),
    *,
    kind: Kind = "vertical",
) -> tuple[np.ndarray, np.ndarray]:
    """Random FRA irregularity profile ``(x, z)`` in m; see :func:`fra_profile_with_slope`."""
    x, z, _ = fra_profile_with_slope(track_class, length, dx, seed, band, kind=kind)
    return x, z


def track_time_input(
    track_class: int,
    speed: float,
    duration: float,
    dt: float,
    seed: int | np.random.Generator | None,
    band: tuple[float, float] = (1.0, 100.0),
    wheelbase: float | None = None,
    *,
    kind: Kind = "vertical",
) -> TrackInput:
    """Track irregularity seen by a vehicle running at constant speed.

    Parameters
    ----------
    track_class : FRA class 1-6.
    speed : running speed v, m/s.
    duration : simulated time, s; the grid is t_k = k·dt, k = 0..floor(duration/dt).
    dt : sample interval, s.
    seed : seed or generator for the random phases.
    band : (min, max) wavelength band, m.
    wheelbase : if given (m), the input is the mean of the leading wheel (at v·t + wheelbase)
        and the trailing wheel (at v·t), applied exactly per harmonic.
    kind : "vertical", "alignment" or "crosslevel".

    Returns
    -------
    TrackInput ``(t, z, zdot)``: z in m at x = v·t, zdot = v·dz/dx in m/s.

    Notes
    -----
    The samples are exact values of the harmonic sum: where v·dt exceeds half the shortest
    wavelength the sum is evaluated on a finer internal grid (dt/m) and every m-th value kept,
    so nothing is interpolated (the sampled signal then aliases, as a measured one would).
    """
    grid = _time_grid(track_class, speed, duration, dt, band, wheelbase, kind)
    z, dzdx = _synthesise(
        *grid.args, np.random.default_rng(val.random_seed(seed, "seed")), grid.shift
    )
    last = grid.n_steps * grid.sub + 1
    t = np.arange(grid.n_steps + 1) * dt
    return TrackInput(t, z[: last : grid.sub].copy(), grid.speed * dzdx[: last : grid.sub])


class _TimeGrid(NamedTuple):
    """The checked grid of :func:`track_time_input`: ``args`` of :func:`_synthesise` before
    the generator, the wheelbase ``shift`` (m), control steps ``n_steps``, internal samples
    per time step ``sub`` and the speed (m/s)."""

    args: tuple[TrackClassParameters, str, tuple[float, float], float, int]
    shift: float
    n_steps: int
    sub: int
    speed: float


def _time_grid(
    track_class: int,
    speed: float,
    duration: float,
    dt: float,
    band: tuple[float, float],
    wheelbase: float | None,
    kind: str,
) -> _TimeGrid:
    """Check the arguments of :func:`track_time_input` and derive its internal grid."""
    p = class_parameters(track_class)
    _check_kind(kind)
    speed = val.positive(speed, "speed")
    duration = val.positive(duration, "duration")
    dt = val.positive(dt, "dt")
    lo, hi = _check_band(band)
    if not dt <= duration:
        raise ValueError(f"duration must be at least dt, got {duration}")
    shift = 0.0 if wheelbase is None else val.positive(wheelbase, "wheelbase")
    n_steps = math.floor(duration / dt + 1e-9)
    step = speed * dt
    sub = math.floor(2.0 * step / lo) + 1  # internal samples per time step, keeps dx < lo/2
    dx = step / sub
    n_needed = n_steps * sub + 1 + math.ceil(shift / dx)
    return _TimeGrid((p, kind, (lo, hi), dx, n_needed), shift, n_steps, sub, speed)


def track_time_window(
    track_class: int,
    speed: float,
    duration: float,
    dt: float,
    seed: int | np.random.Generator | None,
    start: int,
    count: int,
    band: tuple[float, float] = (1.0, 100.0),
    wheelbase: float | None = None,
    *,
    kind: Kind = "vertical",
) -> tuple[np.ndarray, np.ndarray]:
    """Samples ``start .. start + count - 1`` of :func:`track_time_input`'s ``(z, zdot)``
    (m, m/s), bit for bit the same values (arguments as there; the window must lie in
    ``0 .. floor(duration/dt)``).

    Notes
    -----
    The whole period is synthesised again (two inverse FFTs; the amplitudes are cached per
    grid) and the window copied out, so a window costs as much as a whole track and its
    values do not depend on where the windows start.
    """
    grid = _time_grid(track_class, speed, duration, dt, band, wheelbase, kind)
    start, count = int(start), int(count)
    if start < 0 or count < 1 or start + count > grid.n_steps + 1:
        raise ValueError(
            f"window {start}..{start + count - 1} is outside the samples 0..{grid.n_steps}"
        )
    z, dzdx = _synthesise(
        *grid.args, np.random.default_rng(val.random_seed(seed, "seed")), grid.shift
    )
    sub = grid.sub
    window = slice(start * sub, (start + count - 1) * sub + 1, sub)
    return z[window].copy(), grid.speed * dzdx[window]
