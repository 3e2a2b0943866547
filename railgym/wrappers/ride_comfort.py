"""Ride comfort of an episode: ISO 2631-1 weighted r.m.s. acceleration and Sperling's Wz.

The wrapped env reports the carbody acceleration in ``info`` once per control step, so the
weighting runs at the control rate. At the default 100 Hz of the railgym envs the ISO 2631-1
band-limiting low-pass at 100 Hz cannot be represented and is dropped (analog gain
``1/√(1 + (f/100 Hz)⁴)``: < 0.5 % below 30 Hz); the discrete Wk filter then matches the
standard's gain within 0.3 % up to 10 Hz, 1 % at 16 Hz and 2.5 % at 20 Hz
(:mod:`railgym.comfort`). At control rates above 200 Hz the low-pass is kept (< 0.1 % up to
80 Hz at 1 kHz). Content above the Nyquist frequency of the control rate is not seen.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from railgym import _checks as val
from railgym.comfort import RunningComfort, sperling_label, sperling_wz

#: low-pass corner of ISO 2631-1 (f2), Hz; representable only above 2·f2
_F2 = 100.0
#: Sperling's band reaches 30 Hz, so Wz needs a sample rate above this, Hz
_SPERLING_MIN_FS = 60.0


def _control_rate(env: gym.Env) -> float:
    """Control rate (Hz) of ``env`` from ``env.unwrapped.cfg.control_dt`` (s)."""
    control_dt = getattr(getattr(env.unwrapped, "cfg", None), "control_dt", None)
    if control_dt is None:
        raise ValueError(
            f"fs: cannot read the control rate of {type(env.unwrapped).__name__} "
            "(no cfg.control_dt); pass fs= in Hz"
        )
    return 1.0 / float(control_dt)


#: highest sample rate of ``fs``, Hz (the weighting filters are designed up to it)
MAX_FS = 1e6


def _sample_rate(env: gym.Env, fs: Any) -> float:
    """``fs`` (Hz), else the env's control rate; a given ``fs`` must be the control rate of
    an env that has one (a FieldError naming ``fs`` otherwise: the statistics would be those
    of another rate)."""
    if fs is None:
        return _control_rate(env)
    fs = val.positive(fs, "fs", MAX_FS)
    control_dt = getattr(getattr(env.unwrapped, "cfg", None), "control_dt", None)
    if control_dt is not None and not math.isclose(fs * float(control_dt), 1.0, rel_tol=1e-9):
        raise val.FieldError(
            "fs",
            f"({fs:g} Hz) is not the env's control rate 1/control_dt = "
            f"{1.0 / float(control_dt):g} Hz; leave fs out (it is read from the env)",
        )
    return fs


class RideComfort(gym.Wrapper):
    """ISO 2631-1 and Sperling ride comfort of the acceleration in ``info[acc_key]``.

    Parameters
    ----------
    env : env whose ``step`` info holds one acceleration sample (m/s²) per step.
    kind : ``"Wk"`` (vertical, default) or ``"Wd"`` (horizontal) ISO 2631-1 weighting;
        Sperling's Wz uses the matching direction.
    reward_weight : ``w ≥ 0`` of the comfort reward term: the step reward becomes
        ``r − w·(a_w,k / acc_ref)²`` with ``a_w,k`` this step's weighted acceleration.
        0 (default) leaves the reward unchanged.
    fs : sample (control) rate, Hz, ≥ 50; ``None`` reads ``1 / env.unwrapped.cfg.control_dt``.
    acc_key : ``info`` key of the acceleration (default ``"carbody_acc"``).
    acc_ref : normalising acceleration of the reward term, m/s² (default 0.75, the vertical
        env's ``ACC_REF``).
    discard : settling time after ``reset`` left out of the statistics, s (filter still runs);
        shorter than the env's ``cfg.duration`` where it has one. An episode that ends inside
        the settling time raises ``ValueError`` (there is no sample to rate).
    tau : integration time of the running r.m.s. behind the MTVV, s.
    point : index into a vector acceleration (``VerticalVehicle-v1`` reports the floor points
        front, centre, rear): rate that point only. ``None`` (default) rates every point of a
        vector and the scalar of a scalar.

    Notes
    -----
    Every step ``info`` gains ``comfort_aw`` (overall weighted r.m.s. so far, m/s²) and
    ``comfort_acc_w`` (this step's weighted acceleration, m/s²); for a vector acceleration
    these are arrays with one value per point and the reward term takes the mean over the
    points of ``(a_w,k / acc_ref)²``. At episode end
    ``info["comfort"]`` holds ``a_w``, ``mtvv``, ``peak`` (largest |weighted acceleration|)
    (m/s²), ``crest_factor``, ``vdv`` (m/s^1.75), ``duration`` (s, after ``discard``),
    ``Wz`` (Sperling ride index of the unweighted samples; NaN when ``fs ≤ 60`` Hz or
    fewer than two samples), ``label`` (Sperling scale text, ``None`` without Wz),
    ``kind``, ``fs`` and ``lowpass`` (whether the 100 Hz band limit is included: only for
    ``fs > 200`` Hz). For a vector acceleration each statistic is an array with one value per
    point and ``label`` a list.
    """

    def __init__(
        self,
        env: gym.Env,
        kind: str = "Wk",
        reward_weight: float = 0.0,
        fs: float | None = None,
        acc_key: str = "carbody_acc",
        acc_ref: float = 0.75,
        discard: float = 0.0,
        tau: float = 1.0,
        point: int | None = None,
    ) -> None:
        super().__init__(env)
        fs = _sample_rate(env, fs)
        reward_weight = val.non_negative(reward_weight, "reward_weight")
        acc_ref = val.positive(acc_ref, "acc_ref")
        tau, discard = val.positive(tau, "tau"), val.non_negative(discard, "discard")
        if not isinstance(acc_key, str):
            raise val.FieldTypeError("acc_key", f"must be an info key (str), got {acc_key!r}")
        self.point = None if point is None else val.integer(point, "point", min=0)
        duration = getattr(getattr(env.unwrapped, "cfg", None), "duration", None)
        if duration is not None and discard >= float(duration):
            raise val.FieldError(
                "discard",
                f"({discard} s) must be shorter than the episode ({float(duration)} s): "
                "no sample would be left for the statistics",
            )
        lowpass = fs > 2.0 * _F2
        self.comfort = RunningComfort(fs, kind, tau=tau, discard=discard, lowpass=lowpass)
        # the same sections, run sample by sample in Python floats (a scipy call per
        # control step would cost several times the env step)
        self._sos = [tuple(float(c) for c in row) for row in self.comfort.filter.sos]
        self._zi: list[list[list[float]]] = []
        self.fs, self.kind, self.lowpass = float(fs), kind, lowpass
        self.reward_weight, self.acc_ref, self.acc_key = float(reward_weight), acc_ref, acc_key
        self._n_discard = int(round(discard * self.fs))
        self._samples: list[list[float]] = []
        self._sum2: list[float] = []
        self._vector = False

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the env and the comfort statistics."""
        self._zi = []
        self._samples = []
        self._sum2 = []
        return self.env.reset(seed=seed, options=options)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Step the env, feed its acceleration sample to the weighting filter."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        if self.acc_key not in info:
            raise ValueError(f"acc_key: the env's info has no {self.acc_key!r}")
        x = self._sample(info[self.acc_key])
        if not self._zi:  # first step: one filter state per point
            self._zi = [[[0.0, 0.0] for _ in self._sos] for _ in x]
            self._sum2 = [0.0] * len(x)
        self._samples.append(x)
        y = [self._weigh(xi, zi) for xi, zi in zip(x, self._zi, strict=True)]
        n = len(self._samples) - self._n_discard
        if n > 0:
            self._sum2 = [s2 + yi * yi for s2, yi in zip(self._sum2, y, strict=True)]
        aw = [math.sqrt(s2 / n) if n > 0 else 0.0 for s2 in self._sum2]
        info["comfort_aw"] = np.array(aw) if self._vector else aw[0]
        info["comfort_acc_w"] = np.array(y) if self._vector else y[0]
        if self.reward_weight:
            penalty = sum((yi / self.acc_ref) ** 2 for yi in y) / len(y)
            reward = float(reward) - self.reward_weight * penalty
        if terminated or truncated:
            info["comfort"] = self._summary()
        return obs, reward, terminated, truncated, info

    def _sample(self, value: Any) -> list[float]:
        """This step's acceleration (m/s²) as a list of one value per rated point."""
        a = np.asarray(value, dtype=float)
        if a.ndim > 1:
            raise ValueError(f"acc_key: info[{self.acc_key!r}] has shape {a.shape}, not a vector")
        if self.point is not None:
            if a.ndim == 0 or self.point >= a.size:
                raise val.FieldError(
                    "point", f"{self.point} is not an index of info[{self.acc_key!r}] {a.shape}"
                )
            a = a[self.point]
        self._vector = a.ndim == 1
        return [float(v) for v in a.reshape(-1)]

    def _weigh(self, x: float, zi: list[list[float]]) -> float:
        """Weighted acceleration (m/s²) of the next sample ``x`` (m/s²) of one point with
        filter state ``zi``: the cascade of second-order sections in transposed direct form
        II, as ``scipy.signal.sosfilt``."""
        for (b0, b1, b2, _, a1, a2), z in zip(self._sos, zi, strict=True):
            y = b0 * x + z[0]
            z[0] = b1 * x - a1 * y + z[1]
            z[1] = b2 * x - a2 * y
            x = y
        return x

    def _summary(self) -> dict[str, Any]:
        """Episode statistics, one dict entry per statistic (an array over points for a
        vector acceleration)."""
        samples = np.asarray(self._samples)  # (steps, points)
        if samples.shape[0] <= self._n_discard:
            raise val.FieldError(
                "discard",
                f"discard ({self._n_discard / self.fs} s): the episode ended after "
                f"{samples.shape[0] / self.fs} s, inside the settling time: no sample left "
                "to rate",
                full=True,
            )
        per_point = [self._point_summary(samples[:, j]) for j in range(samples.shape[1])]
        out: dict[str, Any]
        if self._vector:
            out = {k: np.array([p[k] for p in per_point]) for k in per_point[0] if k != "label"}
            out["label"] = [p["label"] for p in per_point]
        else:
            out = per_point[0]
        out.update(kind=self.kind, fs=self.fs, lowpass=self.lowpass)
        return out

    def _point_summary(self, samples: np.ndarray) -> dict[str, Any]:
        """Statistics of one point's samples (m/s²)."""
        self.comfort.reset()
        self.comfort.update(samples)
        out: dict[str, Any] = self.comfort.summary()
        x = samples[self._n_discard :]
        wz = math.nan
        if self.fs > _SPERLING_MIN_FS and x.size >= 2:
            direction = "vertical" if self.kind == "Wk" else "horizontal"
            wz = sperling_wz(x, self.fs, direction)
        out["Wz"] = wz
        out["label"] = sperling_label(wz) if math.isfinite(wz) else None
        return out
