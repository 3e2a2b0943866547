"""Ride-comfort metrics: ISO 2631-1 frequency weighting and the Sperling ride index.

Pure numpy/scipy. Accelerations are in m/s², frequencies in Hz, times in s.

ISO 2631-1:1997, Annex A, defines the weightings as products of analog transfer functions
in the Laplace variable ``s = j 2 pi f``:

* band-limiting high-pass  ``H_h = s² / (s² + s w1/Q1 + w1²)``,
* band-limiting low-pass   ``H_l = w2² / (s² + s w2/Q2 + w2²)``,   Q1 = Q2 = 1/sqrt(2),
* acceleration-velocity transition
  ``H_t = (1 + s/w3) / (1 + s/(Q4 w4) + s²/w4²)``,
* upward step ``H_s = (1 + s/(Q5 w5) + s²/w5²) / (1 + s/(Q6 w6) + s²/w6²) * (w5/w6)²``,

with ``w_i = 2 pi f_i``. Wk (vertical, seated) and Wd (horizontal) use f1 = 0.4 Hz, f2 = 100 Hz;
Wk: f3 = f4 = 12.5 Hz, Q4 = 0.63, f5 = 2.37 Hz, Q5 = 0.91, f6 = 3.35 Hz, Q6 = 0.91;
Wd: f3 = f4 = 2 Hz, Q4 = 0.63 and no upward step (H_s = 1).
Wb (EN 12299 vertical comfort, ISO 2631-4:2001 Table A.1, parameters as in ISO 8041):
f3 = f4 = 16 Hz, Q4 = 0.55, f5 = 2.5 Hz, Q5 = 0.9, f6 = 4 Hz, Q6 = 0.95, times K = 1.024.

Discretisation: each analog section becomes one second-order section. H_h, H_l and H_s use
the bilinear transform pre-warped at the section's own frequency (f1, f2, sqrt(f5 f6)). H_t
falls off as 1/f, which the bilinear transform squeezes to zero at the Nyquist frequency; it
is discretised instead by magnitude matching (M. Vicanek, "Matched second order digital
filters", 2016): poles by impulse invariance, numerator fitted to the analog magnitude at
0, f4 and fs/2. Deviation of the discrete from the analog gain, Wk (Wd): fs = 1000 Hz:
< 0.1 % up to 80 Hz; fs = 100 Hz: < 0.3 % (1.2 %) up to 10 Hz, 1 % (3 %) at 16 Hz,
2.5 % (4.6 %) at 20 Hz. The band-limiting low-pass at f2 = 100 Hz
cannot be represented when ``fs <= 2 f2`` (at the 100 Hz control rate of the environments the
whole band above 50 Hz is missing anyway); it is then omitted. Its analog gain is
``1/sqrt(1 + (f/f2)⁴)``, so omitting it changes the weighting by less than 0.5 % below 30 Hz
and by 3 % at 50 Hz.

Check against tabulated values: ``wb_weighting`` reproduces the Wb design-goal weighting
factors of ISO 8041-1:2017 Annex B, Table B.1 (one-third-octave band centres 0.1 to 398 Hz,
band limiting included) to their printed four significant figures
(``tests/test_vehicle_comfort.py``; table as transcribed in the phonometry project,
github.com/jmrplens/phonometry, ``tests/reference_data/vibration.py``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import signal

__all__ = [
    "MIN_FS",
    "SPERLING_SCALE",
    "RunningComfort",
    "WeightingFilter",
    "sperling_b",
    "sperling_label",
    "sperling_wz",
    "a_zp95",
    "wb_weighting",
    "window_rms_p95",
    "weighted_rms",
    "wk_gain",
    "wk_weighting_tf",
]

#: Smallest accepted sample rate [Hz] (the Wk transition frequency f4 = 12.5 Hz is fs/4 there).
MIN_FS = 50.0

_Q_BUTTER = 1.0 / np.sqrt(2.0)


@dataclass(frozen=True)
class _Params:
    f1: float
    f2: float
    f3: float
    f4: float
    q4: float
    f5: float | None
    q5: float | None
    f6: float | None
    q6: float | None
    k: float = 1.0  # overall gain factor K (ISO 8041; 1 except for Wb)


_PARAMS = {
    "Wk": _Params(0.4, 100.0, 12.5, 12.5, 0.63, 2.37, 0.91, 3.35, 0.91),
    "Wd": _Params(0.4, 100.0, 2.0, 2.0, 0.63, None, None, None, None),
    # EN 12299 / ISO 2631-4:2001 vertical weighting for rail passengers, parameters and gain
    # factor K = 1.024 as in ISO 8041 (Q1 = Q2 = 1/sqrt(2) exactly)
    "Wb": _Params(0.4, 100.0, 16.0, 16.0, 0.55, 2.5, 0.9, 4.0, 0.95, 1.024),
}

#: Sperling ride-index scale (lower bound of Wz, description).
SPERLING_SCALE: tuple[tuple[float, str], ...] = (
    (1.0, "just noticeable"),
    (2.0, "clearly noticeable"),
    (2.5, "more pronounced but not unpleasant"),
    (3.0, "strong but tolerable"),
    (3.25, "very irregular"),
    (3.5, "extremely irregular"),
    (4.0, "extremely unpleasant"),
)

_SPERLING_EXPONENT = 6.67
_SPERLING_BAND = (0.5, 30.0)


def _params(kind: str) -> _Params:
    if not isinstance(kind, str) or kind not in _PARAMS:
        raise ValueError(f"kind must be one of {sorted(_PARAMS)}, got {kind!r}")
    return _PARAMS[kind]


def _sections(kind: str, lowpass: bool) -> list[tuple[str, np.ndarray, np.ndarray, float]]:
    """Analog sections ``(name, b, a, f_ref)``: polynomials in s (highest power first, leading
    denominator coefficient 1) and the section's reference frequency [Hz]."""
    p = _params(kind)
    w1, w2, w3, w4 = (2.0 * np.pi * f for f in (p.f1, p.f2, p.f3, p.f4))
    # K·H_h = K·s² / (s² + s w1/Q + w1²)
    secs = [("h", np.array([p.k, 0.0, 0.0]), np.array([1.0, w1 / _Q_BUTTER, w1**2]), p.f1)]
    if lowpass:
        # H_l = w2² / (s² + s w2/Q + w2²)
        secs.append(
            ("l", np.array([0.0, 0.0, w2**2]), np.array([1.0, w2 / _Q_BUTTER, w2**2]), p.f2)
        )
    # H_t = (1 + s/w3) / (1 + s/(Q4 w4) + s²/w4²), multiplied through by w4²
    secs.append(("t", np.array([0.0, w4**2 / w3, w4**2]), np.array([1.0, w4 / p.q4, w4**2]), p.f4))
    if p.f5 is not None:
        w5, w6 = 2.0 * np.pi * p.f5, 2.0 * np.pi * p.f6
        # H_s = (1 + s/(Q5 w5) + s²/w5²) / (1 + s/(Q6 w6) + s²/w6²) * (w5/w6)²
        #     = (s² + s w5/Q5 + w5²) / (s² + s w6/Q6 + w6²)
        secs.append(
            (
                "s",
                np.array([1.0, w5 / p.q5, w5**2]),
                np.array([1.0, w6 / p.q6, w6**2]),
                float(np.sqrt(p.f5 * p.f6)),
            )
        )
    return secs


def _bilinear_prewarped(b: np.ndarray, a: np.ndarray, fs: float, f_ref: float) -> np.ndarray:
    """SOS row of the bilinear transform of ``b/a``, exact at frequency ``f_ref`` [Hz]."""
    w = 2.0 * np.pi * f_ref
    bz, az = signal.bilinear(b, a, fs=w / (2.0 * np.tan(w / (2.0 * fs))))
    return np.concatenate([bz, az])


def _matched(b: np.ndarray, a: np.ndarray, fs: float, f_ref: float) -> np.ndarray:
    """SOS row matching ``|b/a|`` at 0, ``f_ref`` and fs/2, poles by impulse invariance."""
    w0 = np.sqrt(a[2]) / fs
    zeta = a[1] / (2.0 * np.sqrt(a[2]))
    osc = np.cos if zeta < 1.0 else np.cosh
    a1 = -2.0 * np.exp(-zeta * w0) * osc(np.sqrt(abs(1.0 - zeta**2)) * w0)
    a2 = np.exp(-2.0 * zeta * w0)
    # |A(e^jw)|² = A0 phi0 + A1 phi1 + A2 phi2, phi1 = sin²(w/2), phi0 = 1 - phi1,
    # phi2 = 4 phi0 phi1; same basis for |B|².
    big_a = np.array([(1.0 + a1 + a2) ** 2, (1.0 - a1 + a2) ** 2, -4.0 * a2])

    def h2(f: float) -> float:
        s = 2j * np.pi * f
        return abs(np.polyval(b, s) / np.polyval(a, s)) ** 2

    phi1 = np.sin(np.pi * f_ref / fs) ** 2
    phi = np.array([1.0 - phi1, phi1, 4.0 * (1.0 - phi1) * phi1])
    big_b0 = h2(0.0) * big_a[0]
    big_b1 = h2(fs / 2.0) * big_a[1]
    big_b2 = (h2(f_ref) * (big_a @ phi) - big_b0 * phi[0] - big_b1 * phi[1]) / phi[2]
    r0, r1 = np.sqrt(big_b0), np.sqrt(big_b1)
    w = 0.5 * (r0 + r1)
    b0 = 0.5 * (w + np.sqrt(w**2 + big_b2))
    return np.array([b0, 0.5 * (r0 - r1), -big_b2 / (4.0 * b0), 1.0, a1, a2])


def wk_weighting_tf(kind: str = "Wk", lowpass: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Analog ISO 2631-1 weighting ``H(s) = H_h H_l H_t H_s`` (Annex A, ISO 2631-1:1997).

    Parameters
    ----------
    kind : {"Wk", "Wd"}
        Wk: vertical (z) seated; Wd: horizontal (x, y).
    lowpass : bool
        Include the band-limiting low-pass at f2 = 100 Hz.

    Returns
    -------
    b, a : ndarray
        Numerator and denominator polynomials in s [s in rad/s], highest power first.
    """
    b, a = np.array([1.0]), np.array([1.0])
    for _, bs, as_, _ in _sections(kind, lowpass):
        b, a = np.polymul(b, bs), np.polymul(a, as_)
    return np.trim_zeros(b, "f"), a


def wk_gain(f: float | np.ndarray, kind: str = "Wk", lowpass: bool = True) -> np.ndarray:
    """Modulus ``|H(j 2 pi f)|`` of the analog ISO 2631-1 weighting at frequency ``f`` [Hz]."""
    f = np.asarray(f, dtype=float)
    if np.any(~np.isfinite(f)) or np.any(f < 0.0):
        raise ValueError("f must be finite and >= 0")
    s = 2j * np.pi * f
    h = np.ones_like(s)
    for _, bs, as_, _ in _sections(kind, lowpass):
        h = h * np.polyval(bs, s) / np.polyval(as_, s)
    return np.abs(h)


def _check_fs(fs: float) -> float:
    fs = float(fs)
    if not np.isfinite(fs) or fs < MIN_FS:
        raise ValueError(f"fs must be a finite sample rate >= {MIN_FS} Hz, got {fs}")
    return fs


def _as_signal(a: np.ndarray | float, name: str = "a") -> np.ndarray:
    x = np.atleast_1d(np.asarray(a, dtype=float))
    if x.ndim != 1:
        raise ValueError(f"{name} must be a scalar or 1-D array, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} must be finite")
    return x


class WeightingFilter:
    """Discrete ISO 2631-1 weighting filter (cascaded second-order sections).

    Parameters
    ----------
    fs : float
        Sample rate [Hz], ``>= MIN_FS``.
    kind : {"Wk", "Wd"}
        Weighting.
    lowpass : bool or None
        Band-limiting low-pass at f2 = 100 Hz. None (default): included iff ``fs > 2 f2``,
        otherwise omitted with a ``UserWarning``. False: omitted silently. True: required,
        ValueError if ``fs <= 2 f2``.

    Notes
    -----
    ``filter`` processes a whole signal from rest; ``step`` processes consecutive chunks with
    internal state, so concatenated ``step`` outputs equal ``filter`` of the concatenation.
    """

    def __init__(self, fs: float, kind: str = "Wk", lowpass: bool | None = None) -> None:
        self.fs = _check_fs(fs)
        p = _params(kind)
        self.kind = kind
        representable = self.fs > 2.0 * p.f2
        if lowpass is None:
            if not representable:
                warnings.warn(
                    f"fs = {self.fs} Hz <= 2 f2 = {2.0 * p.f2} Hz: the {p.f2} Hz band-limiting "
                    "low-pass is omitted (pass lowpass=False to silence)",
                    UserWarning,
                    stacklevel=2,
                )
            lowpass = representable
        elif lowpass and not representable:
            raise ValueError(f"lowpass=True needs fs > {2.0 * p.f2} Hz, got fs = {self.fs}")
        self.lowpass = bool(lowpass)
        self.sos = np.array(
            [
                (_matched if name == "t" else _bilinear_prewarped)(bs, as_, self.fs, f_ref)
                for name, bs, as_, f_ref in _sections(kind, self.lowpass)
            ]
        )
        self._zi = np.zeros((self.sos.shape[0], 2))

    def gain(self, f: float | np.ndarray) -> np.ndarray:
        """Modulus of the discrete filter's frequency response at ``f`` [Hz]."""
        _, h = signal.sosfreqz(self.sos, worN=np.atleast_1d(np.asarray(f, float)), fs=self.fs)
        return np.abs(h)

    def filter(self, a: np.ndarray) -> np.ndarray:
        """Weighted acceleration [m/s²] of signal ``a`` [m/s²], filter starting at rest."""
        return signal.sosfilt(self.sos, _as_signal(a))

    def step(self, a_chunk: np.ndarray | float) -> np.ndarray:
        """Filter the next chunk of a stream, keeping the filter state between calls."""
        y, self._zi = signal.sosfilt(self.sos, _as_signal(a_chunk, "a_chunk"), zi=self._zi)
        return y

    def reset(self) -> None:
        """Return the streaming state to rest."""
        self._zi = np.zeros_like(self._zi)


def weighted_rms(
    a: np.ndarray,
    fs: float,
    kind: str = "Wk",
    discard: float = 0.0,
    lowpass: bool | None = None,
) -> float:
    """Frequency-weighted r.m.s. acceleration ``a_w`` [m/s²] (ISO 2631-1 basic method).

    Parameters
    ----------
    a : ndarray
        Acceleration samples [m/s²].
    fs : float
        Sample rate [Hz].
    kind : {"Wk", "Wd"}
        Weighting.
    discard : float
        Settling time [s] at the start excluded from the r.m.s. (the filter still runs).
    lowpass : bool or None
        See ``WeightingFilter``.
    """
    x = _as_signal(a)
    flt = WeightingFilter(fs, kind, lowpass)
    n0 = int(round(float(discard) * flt.fs))
    if not np.isfinite(discard) or discard < 0.0 or n0 >= x.size:
        raise ValueError(f"discard must be >= 0 and shorter than the signal, got {discard}")
    return float(np.sqrt(np.mean(flt.filter(x)[n0:] ** 2)))


def sperling_b(f: float | np.ndarray, direction: str = "vertical") -> np.ndarray:
    """Sperling weighting ``B(f)`` [-] for frequency ``f`` [Hz].

    ``B_h = 0.737 sqrt[(1.911 f² + (0.25 f²)²) / ((1 - 0.277 f²)² + (1.563 f - 0.0368 f³)²)]``,
    ``B_v = B_h / 1.25``.
    """
    f = np.asarray(f, dtype=float)
    num = 1.911 * f**2 + (0.25 * f**2) ** 2
    den = (1.0 - 0.277 * f**2) ** 2 + (1.563 * f - 0.0368 * f**3) ** 2
    b = 0.737 * np.sqrt(num / den)
    if direction == "horizontal":
        return b
    if direction == "vertical":
        return b / 1.25
    raise ValueError(f"direction must be 'vertical' or 'horizontal', got {direction!r}")


def sperling_wz(
    a: np.ndarray, fs: float, direction: str = "vertical", nperseg: int | None = None
) -> float:
    """Sperling ride index ``Wz = [int B²(f) G_a(f) df]^(1/6.67)`` over 0.5-30 Hz.

    Parameters
    ----------
    a : ndarray
        Acceleration samples [m/s²]; converted to cm/s² internally.
    fs : float
        Sample rate [Hz], must exceed 60 Hz so that the band reaches 30 Hz.
    direction : {"vertical", "horizontal"}
        Selects ``B_v`` or ``B_h``.
    nperseg : int or None
        Welch segment length (Hann window, 50 % overlap). Default: 4 s of samples
        (0.25 Hz resolution), or the whole signal if shorter.
    """
    x = _as_signal(a) * 100.0
    fs = float(fs)
    if not np.isfinite(fs) or fs <= 2.0 * _SPERLING_BAND[1]:
        raise ValueError(f"fs must exceed {2.0 * _SPERLING_BAND[1]} Hz, got {fs}")
    sperling_b(0.0, direction)  # validates direction
    if nperseg is None:
        nperseg = min(x.size, int(round(4.0 * fs)))
    if nperseg < 2 or nperseg > x.size:
        raise ValueError(f"nperseg must be in [2, len(a)] = [2, {x.size}], got {nperseg}")
    freq, g = signal.welch(x, fs=fs, window="hann", nperseg=nperseg, scaling="density")
    band = (freq >= _SPERLING_BAND[0]) & (freq <= _SPERLING_BAND[1])
    df = freq[1] - freq[0]
    integral = float(np.sum(sperling_b(freq[band], direction) ** 2 * g[band]) * df)
    return integral ** (1.0 / _SPERLING_EXPONENT)


def sperling_label(wz: float) -> str:
    """Sperling scale text for ride index ``wz``: the highest scale point not above it."""
    wz = float(wz)
    if not np.isfinite(wz) or wz < 0.0:
        raise ValueError(f"wz must be finite and >= 0, got {wz}")
    label = "not noticeable"
    for lower, text in SPERLING_SCALE:
        if wz >= lower:
            label = text
    return label


class RunningComfort:
    """Streaming ISO 2631-1 comfort statistics of one acceleration channel.

    Tracks the overall weighted r.m.s. ``a_w``, the running r.m.s. with exponential
    integration time ``tau`` (ISO 2631-1 eq. 2) and its maximum, the MTVV, the peak
    ``|a_w(t)|`` and the fourth-power vibration dose value VDV [m/s^1.75].

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    kind : {"Wk", "Wd"}
        Weighting.
    tau : float
        Running-r.m.s. integration time [s] (ISO recommends 1 s).
    discard : float
        Settling time [s] after ``reset`` excluded from all statistics.
    lowpass : bool or None
        See ``WeightingFilter``.
    """

    def __init__(
        self,
        fs: float,
        kind: str = "Wk",
        tau: float = 1.0,
        discard: float = 0.0,
        lowpass: bool | None = None,
    ) -> None:
        self.filter = WeightingFilter(fs, kind, lowpass)
        if not np.isfinite(tau) or tau <= 0.0:
            raise ValueError(f"tau must be > 0, got {tau}")
        if not np.isfinite(discard) or discard < 0.0:
            raise ValueError(f"discard must be >= 0, got {discard}")
        self.tau = float(tau)
        self._alpha = float(np.exp(-1.0 / (self.filter.fs * self.tau)))
        self._n_discard = int(round(discard * self.filter.fs))
        self.reset()

    def reset(self) -> None:
        """Clear the filter state and all statistics."""
        self.filter.reset()
        self._n_seen = 0
        self._n = 0
        self._sum2 = 0.0
        self._sum4 = 0.0
        self._run2 = 0.0
        self._mtvv = 0.0
        self._peak = 0.0

    def update(self, a_samples: np.ndarray | float) -> tuple[float, float]:
        """Feed the next samples [m/s²]; return ``(a_w, mtvv)`` so far [m/s²]."""
        y = self.filter.step(a_samples)
        skip = min(max(self._n_discard - self._n_seen, 0), y.size)
        self._n_seen += y.size
        # exponential running mean square, y2_n = alpha y2_{n-1} + (1 - alpha) a_n²
        run2, _ = signal.lfilter(
            [1.0 - self._alpha], [1.0, -self._alpha], y**2, zi=[self._alpha * self._run2]
        )
        self._run2 = float(run2[-1])
        y, run2 = y[skip:], run2[skip:]
        if y.size:
            self._n += y.size
            self._sum2 += float(np.sum(y**2))
            self._sum4 += float(np.sum(y**4))
            self._mtvv = max(self._mtvv, float(np.sqrt(run2.max())))
            self._peak = max(self._peak, float(np.abs(y).max()))
        return self.a_w, self._mtvv

    @property
    def a_w(self) -> float:
        """Overall weighted r.m.s. acceleration [m/s²] since the end of the settling time."""
        return float(np.sqrt(self._sum2 / self._n)) if self._n else 0.0

    def summary(self) -> dict[str, float]:
        """Statistics: a_w, mtvv, peak [m/s²], crest_factor, vdv [m/s^1.75], duration [s]."""
        a_w = self.a_w
        return {
            "a_w": a_w,
            "mtvv": self._mtvv,
            "peak": self._peak,
            "crest_factor": self._peak / a_w if a_w > 0.0 else 0.0,
            "vdv": (self._sum4 / self.filter.fs) ** 0.25,
            "duration": self._n / self.filter.fs,
        }


# --------------------------------------------------------------------- EN 12299 (vertical)
#: EN 12299 averaging window of the r.m.s. values that enter the comfort indices, s
EN12299_WINDOW = 5.0


def wb_weighting(f: float | np.ndarray, lowpass: bool = True) -> np.ndarray:
    """EN 12299 vertical weighting ``|W_b(j 2 pi f)|`` [-] at frequency ``f`` [Hz].

    The ISO 2631-4 / ISO 8041 filter (band limits 0.4 and 100 Hz, a-v transition at 16 Hz,
    upward step 2.5 -> 4 Hz, gain K = 1.024; parameters in the module docstring). Use
    ``WeightingFilter(fs, "Wb")`` or ``weighted_rms(a, fs, "Wb")`` to weight signals.
    """
    return wk_gain(f, "Wb", lowpass)


def a_zp95(
    a: np.ndarray,
    fs: float,
    window: float = EN12299_WINDOW,
    lowpass: bool | None = None,
) -> float:
    """95th percentile of the ``window``-s r.m.s. of the Wb-weighted vertical acceleration.

    EN 12299's ``a_ZP95^Wb`` [m/s²], the vertical term of the mean comfort index
    ``N_MV = 6 sqrt(a_XP95² + a_YP95² + a_ZP95²)``: the signal [m/s²] sampled at ``fs`` [Hz]
    is Wb-weighted (filter from rest), cut into consecutive windows (an incomplete last one
    is dropped) and the percentile of their r.m.s. values taken with linear interpolation.
    The standard evaluates 60 windows (5 min); shorter records give fewer windows.
    """
    x = _as_signal(a)
    flt = WeightingFilter(fs, "Wb", lowpass)
    return float(window_rms_p95(flt.filter(x), flt.fs, window))


def window_rms_p95(y: np.ndarray, fs: float, window: float = EN12299_WINDOW) -> np.ndarray:
    """95th percentile of the r.m.s. over consecutive ``window``-s blocks of the already
    weighted signal(s) ``y`` [m/s²] (samples along axis 0; an incomplete last block is
    dropped), linear interpolation; one value per channel (the core of :func:`a_zp95`)."""
    y = np.asarray(y, dtype=float)
    n_win = int(round(float(window) * float(fs)))
    if not np.isfinite(window) or n_win < 1 or n_win > y.shape[0]:
        raise ValueError(f"window must be > 0 s and not longer than the signal, got {window}")
    n_blocks = y.shape[0] // n_win
    blocks = y[: n_blocks * n_win].reshape(n_blocks, n_win, *y.shape[1:])
    return np.percentile(np.sqrt(np.mean(blocks**2, axis=1)), 95.0, axis=0)
