"""Data-collection designs that cover the operating envelope of the vertical model.

The paper trains its element on one passive run (FRA class 5, 144 km/h, 20 s at 50 Hz):
``design="paper"``. Agents and other track classes visit states that run never shows
(bump-stop contacts, large actuator forces). ``design="envelope"`` runs the reference model
over several track classes, speeds and seeds, each once passive and once with the actuator
driven by a band-limited random force of peak ``f_max``, so that those states are in the data.

Every run is recorded at the integration step (the memory features of
:mod:`surrogates.memory` need the full-rate history); ``rows`` marks the samples at
``sample_rate`` used for training. The secondary-suspension force ``F_s`` is the output
(``m2·ẍ2 − F_a`` when the actuator acts).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from railgym import _checks as val
from railgym.track import class_speed, track_time_input
from railgym.vehicles.vertical.kernels import DEFAULT_DT
from railgym.vehicles.vertical.params import load_vehicle
from railgym.vehicles.vertical.simulate import simulate

DESIGNS = ("paper", "envelope")
#: sample rate of the memory element's training data and of the refinement samples, Hz
MEMORY_SAMPLE_RATE = 200.0


def _number(v: Any) -> float | None:
    """``v`` as a finite float, or ``None`` when it is not a finite real number."""
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        return None
    x = float(v)
    return x if np.isfinite(x) else None


def _count(v: Any) -> bool:
    """True for a non-negative integer (not a bool)."""
    return isinstance(v, (int, np.integer)) and not isinstance(v, bool) and int(v) >= 0


@dataclass(frozen=True)
class CollectionDesign:
    """Runs of a data collection: every class × speed factor × seed, passive and excited.

    Attributes
    ----------
    track_classes : FRA classes.
    speed_factors : running speeds as fractions of each class's maximum speed.
    seeds : track seeds (each excited run's actuator signal is seeded from its track seed
        and its case number).
    duration : s per run. sample_rate : Hz of the training samples (50 Hz, 20 s → 1001).
    f_max : peak actuator force of the excited runs, N (0: passive runs only).
    band : upper frequency of the random actuator force, Hz.
    speeds : absolute speeds in m/s overriding ``speed_factors`` (the paper's 40 m/s).
    """

    track_classes: tuple[int, ...] = (3, 4, 5, 6)
    speed_factors: tuple[float, ...] = (0.7, 1.0)
    seeds: tuple[int, ...] = (0,)
    duration: float = 20.0
    sample_rate: float = 50.0
    f_max: float = 8000.0
    band: float = 5.0
    speeds: tuple[float, ...] = field(default=())

    def __post_init__(self) -> None:
        for name in ("track_classes", "seeds"):
            values = getattr(self, name)
            if not values or not all(_count(v) for v in values):
                raise ValueError(f"design.{name} must be a non-empty tuple of integers >= 0")
        for name in ("speed_factors", "speeds"):
            values = getattr(self, name)
            if not all((_number(v) or 0.0) > 0 for v in values):
                raise ValueError(f"design.{name} must hold positive numbers, got {values!r}")
        if not self.speed_factors and not self.speeds:
            raise ValueError("design needs speed_factors or speeds")
        for name in ("duration", "sample_rate", "band"):
            v = getattr(self, name)
            if not (_number(v) or 0.0) > 0:
                raise ValueError(f"design.{name} must be a positive number, got {v!r}")
        f_max = _number(self.f_max)
        if f_max is None or f_max < 0:
            raise ValueError(f"design.f_max must be a non-negative force in N, got {self.f_max!r}")

    def cases(self) -> list[tuple[int, float, int]]:
        """``(track_class, speed m/s, seed)`` of every track run."""
        out = []
        for c in self.track_classes:
            speeds = self.speeds or tuple(f * class_speed(c) for f in self.speed_factors)
            out += [(c, float(v), s) for v in speeds for s in self.seeds]
        return out


#: the paper's single passive class-5 run (section 4.1)
PAPER = CollectionDesign(track_classes=(5,), speeds=(40.0,), seeds=(0,), f_max=0.0)
ENVELOPE = CollectionDesign()


def design_named(design: str | CollectionDesign) -> CollectionDesign:
    """``"paper"``, ``"envelope"`` or a :class:`CollectionDesign` (returned as is)."""
    if isinstance(design, CollectionDesign):
        return design
    if design == "paper":
        return PAPER
    if design == "envelope":
        return ENVELOPE
    raise ValueError(f"design must be one of {DESIGNS} or a CollectionDesign, got {design!r}")


def band_limited_force(n: int, dt: float, band: float, f_max: float, seed: Any) -> np.ndarray:
    """Random actuator force (n,), N: Gaussian noise low-passed to ``band`` Hz (ideal
    filter, FFT), scaled so that its peak ``max|F|`` is exactly ``f_max``."""
    if n < 2:
        raise ValueError(f"n must be at least 2 samples, got {n}")
    rng = np.random.default_rng(val.random_seed(seed, "seed"))
    spectrum = np.fft.rfft(rng.standard_normal(n))
    spectrum[np.fft.rfftfreq(n, dt) > band] = 0.0
    spectrum[0] = 0.0
    g = np.fft.irfft(spectrum, n)
    peak = np.max(np.abs(g))
    if peak == 0.0:
        raise ValueError(f"band {band} Hz is below the frequency resolution 1/(n·dt)")
    return f_max * g / peak


def run_record(
    case: tuple[int, float, int], excited: bool, rec: dict[str, Any], fa: np.ndarray, every: int
) -> dict[str, Any]:
    """The run dict of :func:`collect_design` of the track ``case`` ``(track_class, speed m/s,
    seed)`` from its :func:`~railgym.vehicles.vertical.simulate` record ``rec``, actuator force
    ``fa`` (N) and training samples every ``every`` steps."""
    m = rec["t"].size
    return {
        "track_class": case[0],
        "speed": case[1],
        "seed": case[2],
        "excited": excited,
        "t": rec["t"],
        "delta": rec["x1"] - rec["x2"],
        "delta_dot": rec["v1"] - rec["v2"],
        "force": rec["F_s"],
        "force_a": fa[: m - 1],
        "a2": rec["a2"],
        "contacts": rec["contacts"],
        "rows": np.arange(0, m, every),
    }


def collect_design(
    design: str | CollectionDesign = "envelope",
    vehicle: Any = "manchester",
    variant: str = "dynamic",
    dt: float | None = None,
    progress: Callable[[int, int], None] | None = None,
    run: Any = None,
) -> dict[str, Any]:
    """Run the reference model over a design and return its training data; ``progress(i,
    total)`` is called after each of the design's cases.

    ``run(z, zdot, dt, force_a)``, when given, replaces the built-in model: a record as
    :func:`~railgym.vehicles.vertical.simulate` returns (``t, x1, v1, x2, v2, a2, F_s,
    contacts``), e.g. an FMU's (:func:`railgym.fmu.collect.collect_fmu`).

    Returns
    -------
    dict
        ``runs``: one dict per run with ``track_class, speed, seed, excited`` and the
        full-rate histories ``t`` (s), ``delta`` (m), ``delta_dot`` (m/s), ``force`` (F_s, N),
        ``a2`` (carbody acceleration, m/s²), ``force_a`` (N, one value per step, held from
        ``t[k]`` to ``t[k+1]``; one shorter than ``t``), ``contacts`` (substeps in bump-stop
        contact) and the indices ``rows`` of the samples at
        ``sample_rate``; ``U`` (n, 2) = (δ, δ̇) and ``V`` (n,) = F_s of those samples of all
        runs; ``design`` the :class:`CollectionDesign`.
    """
    design = design_named(design)
    veh = load_vehicle(vehicle)
    dt = DEFAULT_DT[variant] if dt is None else dt
    every = round(1.0 / (design.sample_rate * dt))
    if every < 1 or not np.isclose(every * dt * design.sample_rate, 1.0):
        raise ValueError(
            f"design.sample_rate {design.sample_rate} Hz is not a whole number of steps of {dt} s"
        )
    runs = []
    cases = list(design.cases())
    for case, (track_class, speed, seed) in enumerate(cases):
        _, z, zdot = track_time_input(track_class, speed, design.duration, dt, seed)
        excitations = [False, True] if design.f_max > 0 else [False]
        for excited in excitations:
            n = z.size - 1
            fa = (
                band_limited_force(n, dt, design.band, design.f_max, [seed, case])
                if excited
                else np.zeros(n)
            )
            rec = (
                simulate(variant, veh, z, zdot, dt, force_a=fa)
                if run is None
                else run(z, zdot, dt, fa)
            )
            runs.append(run_record((track_class, speed, seed), excited, rec, fa, every))
        if progress is not None:
            progress(case + 1, len(cases))
    U = np.concatenate([np.column_stack([r["delta"], r["delta_dot"]])[r["rows"]] for r in runs])
    V = np.concatenate([r["force"][r["rows"]] for r in runs])
    return {"runs": runs, "U": U, "V": V, "design": design}


__all__ = [
    "DESIGNS",
    "ENVELOPE",
    "MEMORY_SAMPLE_RATE",
    "PAPER",
    "CollectionDesign",
    "band_limited_force",
    "collect_design",
    "design_named",
    "run_record",
]
