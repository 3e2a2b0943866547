"""Data collection and feature extraction (paper section 3.1).

A :class:`TimeHistory` holds recorded channels on a common time base. Two feature sets turn
it into surrogate training data ``(U, V)``:

* vertical dynamics (eqs. 1–2): the secondary suspension force of a body of mass ``m2`` is
  learnt as ``v = m2·ẍ2 = F(x1 − x2, ẋ1 − ẋ2)``: :func:`vertical_features`;
* longitudinal crash (eqs. 3–4): the wall force ``f1 = G1(x1)`` and the interface force
  ``f2 = G2(x1 − x2)``, each split into a loading and an unloading branch by the sign of the
  deformation rate: :func:`split_branches`, :func:`crash_features`. Deformations are crush,
  positive in compression, as in the paper's ``f1 ≈ k1·x1``, ``f2 ≈ k2·(x1 − x2)``.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from numbers import Real
from types import MappingProxyType
from typing import Any

import numpy as np

LOADING = 1
UNLOADING = -1
CRASH_KEYS = ("wall_loading", "wall_unloading", "interface_loading", "interface_unloading")


def _finite_number(x: Any) -> float | None:
    """``x`` as a float if it is a finite real number (Python or numpy, not a bool), else None."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, Real):
        return None
    value = float(x)
    return value if np.isfinite(value) else None


def finite_vector(x: Any, name: str, n: int | None = None) -> np.ndarray:
    """``x`` as a read-only finite 1-D float array (of length ``n`` if given)."""
    a = np.array(x, dtype=float)
    if a.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array, got shape {a.shape}")
    if n is not None and a.size != n:
        raise ValueError(f"{name} has {a.size} samples, expected {n}")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise ValueError(f"{name} has a non-finite value at index {bad[0]}: {a[bad[0]]}")
    a.flags.writeable = False
    return a


def time_base(t: Any, n: int | None = None) -> np.ndarray:
    """Time base (s): finite, 1-D, at least 2 samples, strictly increasing."""
    t = finite_vector(t, "t", n)
    if t.size < 2:
        raise ValueError(f"t needs at least 2 samples, got {t.size}")
    back = np.flatnonzero(np.diff(t) <= 0.0)
    if back.size:
        i = back[0] + 1
        raise ValueError(
            f"t must be strictly increasing: t[{i}] = {t[i]} <= t[{i - 1}] = {t[i - 1]}"
        )
    return t


class TimeHistory:
    """Recorded channels on a common, strictly increasing time base.

    Parameters
    ----------
    t : sample times (n,), s.
    channels : name → samples (n,); every array 1-D, finite, as long as ``t``.
    units : name → unit string (e.g. ``{"x1": "m"}``); ``"t"`` defaults to ``"s"``.

    ``th["x1"]`` returns a channel (``th["t"]`` the time); arrays are read-only copies.
    Bad input raises ``ValueError`` naming the channel (and the first bad index).
    """

    def __init__(
        self, t: Any, channels: Mapping[str, Any], units: Mapping[str, str] | None = None
    ) -> None:
        self._t = time_base(t)
        n = self._t.size
        if not channels:
            raise ValueError("channels is empty")
        data: dict[str, np.ndarray] = {}
        for name, values in channels.items():
            if not isinstance(name, str) or not name:
                raise ValueError(f"channel names must be non-empty strings, got {name!r}")
            if name == "t":
                raise ValueError("channel name 't' is reserved for the time base")
            data[name] = finite_vector(values, f"channel {name!r}", n)
        all_units = {"t": "s", **(units or {})}
        for name, unit in all_units.items():
            if name != "t" and name not in data:
                raise ValueError(f"units names {name!r}, which is not a channel")
            if not isinstance(unit, str):
                raise ValueError(f"unit of {name!r} must be a string, got {unit!r}")
        self._channels = MappingProxyType(data)
        self._units = MappingProxyType(all_units)

    @property
    def t(self) -> np.ndarray:
        """Sample times (n,), s."""
        return self._t

    @property
    def channels(self) -> Mapping[str, np.ndarray]:
        """Read-only mapping name → samples (n,)."""
        return self._channels

    @property
    def units(self) -> Mapping[str, str]:
        """Read-only mapping name → unit (channels without a unit are absent)."""
        return self._units

    @property
    def names(self) -> tuple[str, ...]:
        """Channel names in insertion order."""
        return tuple(self._channels)

    @property
    def sample_rate(self) -> float:
        """Mean sample rate (n − 1)/(t[-1] − t[0]), Hz."""
        return (self._t.size - 1) / float(self._t[-1] - self._t[0])

    def __getitem__(self, name: str) -> np.ndarray:
        if name == "t":
            return self._t
        try:
            return self._channels[name]
        except KeyError:
            raise KeyError(f"no channel {name!r}; channels: {list(self._channels)}") from None

    def __contains__(self, name: object) -> bool:
        return name == "t" or name in self._channels

    def __iter__(self) -> Iterator[str]:
        return iter(self._channels)

    def __len__(self) -> int:
        """Number of samples."""
        return self._t.size

    def __repr__(self) -> str:
        chans = ", ".join(f"{k} [{self._units[k]}]" if k in self._units else k for k in self)
        return f"TimeHistory(n={len(self)}, {self.sample_rate:.6g} Hz, channels: {chans})"


def _channel(th: TimeHistory, name: str, role: str) -> np.ndarray:
    if not isinstance(th, TimeHistory):
        raise ValueError(f"th must be a TimeHistory, got {type(th).__name__}")
    if name not in th.channels:
        raise ValueError(f"{role}: no channel {name!r} in the time history {list(th.names)}")
    return th[name]


# --------------------------------------------------------------------------------------
# vertical dynamics


def vertical_features(
    x1: Any, x2: Any, v1: Any, v2: Any, a2: Any, m2: float
) -> tuple[np.ndarray, np.ndarray]:
    """Training data of the secondary suspension (paper eqs. 1–2).

    Parameters
    ----------
    x1, x2 : bogie and body displacements (n,), m.
    v1, v2 : bogie and body velocities (n,), m/s.
    a2 : body acceleration (n,), m/s².
    m2 : body mass, kg (> 0).

    Returns
    -------
    U : (n, 2) inputs ``[x1 − x2, v1 − v2]`` (m, m/s).
    V : (n,) suspension force on the body ``m2·a2``, N.
    """
    mass = _finite_number(m2)
    if mass is None or mass <= 0:
        raise ValueError(f"m2 must be a positive finite mass in kg, got {m2!r}")
    x1 = finite_vector(x1, "x1")
    n = x1.size
    x2, v1, v2, a2 = (
        finite_vector(a, name, n) for a, name in ((x2, "x2"), (v1, "v1"), (v2, "v2"), (a2, "a2"))
    )
    return np.column_stack([x1 - x2, v1 - v2]), mass * a2


def vertical_features_from(
    th: TimeHistory,
    m2: float,
    *,
    x1: str = "x1",
    x2: str = "x2",
    v1: str = "v1",
    v2: str = "v2",
    a2: str = "a2",
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`vertical_features` of the channels of ``th`` named by ``x1`` … ``a2``."""
    names = {"x1": x1, "x2": x2, "v1": v1, "v2": v2, "a2": a2}
    arrays = {role: _channel(th, name, role) for role, name in names.items()}
    return vertical_features(**arrays, m2=m2)


# --------------------------------------------------------------------------------------
# crash: loading / unloading branches


def _merge_short_runs(labels: np.ndarray, min_length: int) -> np.ndarray:
    """Merge runs shorter than ``min_length`` into their neighbours, shortest first."""
    bounds = np.concatenate([[0], np.flatnonzero(np.diff(labels)) + 1, [labels.size]])
    lengths, values = np.diff(bounds), labels[bounds[:-1]]
    while lengths.size > 1:
        k = int(np.argmin(lengths))
        if lengths[k] >= min_length:
            break
        lo, hi = max(k - 1, 0), min(k + 1, lengths.size - 1)  # run k joins both neighbours
        value = values[lo] if k > 0 else values[hi]
        lengths = np.concatenate([lengths[:lo], [lengths[lo : hi + 1].sum()], lengths[hi + 1 :]])
        values = np.concatenate([values[:lo], [value], values[hi + 1 :]])
    return np.repeat(values, lengths)


def split_branches(
    deformation: Any, t: Any = None, *, min_length: int = 3, tol: float = 0.05
) -> np.ndarray:
    """Label each sample as loading (+1, deformation increasing) or unloading (−1).

    Sample ``i`` takes the sign of the rate from sample ``i − 1`` to ``i`` (sample 0 that of
    sample 1), with hysteresis: the label changes only when the rate passes ``±tol·s``, where
    ``s`` is the 90th percentile of |rate|, so plateaus and small noise keep the current label.
    Runs shorter than ``min_length`` samples are then merged into their neighbours (shortest
    first), so no run is shorter than ``min_length`` unless the whole record is.

    Parameters
    ----------
    deformation : crush (n,), m, positive in compression.
    t : sample times (n,), s; default equally spaced.
    min_length : shortest run kept, samples (>= 1; 1 merges nothing).
    tol : hysteresis threshold relative to the rate scale (>= 0).

    Returns
    -------
    labels : (n,) int8 array of ``LOADING`` (+1) / ``UNLOADING`` (−1); all loading when the
    deformation never moves.
    """
    d = finite_vector(deformation, "deformation")
    if d.size < 2:
        raise ValueError(f"deformation needs at least 2 samples, got {d.size}")
    if isinstance(min_length, bool) or not isinstance(min_length, int | np.integer):
        raise ValueError(f"min_length must be an integer, got {min_length!r}")
    if min_length < 1:
        raise ValueError(f"min_length must be >= 1, got {min_length}")
    tol_ = _finite_number(tol)
    if tol_ is None or tol_ < 0:
        raise ValueError(f"tol must be a finite number >= 0, got {tol!r}")
    dt = np.ones(d.size - 1) if t is None else np.diff(time_base(t, d.size))
    rate = np.diff(d) / dt
    speed = np.abs(rate)
    scale = np.quantile(speed, 0.9)
    if scale == 0.0:  # mostly at rest: scale by the fastest move instead
        scale = speed.max()
    threshold = tol_ * scale
    sign = np.where(rate > threshold, LOADING, np.where(rate < -threshold, UNLOADING, 0))
    moved = np.flatnonzero(sign)
    if moved.size == 0:
        return np.full(d.size, LOADING, dtype=np.int8)
    last = np.maximum.accumulate(np.where(sign != 0, np.arange(sign.size), -1))
    held = np.where(last >= 0, sign[np.maximum(last, 0)], sign[moved[0]])
    labels = np.concatenate([held[:1], held]).astype(np.int8)
    return _merge_short_runs(labels, int(min_length))


def crash_features(
    t: Any,
    x1: Any,
    x2: Any,
    f1: Any,
    f2: Any,
    *,
    min_length: int = 3,
    tol: float = 0.05,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Training data of the two crash elements (paper eqs. 3–4), split into branches.

    Parameters
    ----------
    t : sample times (n,), s.
    x1 : lead-car crush against the wall (n,), m; the wall element's deformation.
    x2 : passenger-car displacement (n,), m; the interface deformation is ``x1 − x2``.
    f1, f2 : wall and interface forces (n,), N.
    min_length, tol : see :func:`split_branches`.

    Returns
    -------
    ``{"wall_loading": (U, V), "wall_unloading": ..., "interface_loading": ...,
    "interface_unloading": ...}`` with ``U`` (k, 1) the deformation (m) and ``V`` (k,) the
    force (N) of the samples of that branch; loading = deformation increasing.
    """
    t = time_base(t)
    n = t.size
    x1, x2, f1, f2 = (
        finite_vector(a, name, n) for a, name in ((x1, "x1"), (x2, "x2"), (f1, "f1"), (f2, "f2"))
    )
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for element, deformation, force in (("wall", x1, f1), ("interface", x1 - x2, f2)):
        labels = split_branches(deformation, t, min_length=min_length, tol=tol)
        for branch, label in (("loading", LOADING), ("unloading", UNLOADING)):
            mask = labels == label
            out[f"{element}_{branch}"] = (deformation[mask][:, None], force[mask])
    return out


def crash_features_from(
    th: TimeHistory,
    *,
    x1: str = "x1",
    x2: str = "x2",
    f1: str = "f1",
    f2: str = "f2",
    min_length: int = 3,
    tol: float = 0.05,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """:func:`crash_features` of the channels of ``th`` named by ``x1``, ``x2``, ``f1``, ``f2``."""
    names = {"x1": x1, "x2": x2, "f1": f1, "f2": f2}
    arrays = {role: _channel(th, name, role) for role, name in names.items()}
    return crash_features(th.t, **arrays, min_length=min_length, tol=tol)
