"""Comfort figures of the floor accelerations accumulated online, a control step at a time:
the memory of ``VerticalVehicle-v3`` does not grow with the episode.

The three figures of :func:`~railgym.envs.vehicle.batch.episode_comfort` from recursive
filters stepped inside the compiled step (second-order sections in transposed direct form II,
:func:`~railgym.envs.compiled.weigh`, starting at rest as there):

* ``a_w``: ISO 2631-1 Wk-weighted r.m.s., the mean square of the Wk output summed online
  (the same filter as the record's figure: equal to rounding);
* ``a_ZP95_Wb``: EN 12299 95th percentile of the 5-s r.m.s. of the Wb-weighted signal; the
  r.m.s. of each completed 5-s block is kept (one value per block and floor point: 120 blocks
  for 600 s), the percentile taken at the end (one window of the whole record when shorter);
* ``Wz``: Sperling ride index ``[∫ B² G_a df]^(1/6.67)`` (a in cm/s²) as the mean square of
  the acceleration through a filter of gain B(f) (its rational form in p = j·f,
  B_v = 0.737/1.25·(√1.911·p + 0.25·p²)/(1 + 1.563·p + 0.277·p² + 0.0368·p³)) band-limited
  to 0.5–30 Hz by fourth-order Butterworth edges (pre-warped; 30 Hz only below the Nyquist
  frequency), bilinear transform; the record's figure integrates a Welch estimate over the
  same band instead (docs/envs/vehicle_vertical.md compares them).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from scipy import signal

from railgym.comfort import EN12299_WINDOW, WeightingFilter
from railgym.envs.compiled import weigh

__all__ = [
    "ComfortArrays",
    "ComfortCfg",
    "comfort_figures",
    "comfort_step",
    "new_comfort",
    "sperling_sections",
]

#: channels (floor points front, centre, rear)
N_POINTS = 3
#: Sperling band, Hz, and its exponent
_BAND = (0.5, 30.0)
_EXPONENT = 6.67


class ComfortArrays(NamedTuple):
    """Online comfort state of ``n`` vehicles."""

    zi_k: np.ndarray  #: (n, 3, n_k, 2) Wk filter state per floor point
    zi_b: np.ndarray  #: (n, 3, n_b, 2) Wb filter state
    zi_s: np.ndarray  #: (n, 3, n_s, 2) Sperling filter state
    sq: np.ndarray  #: (n, 3, 3) sums of squares of the Wk, Wb and Sperling outputs per point
    block: np.ndarray  #: (n, 3) sum of squares of the Wb output in the current 5-s block
    blocks: np.ndarray  #: (n, n_blocks, 3) r.m.s. of the completed 5-s blocks, m/s²


class ComfortCfg(NamedTuple):
    """Filters and block length of :func:`comfort_step`."""

    sos_k: np.ndarray  #: (n_k, 6) Wk
    sos_b: np.ndarray  #: (n_b, 6) Wb
    sos_s: np.ndarray  #: (n_s, 6) Sperling B(f), 0.5–30 Hz
    n_win: int  #: control steps per 5-s block


def sperling_sections(fs: float) -> np.ndarray:
    """Second-order sections (n, 6) of the vertical Sperling weighting B_v(f) band-limited
    to 0.5–30 Hz at the sample rate ``fs`` (Hz)."""
    two_pi = 2.0 * math.pi
    gain = 0.737 / 1.25
    num = gain * np.array([0.25 / two_pi**2, math.sqrt(1.911) / two_pi, 0.0])
    den = np.array([0.0368 / two_pi**3, 0.277 / two_pi**2, 1.563 / two_pi, 1.0])
    z, p, k = signal.tf2zpk(num, den)
    warped = [2.0 * fs * math.tan(math.pi * f / fs) for f in _BAND if f < 0.5 * fs]
    if len(warped) == 2:  # the edges pre-warped to their frequencies
        edges = signal.butter(4, warped, "bandpass", analog=True, output="zpk")
    else:
        edges = signal.butter(4, warped[0], "highpass", analog=True, output="zpk")
    z = np.concatenate([z, edges[0]])
    p = np.concatenate([p, edges[1]])
    zd, pd, kd = signal.bilinear_zpk(z, p, k * edges[2], fs)
    return signal.zpk2sos(zd, pd, kd)


def new_comfort(n: int, control_dt: float, duration: float) -> tuple[ComfortArrays, ComfortCfg]:
    """Zeroed :class:`ComfortArrays` of ``n`` vehicles and the :class:`ComfortCfg` of the
    control step ``control_dt`` (s), blocks for episodes up to ``duration`` (s)."""
    fs = 1.0 / control_dt
    cfg = ComfortCfg(
        WeightingFilter(fs, "Wk", lowpass=False).sos,
        WeightingFilter(fs, "Wb", lowpass=False).sos,
        sperling_sections(fs),
        int(round(EN12299_WINDOW * fs)),
    )
    n_blocks = max(int(round(duration * fs)) // cfg.n_win, 1)
    zk, zb, zs = (np.zeros((n, N_POINTS, s.shape[0], 2)) for s in cfg[:3])
    c = ComfortArrays(
        zk,
        zb,
        zs,
        np.zeros((n, 3, N_POINTS)),
        np.zeros((n, N_POINTS)),
        np.zeros((n, n_blocks, N_POINTS)),
    )
    return c, cfg


@njit(cache=True, error_model="numpy", _nrt=False)
def comfort_step(c, cc, acc, steps, i):
    """Vehicle ``i``'s floor accelerations ``acc[i, :3]`` (m/s²) of its control step number
    ``steps[i]`` (counted from 1) into its online figures."""
    for j in range(N_POINTS):
        a = acc[i, j]
        yk = weigh(cc.sos_k, c.zi_k[i, j], a)
        yb = weigh(cc.sos_b, c.zi_b[i, j], a)
        ys = weigh(cc.sos_s, c.zi_s[i, j], a)
        c.sq[i, 0, j] += yk * yk
        c.sq[i, 1, j] += yb * yb
        c.sq[i, 2, j] += ys * ys
        c.block[i, j] += yb * yb
    if steps[i] % cc.n_win == 0:
        b = steps[i] // cc.n_win - 1
        if b < c.blocks.shape[1]:
            for j in range(N_POINTS):
                c.blocks[i, b, j] = math.sqrt(c.block[i, j] / cc.n_win)
        for j in range(N_POINTS):
            c.block[i, j] = 0.0


def comfort_figures(
    c: ComfortArrays, cc: ComfortCfg, i: int, steps: int, min_steps: int
) -> dict[str, np.ndarray]:
    """``a_w``, ``a_ZP95_Wb`` (m/s²) and ``Wz`` per floor point of vehicle ``i`` after
    ``steps`` control steps; zeros below ``min_steps``."""
    if steps < min_steps:
        return {k: np.zeros(N_POINTS) for k in ("a_w", "a_ZP95_Wb", "Wz")}
    ms = c.sq[i] / steps
    n_blocks = steps // cc.n_win
    if n_blocks == 0:
        p95 = np.sqrt(ms[1])
    else:
        p95 = np.percentile(c.blocks[i, :n_blocks], 95.0, axis=0)
    return {"a_w": np.sqrt(ms[0]), "a_ZP95_Wb": p95, "Wz": (1e4 * ms[2]) ** (1.0 / _EXPONENT)}
