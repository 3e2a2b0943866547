r"""The data-driven element of the controllable damper (:mod:`railgym.vehicles.semi_active`).

Built by the project's pipeline (:func:`surrogates.build`): the reference damper is driven by
random command and velocity histories (:func:`damper_runs`), its force is recorded with the
element's features, ``M`` space-filling training samples are picked by the GA maximin design,
the total degree of a Legendre regression with interactions is chosen on the out-of-bag
samples, and the memory's length ``ℓ`` is chosen the same way among a few values. The
element::

    u̇ = η (command − u)                     known physics, integrated exactly
    ṁ = v − |v| m / ℓ                        memory of the travel direction, |m| ≤ ℓ
    F̂ = P(v, u, m)                          Legendre polynomial of total degree D
    F = F̂ if F̂ v > 0 else 0                  known physics: the device's passivity

``v`` (m/s) is the compression rate, ``u`` the filtered command and ``m`` (m) a relaxation
memory: it relaxes towards ``ℓ·sign(v)`` over a travel ``ℓ`` (a time constant ``ℓ/|v|``), so
it records how far the damper has moved since its last reversal, as the Bouc–Wen variable
does. A memory that relaxes in time instead (``ṁ = (v − m)/τ``, features ``(v, u, v − m)``)
follows the velocity's recent history, not the travel since a reversal that sets the
pre-yield force of a rate-independent hysteresis, and fits this damper far worse. The fitted
output is the law's force before the passivity cut (``F_h`` of the reference); the
element applies the cut itself.

:func:`element_force` and :func:`element_rates` are the compiled, scalar, allocation-free
laws a vehicle kernel calls inside each RK4 stage with a :class:`DamperElementArrays`.
:func:`build_damper_element` builds an element (seeded, reproducible),
:meth:`DamperElement.save` and :func:`load_damper_element` write and read it through
:mod:`surrogates.io`. The packaged element ``railgym/data/damper_mr_secondary.json`` is
rebuilt by::

    railgym damper-element -o railgym/data/damper_mr_secondary.json --overwrite
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from railgym import _checks as val
from railgym.vehicles.semi_active import DamperParams, checked_history, simulate_damper
from surrogates import io
from surrogates.builder import build
from surrogates.checks import is_number
from surrogates.models.checks import ModelFieldError
from surrogates.models.lpr import LegendreRegression

__all__ = [
    "DT",
    "ELEMENT_KIND",
    "DamperElement",
    "DamperElementArrays",
    "build_damper_element",
    "command_history",
    "damper_runs",
    "element_cost",
    "element_force",
    "element_rates",
    "filtered_command",
    "heldout_error",
    "load_damper_element",
    "travel_memory",
    "velocity_history",
]

#: integration and sample step of the collected histories, s (the vertical kernels' step)
DT = 1e-3
#: steps a command is held (the 10 ms control period)
HOLD = 10
#: training runs, their length (s) and the rows taken from each (every ``EVERY`` steps)
RUNS, DURATION, EVERY = 24, 10.0, 10
#: start of each run left out of the training rows, s (≫ 1/η and ℓ/|v|)
WARMUP = 0.1
#: space-filling training samples M
SAMPLES = 600
#: candidate memory lengths ℓ, m, and total degrees D
LENGTHS = (1e-3, 2e-3, 3e-3, 4e-3)
DEGREES = tuple(range(3, 11))
#: range of the runs' peak velocity, m/s (a secondary suspension's relative velocity, up to
#: the peaks of FRA classes 3–4 at their maximum speed)
PEAK = (0.1, 1.0)
#: ``metadata.element`` of a saved damper element
ELEMENT_KIND = "semi_active_damper"
INPUTS = ("v", "u", "m")
UNITS = {"v": "m/s", "u": "1", "m": "m", "F": "N"}
_NAME = re.compile(r"[A-Za-z0-9_-]+")


# ---------------------------------------------------------------------- histories
def velocity_history(n: int, dt: float, peak: float, rng: np.random.Generator) -> np.ndarray:
    """Random velocity (n,), m/s, with the spectrum of a secondary suspension's relative
    velocity: a carbody-bounce peak at 1.2 Hz and a bogie band around 7 Hz, 0.2–13 Hz (half
    its power below 2 Hz, 99 % below 12 Hz, as the vertical vehicle's on FRA tracks), scaled
    to the peak ``max|v| = peak``."""
    f = np.fft.rfftfreq(n, dt)
    amp = 1.0 / np.sqrt(1.0 + ((f - 1.2) / 0.6) ** 2) + 0.3 / np.sqrt(1.0 + ((f - 7.0) / 2.5) ** 2)
    amp[(f < 0.2) | (f > 13.0)] = 0.0
    v = np.fft.irfft(amp * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)), n)
    return peak * v / np.abs(v).max()


def command_history(n: int, rng: np.random.Generator, hold: int = HOLD) -> np.ndarray:
    """Random piecewise-constant command (n,) in [0, 1], held ``hold`` steps: each hold keeps
    the previous value with a probability drawn per run (so that ``u`` reaches 0 and 1), its
    values uniform or on-off (0 or 1) by a draw per run."""
    slots = -(-n // hold)
    values = rng.uniform(0.0, 1.0, slots) if rng.random() < 0.5 else rng.integers(0, 2, slots)
    keep = rng.random(slots) < rng.uniform(0.0, 0.95)
    keep[0] = False
    last = np.maximum.accumulate(np.where(keep, 0, np.arange(slots)))
    return np.repeat(np.asarray(values, float)[last], hold)[:n]


def damper_runs(
    damper: DamperParams, seed: int, runs: int, duration: float, stream: int = 0
) -> list[dict[str, np.ndarray]]:
    """The reference damper over ``runs`` random histories of ``duration`` s at :data:`DT`.

    Run ``k`` is seeded by ``(seed, stream, k)``: stream 0 trains, stream 1 is held out.
    Each run holds ``t`` (s), ``v`` (m/s), ``command``, the force ``F`` (N), the law's force
    before the passivity cut ``F_h`` (N) and the reference's states ``u``, ``w``.
    """
    n = round(duration / DT) + 1
    out = []
    for k in range(runs):
        rng = np.random.default_rng([seed, stream, k])
        v = velocity_history(n, DT, rng.uniform(*PEAK), rng)
        command = command_history(n, rng)
        force, states = simulate_damper(v, command, DT, damper)
        u, w = states[:, 0], states[:, 1]
        f_h = (damper.c_a + damper.c_b * u) * v + (damper.f_a + damper.f_b * u) * w
        out.append(
            {"t": np.arange(n) * DT, "v": v, "command": command, "F": force, "F_h": f_h}
            | {"u": u, "w": w}
        )
    return out


@njit(cache=True, error_model="numpy")
def _filtered(command: np.ndarray, decay: float, u0: float) -> np.ndarray:
    u = np.empty(command.size)
    x = u0
    for k in range(command.size):
        u[k] = x
        x = command[k] + (x - command[k]) * decay
    return u


def filtered_command(command: np.ndarray, dt: float, eta: float, u0: float = 0.0) -> np.ndarray:
    """Filtered command ``u`` (n,) of ``u̇ = η (command − u)``, exact for a command held over
    each step of ``dt`` s (η in 1/s); ``u[0] = u0``."""
    c = np.ascontiguousarray(command, dtype=np.float64)
    return _filtered(c, math.exp(-eta * dt), float(u0))


@njit(cache=True, error_model="numpy")
def _memory_rate(v: float, m: float, length: float) -> float:
    return v - abs(v) * m / length


@njit(cache=True, error_model="numpy")
def _memory(v: np.ndarray, dt: float, length: float, m0: float) -> np.ndarray:
    m = np.empty(v.size)
    x = m0
    for k in range(v.size):
        m[k] = x
        if k == v.size - 1:
            break
        va, vb = v[k], v[k + 1]
        vm = 0.5 * (va + vb)
        k1 = _memory_rate(va, x, length)
        k2 = _memory_rate(vm, x + 0.5 * dt * k1, length)
        k3 = _memory_rate(vm, x + 0.5 * dt * k2, length)
        k4 = _memory_rate(vb, x + dt * k3, length)
        x += dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return m


def travel_memory(v: np.ndarray, dt: float, length: float, m0: float = 0.0) -> np.ndarray:
    """Memory ``m`` (n,), m, of ``ṁ = v − |v| m/ℓ`` along a velocity history (m/s) sampled at
    ``dt`` s, RK4 with ``v`` linear between samples (as a vehicle kernel integrates it);
    ``m[0] = m0``."""
    return _memory(np.ascontiguousarray(v, dtype=np.float64), float(dt), float(length), m0)


def _features(run: dict[str, np.ndarray], length: float, eta: float) -> np.ndarray:
    u = filtered_command(run["command"], DT, eta)
    return np.column_stack([run["v"], u, travel_memory(run["v"], DT, length)])


# ---------------------------------------------------------------------- compiled laws
class DamperElementArrays(NamedTuple):
    """A fitted damper element as plain arrays (the kernels' argument)."""

    #: float64 (D+1, D+1, D+1): coefficient of t_v^i·t_u^j·t_m^k (i + j + k ≤ D), the fitted
    #: Legendre terms in the power basis of the mapped inputs t ∈ [−1, 1]
    coef: np.ndarray
    lo: np.ndarray  #: float64 (3,): lower corner of the training box (v, u, m)
    up: np.ndarray  #: float64 (3,): upper corner
    scale: np.ndarray  #: float64 (3,): 2/(up − lo), the map to t ∈ [−1, 1]
    degree: int  #: total degree D (terms with i + j + k ≤ D)
    length: float  #: memory length ℓ of ṁ = v − |v| m/ℓ, m


@njit(cache=True, error_model="numpy")
def element_force(v: float, u: float, m: float, a: DamperElementArrays) -> float:
    """Force of the element on the carbody (N, in the direction of ``v``) at compression rate
    ``v`` (m/s), filtered command ``u`` and memory ``m`` (m); zero where it would supply power.

    Outside the training box ``u`` and ``m`` are clipped and the polynomial is extended
    linearly in ``v`` from the box's edge. Nested Horner sums over ``a.coef``.
    """
    vc = min(max(v, a.lo[0]), a.up[0])
    tv = (vc - a.lo[0]) * a.scale[0] - 1.0
    tu = (min(max(u, a.lo[1]), a.up[1]) - a.lo[1]) * a.scale[1] - 1.0
    tm = (min(max(m, a.lo[2]), a.up[2]) - a.lo[2]) * a.scale[2] - 1.0
    d = a.degree
    value = 0.0
    slope = 0.0  # d value / d t_v
    for i in range(d, -1, -1):
        s = 0.0
        for j in range(d - i, -1, -1):
            inner = 0.0
            for k in range(d - i - j, -1, -1):
                inner = inner * tm + a.coef[i, j, k]
            s = s * tu + inner
        slope = slope * tv + value
        value = value * tv + s
    f = value + slope * a.scale[0] * (v - vc)
    return f if f * v > 0.0 else 0.0


@njit(cache=True, error_model="numpy")
def element_rates(v: float, m: float, a: DamperElementArrays) -> float:
    """Rate ``ṁ = v − |v| m/ℓ`` (m/s) of the element's memory at compression rate ``v``
    (m/s); ``m = 0`` at rest."""
    return _memory_rate(v, m, a.length)


@njit(cache=True, error_model="numpy")
def _simulate(
    v: np.ndarray, u: np.ndarray, dt: float, a: DamperElementArrays, m0: float
) -> np.ndarray:
    m = _memory(v, dt, a.length, m0)
    force = np.empty(v.size)
    for k in range(v.size):
        force[k] = element_force(v[k], u[k], m[k], a)
    return force


def _power_basis(model: LegendreRegression) -> tuple[np.ndarray, int]:
    """The model's Legendre coefficients as a dense power-basis tensor and its total degree."""
    e = np.asarray(model.exponents_, dtype=np.int64)
    degree = int(e.sum(axis=1).max())
    legendre = np.zeros((degree + 1,) * 3)
    legendre[e[:, 0], e[:, 1], e[:, 2]] = model.coef_
    # column i: the power coefficients of P_i
    basis = np.zeros((degree + 1, degree + 1))
    for i in range(degree + 1):
        basis[: i + 1, i] = np.polynomial.legendre.leg2poly(np.eye(degree + 1)[i])
    return np.einsum("ai,bj,ck,ijk->abc", basis, basis, basis, legendre), degree


# ---------------------------------------------------------------------- the element
@dataclass
class DamperElement:
    """A fitted damper element: the polynomial ``model`` of ``(v, u, m)``, its memory length
    ``length`` (m), the command bandwidth ``eta`` (1/s) of its known command filter, the name
    of the ``damper`` it was built from and its build ``report``."""

    model: LegendreRegression
    length: float
    eta: float
    damper: str
    report: dict[str, Any] = field(default_factory=dict)

    def arrays(self) -> DamperElementArrays:
        """The element as :class:`DamperElementArrays` for :func:`element_force`."""
        coef, degree = _power_basis(self.model)
        lo = np.ascontiguousarray(self.model.lower_, dtype=np.float64).copy()
        up = np.ascontiguousarray(self.model.upper_, dtype=np.float64).copy()
        return DamperElementArrays(coef, lo, up, 2.0 / (up - lo), degree, float(self.length))

    def simulate(
        self, velocity: Any, command: Any, dt: float = DT, u0: float = 0.0, m0: float = 0.0
    ) -> np.ndarray:
        """The element's force (n,), N, along a compression-rate history (m/s, at
        ``t_k = k·dt``) and a command in [0, 1] held over each step: ``u`` exact, ``m`` by
        RK4 (as :func:`~railgym.vehicles.semi_active.simulate_damper` runs the damper)."""
        v, c, step = checked_history(velocity, command, dt)
        u = filtered_command(c, step, self.eta, u0)
        return _simulate(v, u, step, self.arrays(), float(m0))

    def save(self, path: str | Path, *, overwrite: bool = False) -> Path:
        """Write the element as a :mod:`surrogates.io` model file (``metadata.element`` =
        :data:`ELEMENT_KIND`, the memory and the command filter in ``metadata``)."""
        return io.save(
            self.model,
            path,
            overwrite=overwrite,
            inputs=list(INPUTS),
            output="F",
            units=dict(UNITS),
            form="static",
            metadata={
                "element": ELEMENT_KIND,
                "damper": self.damper,
                "memory_length": self.length,
                "eta": self.eta,
                "law": "u' = eta (command - u); m' = v - |v| m / memory_length; "
                "F = P(v, u, m) where P(v, u, m) v > 0, else 0",
                "report": self.report,
            },
        )


def _positive(meta: dict[str, Any], key: str, source: str) -> float:
    x: Any = meta.get(key)
    if not (is_number(x) and math.isfinite(x) and x > 0.0):
        raise ModelFieldError(f"{source}: field 'metadata.{key}' must be a positive number")
    return float(x)


def load_damper_element(name_or_path: str | Path = "mr_secondary") -> DamperElement:
    """A damper element from a packaged name (``"mr_secondary"``:
    ``railgym/data/damper_mr_secondary.json``) or a ``.json`` path written by
    :meth:`DamperElement.save`; errors name the file and the field."""
    if isinstance(name_or_path, Path) or str(name_or_path).endswith(".json"):
        path = Path(name_or_path)
        if not path.is_file():
            raise FileNotFoundError(f"damper element {path}: no such file")
        return _element(io.load(path), str(path))
    name = name_or_path
    if not (isinstance(name, str) and _NAME.fullmatch(name)):
        raise val.FieldError(
            "damper element", f"must be a packaged name or a .json path, got {name!r}"
        )
    ref = resources.files("railgym") / "data" / f"damper_{name}.json"
    if not ref.is_file():
        raise val.FieldError(
            "damper element", f"no packaged element {name!r} (data/damper_{name}.json)"
        )
    with resources.as_file(ref) as p:
        return _element(io.load(p), str(p))


def _element(model: Any, source: str) -> DamperElement:
    meta = getattr(model, "metadata_", {})
    if meta.get("element") != ELEMENT_KIND:
        raise ModelFieldError(
            f"{source}: field 'metadata.element' must be {ELEMENT_KIND!r}, got "
            f"{meta.get('element')!r} (not a damper element)"
        )
    if model.features_.get("inputs") != list(INPUTS):
        raise ModelFieldError(f"{source}: field 'features.inputs' must be {list(INPUTS)}")
    if not isinstance(model, LegendreRegression) or not model.interactions:
        raise ModelFieldError(f"{source}: field 'model' must be an LPR with interactions")
    report = meta.get("report", {})
    return DamperElement(
        model,
        _positive(meta, "memory_length", source),
        _positive(meta, "eta", source),
        str(meta.get("damper", "")),
        report if isinstance(report, dict) else {},
    )


# ---------------------------------------------------------------------- building
def build_damper_element(
    damper: DamperParams,
    seed: int,
    *,
    name: str = "mr_secondary",
    runs: int = RUNS,
    duration: float = DURATION,
    samples: int = SAMPLES,
    lengths: Sequence[float] = LENGTHS,
    degrees: Sequence[int] = DEGREES,
    progress: Callable[[str, int, int], None] | None = None,
) -> DamperElement:
    """Build the element of ``damper`` (seeded by ``seed``: the same seed gives the same bits).

    For each memory length of ``lengths`` (m) the features ``(v, u, m)`` of ``runs`` random
    histories of ``duration`` s (:func:`damper_runs`, stream 0) are taken every ``EVERY``
    steps after ``WARMUP``; :func:`surrogates.build` picks ``samples`` GA maximin training
    samples, chooses the total degree among ``degrees`` on the out-of-bag samples and fits
    ``F_h``. The length with the lowest out-of-bag RMS error wins. ``progress(stage, i,
    total)`` as in :func:`surrogates.build`, one stage per length; ``name`` is recorded.
    """
    seed = val.integer(seed, "seed", 0)
    if not lengths:
        raise val.FieldError("lengths", "must hold at least one memory length in m")
    data = damper_runs(
        damper, seed, val.integer(runs, "runs", 1), val.positive(duration, "duration")
    )
    start = round(WARMUP / DT)
    y = np.concatenate([r["F_h"][start::EVERY] for r in data])
    t0 = time.perf_counter()
    table, best = [], None
    for length in lengths:
        ell = val.positive(length, "lengths")
        x = np.concatenate([_features(r, ell, damper.eta)[start::EVERY] for r in data])
        model, rep = build(
            x,
            y,
            kind="lpr",
            m=val.integer(samples, "samples", 2),
            sampling="ga",
            selection="oob",
            seed=seed,
            candidates=list(degrees),
            interactions=True,
            progress=None if progress is None else _stage(progress, ell),
        )
        table.append({"length": ell, "degree": rep.chosen, "oob_nrms": rep.oob_nrms})
        if best is None or rep.oob_nrms < best[2].oob_nrms:
            best = (ell, model, rep)
    assert best is not None
    ell, model, rep = best
    assert isinstance(model, LegendreRegression)
    report = {
        "seed": seed,
        "runs": len(data),
        "duration_s": float(duration),
        "samples": rep.m,
        "candidates": rep.n,
        "lengths": table,
        "chosen": {"length": ell, "degree": rep.chosen},
        "oob_nrms": rep.oob_nrms,
        "at_cap": rep.scores.at_cap(),
        "training_time_s": time.perf_counter() - t0,
        "damper_params": {k: float(v) for k, v in damper._asdict().items()},
    }
    return DamperElement(model, ell, float(damper.eta), name, report)


def _stage(
    progress: Callable[[str, int, int], None], length: float
) -> Callable[[str, int, int], None]:
    return lambda stage, i, total: progress(f"l = {1e3 * length:g} mm: {stage}", i, total)


def heldout_error(
    element: DamperElement,
    damper: DamperParams,
    seed: int,
    runs: int = 8,
    duration: float = DURATION,
) -> float:
    """Relative RMS force error ``‖F_element − F‖ / ‖F‖`` of the element against the damper
    on ``runs`` held-out histories (:func:`damper_runs` stream 1, seeded by ``seed``), after
    ``WARMUP``; both start at rest."""
    start = round(WARMUP / DT)
    num = den = 0.0
    for r in damper_runs(damper, seed, runs, duration, stream=1):
        f = element.simulate(r["v"], r["command"])[start:]
        num += float(np.sum((f - r["F"][start:]) ** 2))
        den += float(np.sum(r["F"][start:] ** 2))
    return math.sqrt(num / den)


def element_cost(element: DamperElement, damper: DamperParams) -> tuple[float, float]:
    """Mean time of one element force (with its memory) and one reference damper step, ns."""
    r = damper_runs(damper, 0, 1, 20.0, stream=1)[0]
    element.simulate(r["v"], r["command"])  # compiled
    t0 = time.perf_counter()
    element.simulate(r["v"], r["command"])
    t_el = time.perf_counter() - t0
    t0 = time.perf_counter()
    simulate_damper(r["v"], r["command"], DT, damper)
    t_ref = time.perf_counter() - t0
    return 1e9 * t_el / r["v"].size, 1e9 * t_ref / r["v"].size


if __name__ == "__main__":
    from surrogates.cli_flags import moved_command

    raise SystemExit(
        moved_command("railgym.vehicles.semi_active_element", "railgym damper-element")
    )
