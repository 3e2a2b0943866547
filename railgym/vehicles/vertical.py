"""Vertical (bounce) model of one bogie and its share of the carbody, paper fig. 2, eq. (1)–(2).

Bogie frame ``m1`` on the primary suspension ``k1, c1`` (track side), carbody share ``m2`` on
the secondary suspension; ``x1, x2`` are measured upwards from the loaded static equilibrium
(gravity is balanced by the air-spring preload), ``δ = x1 − x2`` (> 0: compression)::

    m1·ẍ1 = k1·z + c1·ż − k1·x1 − c1·ẋ1 − F_s − F_a
    m2·ẍ2 = F_s + F_a

``f(t) = k1·z + c1·ż`` is the track input (eq. 1), ``F_s`` the secondary-suspension force and
``F_a`` an actuator force between bogie and carbody, held constant over a control interval.

Secondary-suspension variants (``VARIANTS``), each with a numba kernel ``advance_<variant>``:

``"linear"``
    ``F_s = k2·δ + c2·δ̇`` (eq. 1).
``"static"``
    memoryless reference ``F_s = k2·δ·(1 + a·δ²) + F_bump(δ) + F_damper(δ̇)``: progressive
    spring, bump stops beyond the free travel (C1 ramp of ``10·k2`` plus a cubic term),
    asymmetric two-slope damper with a hyperbolic blow-off knee.
``"dynamic"`` (default reference)
    air spring with a surge reservoir joined by an orifice (Nishimura/Berg family: Berg 1999,
    *Vehicle System Dynamics* 33 sup1, 528–539; Docquier, Fisette & Jeanmart 2007, *VSD*
    45(6), 505–524; review: Bruni et al. 2011, *VSD* 49(7), 1021–1072), the same bump stops,
    and the damper in series with its bush/oil stiffness ``k_b`` (Maxwell element). States
    ``[x1, v1, x2, v2, Δp_b, Δp_r, y]`` with the bag and reservoir pressures as deviations
    from the static pressure ``p0`` (Pa) and ``y`` the damper's internal displacement (m):

    * gas: polytropic, ``ρ(p) = ρ0·(p/p0)^(1/n)``; for each volume
      ``ṗ = n·p·(ṁ/(ρ·V) − V̇/V)``, which conserves the total gas mass;
    * bag volume ``V_b = V_b0 − A0·δ − ½·A'·δ²``, effective area ``A_e = A0 + A'·δ``;
    * orifice mass flow bag → reservoir
      ``q = C_d·A_o·√(2ρ̄)·Δp / (Δp² + Δp_l²)^(1/4)``: turbulent ``√|Δp|`` law, laminar
      (linear) below ``Δp_l``, ``ρ̄`` the mean density of both volumes;
    * force ``count·[(p_b − p_atm)·A_e(δ) − (p0 − p_atm)·A0]`` (preload removed);
    * damper ``F_d = k_b·(δ − y) = F_damper(ẏ)``, so ``ẏ = F_damper⁻¹(F_d)`` (closed-form
      inverse of the hyperbolic-knee curve).

    Manchester data (``manchester.yaml``): ``p0`` = 624.5 kPa, quasi-static stiffness
    ``count·(n·p0·A0²/(V_b+V_r) + (p0−p_atm)·A')`` = 861 kN/m ≈ ``k2`` = 860 kN/m; with the
    orifice closed ``count·(n·p0·A0²/V_b + (p0−p_atm)·A')`` = 1.89 MN/m. With the 30 mm
    orifice, measured air-spring in-phase stiffness / loss angle at ±5 mm: 0.862 MN/m / 0.02°
    (0.02 Hz), 0.862 / 1.1° (1 Hz), 0.863 / 2.3° (2 Hz), 0.873 / 6.8° (5 Hz), 0.958 / 17°
    (10 Hz), 1.33 / 21° (20 Hz, near the loss-angle peak), 1.70 / 13° (40 Hz); at ±2 mm:
    0.868 / 5.6° (5 Hz), 1.07 / 21° (20 Hz) (the turbulent orifice makes it amplitude
    dependent). In the ride band the spring is thus nearly static (+1.3 % stiffness at 5 Hz),
    which a static map ``F̂(δ, δ̇)`` can learn: the relative RMS error of the carbody
    acceleration simulated with the LPR surrogate of :mod:`railgym.vehicles.collect` (101
    samples, class 5 at 40 m/s, tested on track seed 1) is 5.5 % (out-of-bag 6.8 %). The
    orifice size is an engineering choice; a 12 mm orifice put the transition at 1–5 Hz
    (1.60 MN/m / 16° at 5 Hz) and that error at 46 %. The Maxwell damper turns into a spring
    above ``k_b/(2π·c)`` ≈ 24 Hz.
``"surrogate"``
    ``F_s = F̂(δ, δ̇)`` from a fitted LPR model via :func:`surrogates.models.lpr.lpr_eval_into`
    (eq. 2; work array allocated once per kernel call). Out-of-domain inputs are counted per
    RK4 stage evaluation (4 per substep).

Integration: classic fixed-step RK4; the track is sampled on ``t_k = k·dt`` and the stages at
``t + dt/2`` use the cubic Hermite midpoint of samples ``k`` and ``k + 1``,
``z_m = (z_k + z_{k+1})/2 + dt·(ż_k − ż_{k+1})/8`` and
``ż_m = 3(z_{k+1} − z_k)/(2dt) − (ż_k + ż_{k+1})/4`` (errors for a sine (ω·dt)⁴/384 and
(ω·dt)⁴/1920 of its amplitudes: 6.5·10⁻⁷ at 20 Hz for dt = 1 ms), so a sampled smooth input
keeps RK4's 4th order. Chosen step (``DEFAULT_DT``): 1 ms for every variant. Measured
change of the carbody acceleration (relative RMS, 20 s, FRA class 5 at 40 m/s, 2.56 m
wheelbase, seed 0) when the step is halved from 1 ms to 0.5 ms: linear 1.4·10⁻⁶ %, static
0.00009 %, dynamic 0.00012 % (2 ms → 1 ms: 2.3·10⁻⁵ %, 0.0004 %, 0.001 %); classes 3, 4, 6
give at most 0.0006 % (static, 1 ms → 0.5 ms), bump-stop contacts included. The linear model
converges with order 4, the nonlinear ones with order ≈ 2: their right-hand sides are not
smooth (the damper's slope jumps at δ̇ = 0, the bump-stop onset is only C1).

Kernel cost (this project's 2-core machine, one env, 10 ms control step = 10 substeps,
numba dispatch included / per env in a batch of 64): linear 2.5 / 0.8 µs, static 3.8 /
2.1 µs, dynamic 6.1 / 4.4 µs, surrogate (LPR of degree (10, 10), 21 terms) 4.5 / 2.7 µs.

Per control step the kernels also report the bump-stop contact count (substeps whose end
state is beyond the free travel, for every variant: a geometric measure), the out-of-domain
count (surrogate only) and a diverged flag: when a substep yields a non-finite state or
``|x1|`` or ``|x2|`` above ``DIVERGENCE_DISPLACEMENT``, the state is frozen at the last finite
value, the outputs are zero and the flag is set; NaN never enters the state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numba import njit

from surrogates.models.lpr import lpr_eval_into, lpr_is_outside, lpr_scratch

VARIANTS = ("linear", "static", "dynamic", "surrogate")
DEFAULT_VARIANT = "dynamic"
#: number of state variables per variant
STATE_SIZE = {"linear": 4, "static": 4, "dynamic": 7, "surrogate": 4}
#: recommended integration step per variant, s
DEFAULT_DT = {"linear": 1e-3, "static": 1e-3, "dynamic": 1e-3, "surrogate": 1e-3}
#: |x1| or |x2| above this (m) counts as divergence
DIVERGENCE_DISPLACEMENT = 10.0

_KIND = {"linear": 0, "static": 1, "dynamic": 2, "surrogate": 3}

# indices into the float64 parameter array of :meth:`VerticalVehicle.kernel_params`
P_M1, P_M2, P_K1, P_C1, P_K2, P_C2 = 0, 1, 2, 3, 4, 5
P_FREE_C, P_FREE_R, P_KBS, P_KBS3, P_BS_SMOOTH = 6, 7, 8, 9, 10
P_PROG = 11
P_CC, P_CR, P_VKC, P_VKR, P_BLOW, P_KNEE, P_KSER = 12, 13, 14, 15, 16, 17, 18
P_NS, P_AE, P_DAE, P_VB, P_VR, P_P0, P_PATM, P_NPOLY, P_RHO0, P_CDA, P_DPLAM = range(19, 30)
N_PARAMS = 30


# ============================================================================ parameters
def _positive(v: float) -> bool:
    return v > 0.0


def _nonneg(v: float) -> bool:
    return v >= 0.0


def _any(v: float) -> bool:
    return True


def _fraction(v: float) -> bool:
    return 0.0 < v <= 1.0


def _polytropic(v: float) -> bool:
    return 1.0 <= v <= 5.0 / 3.0


_RULES = {
    _positive: "must be positive",
    _nonneg: "must be non-negative",
    _any: "must be finite",
    _fraction: "must be in (0, 1]",
    _polytropic: "must be in [1, 5/3]",
}


def _validate(obj: Any, section: str, rules: dict[str, Any]) -> None:
    """Check every numeric field of ``obj`` against its rule; ValueError names the field."""
    for name, rule in rules.items():
        value = getattr(obj, name)
        if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
            raise ValueError(f"{section}.{name} must be a number, got {value!r}")
        if not math.isfinite(float(value)):
            raise ValueError(f"{section}.{name} must be finite, got {value!r}")
        if not rule(float(value)):
            raise ValueError(f"{section}.{name} {_RULES[rule]}, got {value!r}")


@dataclass(frozen=True)
class BumpStop:
    """Bump and rebound stops: free travel (m), ramp stiffness (N/m), cubic (N/m³)."""

    free_travel_compression: float
    free_travel_rebound: float
    stiffness: float
    cubic_stiffness: float
    smoothing: float

    def __post_init__(self) -> None:
        _validate(self, "bump_stop", {
            "free_travel_compression": _positive, "free_travel_rebound": _positive,
            "stiffness": _positive, "cubic_stiffness": _nonneg, "smoothing": _positive,
        })  # fmt: skip


@dataclass(frozen=True)
class StaticSpring:
    """Progressive spring of the static reference: ``k2·δ·(1 + progression·δ²)`` (1/m²)."""

    progression: float

    def __post_init__(self) -> None:
        _validate(self, "static_spring", {"progression": _nonneg})


@dataclass(frozen=True)
class Damper:
    """Two-slope damper (total of one bogie): coefficients N·s/m, knees m/s, ``k_b`` N/m."""

    c_compression: float
    c_rebound: float
    knee_velocity_compression: float
    knee_velocity_rebound: float
    blowoff_ratio: float
    knee_smoothing: float
    series_stiffness: float

    def __post_init__(self) -> None:
        _validate(self, "damper", {
            "c_compression": _positive, "c_rebound": _positive,
            "knee_velocity_compression": _positive, "knee_velocity_rebound": _positive,
            "blowoff_ratio": _fraction, "knee_smoothing": _positive,
            "series_stiffness": _positive,
        })  # fmt: skip


@dataclass(frozen=True)
class AirSpring:
    """Air spring with surge reservoir and orifice, per spring (``count`` springs), SI."""

    count: int
    effective_area: float
    area_gradient: float
    bag_volume: float
    reservoir_volume: float
    polytropic_index: float
    atmospheric_pressure: float
    gas_constant: float
    temperature: float
    orifice_diameter: float
    discharge_coefficient: float
    laminar_pressure: float

    def __post_init__(self) -> None:
        if isinstance(self.count, bool) or not isinstance(self.count, (int, np.integer)):
            raise ValueError(f"air_spring.count must be an integer, got {self.count!r}")
        if self.count < 1:
            raise ValueError(f"air_spring.count must be positive, got {self.count!r}")
        _validate(self, "air_spring", {
            "effective_area": _positive, "area_gradient": _any, "bag_volume": _positive,
            "reservoir_volume": _positive, "polytropic_index": _polytropic,
            "atmospheric_pressure": _positive, "gas_constant": _positive,
            "temperature": _positive, "orifice_diameter": _positive,
            "discharge_coefficient": _fraction, "laminar_pressure": _positive,
        })  # fmt: skip


@dataclass(frozen=True)
class VerticalVehicle:
    """One bogie and half a carbody (SI). See ``configs/vehicles/manchester.yaml``.

    Attributes
    ----------
    m1, m2 : bogie frame and carbody share, kg.
    k1, c1 : primary suspension of the bogie (all axleboxes), N/m and N·s/m.
    k2, c2 : nominal linear secondary suspension (both sides), N/m and N·s/m.
    gravity : m/s², sets the air-spring static pressure.
    """

    name: str
    m1: float
    m2: float
    k1: float
    c1: float
    k2: float
    c2: float
    gravity: float
    bump_stop: BumpStop
    static_spring: StaticSpring
    damper: Damper
    air_spring: AirSpring

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"vehicle.name must be a non-empty string, got {self.name!r}")
        _validate(self, "vehicle", {
            "m1": _positive, "m2": _positive, "k1": _positive, "c1": _nonneg,
            "k2": _positive, "c2": _nonneg, "gravity": _positive,
        })  # fmt: skip
        air = self.air_spring
        travel = self.bump_stop.free_travel_compression
        v_min = (
            air.bag_volume - air.effective_area * travel - 0.5 * air.area_gradient * travel**2
        )
        if v_min <= 0.2 * air.bag_volume:
            raise ValueError(
                "air_spring.bag_volume is too small: the bag would lose over 80 % of its "
                f"volume within the free travel of {travel} m"
            )
        if air.effective_area + air.area_gradient * travel <= 0.0:
            raise ValueError("air_spring.area_gradient makes the effective area non-positive")

    @property
    def static_pressure(self) -> float:
        """Absolute air-spring pressure at static equilibrium ``p0``, Pa."""
        air = self.air_spring
        return air.atmospheric_pressure + self.m2 * self.gravity / (
            air.count * air.effective_area
        )

    def air_spring_stiffness(self) -> tuple[float, float]:
        """(quasi-static, orifice-closed) vertical stiffness of all air springs, N/m."""
        air = self.air_spring
        p0 = self.static_pressure
        geo = (p0 - air.atmospheric_pressure) * air.area_gradient
        pa2 = air.polytropic_index * p0 * air.effective_area**2
        return (
            air.count * (pa2 / (air.bag_volume + air.reservoir_volume) + geo),
            air.count * (pa2 / air.bag_volume + geo),
        )

    def kernel_params(self) -> np.ndarray:
        """Float64 parameter array (``N_PARAMS``,) for the kernels, indices ``P_*``."""
        b, s, d, a = self.bump_stop, self.static_spring, self.damper, self.air_spring
        p = np.empty(N_PARAMS)
        p[[P_M1, P_M2, P_K1, P_C1, P_K2, P_C2]] = (self.m1, self.m2, self.k1, self.c1,
                                                  self.k2, self.c2)  # fmt: skip
        p[[P_FREE_C, P_FREE_R, P_KBS, P_KBS3, P_BS_SMOOTH]] = (
            b.free_travel_compression, b.free_travel_rebound, b.stiffness,
            b.cubic_stiffness, b.smoothing,
        )  # fmt: skip
        p[P_PROG] = s.progression
        p[[P_CC, P_CR, P_VKC, P_VKR, P_BLOW, P_KNEE, P_KSER]] = (
            d.c_compression, d.c_rebound, d.knee_velocity_compression,
            d.knee_velocity_rebound, d.blowoff_ratio, d.knee_smoothing, d.series_stiffness,
        )  # fmt: skip
        p0 = self.static_pressure
        p[[P_NS, P_AE, P_DAE, P_VB, P_VR, P_P0, P_PATM, P_NPOLY]] = (
            a.count, a.effective_area, a.area_gradient, a.bag_volume, a.reservoir_volume,
            p0, a.atmospheric_pressure, a.polytropic_index,
        )  # fmt: skip
        p[P_RHO0] = p0 / (a.gas_constant * a.temperature)
        p[P_CDA] = a.discharge_coefficient * math.pi * a.orifice_diameter**2 / 4.0
        p[P_DPLAM] = a.laminar_pressure
        return p


_SECTIONS: dict[str, type] = {
    "bump_stop": BumpStop,
    "static_spring": StaticSpring,
    "damper": Damper,
    "air_spring": AirSpring,
}


def vehicle_from_dict(d: dict[str, Any]) -> VerticalVehicle:
    """Build a validated :class:`VerticalVehicle` from a dict shaped like the YAML file."""
    if not isinstance(d, dict):
        raise ValueError(f"vehicle description must be a mapping, got {type(d).__name__}")
    for key in d:
        if key not in ("vehicle", *_SECTIONS):
            raise ValueError(f"unknown section {key!r} in the vehicle description")
    top = [f.name for f in fields(VerticalVehicle) if f.name not in _SECTIONS]
    kwargs = _section(d, "vehicle", top)
    for sec, cls in _SECTIONS.items():
        kwargs[sec] = cls(**_section(d, sec, [f.name for f in fields(cls)]))
    return VerticalVehicle(**kwargs)


def _section(d: dict[str, Any], sec: str, names: list[str]) -> dict[str, Any]:
    if sec not in d:
        raise ValueError(f"{sec} is missing from the vehicle description")
    s = d[sec]
    if not isinstance(s, dict):
        raise ValueError(f"{sec} must be a mapping, got {type(s).__name__}")
    for key in s:
        if key not in names:
            raise ValueError(f"unknown field {sec}.{key}")
    for name in names:
        if name not in s:
            raise ValueError(f"{sec}.{name} is missing")
    return {name: s[name] for name in names}


def load_vehicle(name_or_path: str | Path = "manchester") -> VerticalVehicle:
    """Load a vehicle: a packaged name (``"manchester"``) or a path to a YAML file."""
    text = str(name_or_path)
    if isinstance(name_or_path, Path) or text.endswith((".yaml", ".yml")) or "/" in text:
        path = Path(text)
        if not path.is_file():
            raise ValueError(f"vehicle file {text!r} does not exist")
        raw = path.read_text()
    else:
        res = resources.files("railgym").joinpath("configs", "vehicles", f"{text}.yaml")
        if not res.is_file():
            raise ValueError(f"unknown vehicle {text!r}; no packaged file {text}.yaml")
        raw = res.read_text()
    return vehicle_from_dict(yaml.safe_load(raw))


# ======================================================================== element laws
@njit(cache=True)
def _ramp(x: float, eps: float) -> float:
    """Hyperbolic smooth ramp ``(x + √(x² + ε²))/2``."""
    return 0.5 * (x + math.sqrt(x * x + eps * eps))


@njit(cache=True)
def _damper_branch(v: float, c: float, vk: float, r: float, eps: float) -> float:
    """Force of one damper branch for ``v ≥ 0``: slope ``c`` then ``r·c`` past the knee."""
    return c * (v - (1.0 - r) * (_ramp(v - vk, eps) - _ramp(-vk, eps)))


@njit(cache=True)
def _damper_branch_inv(f: float, c: float, vk: float, r: float, eps: float) -> float:
    """Closed-form inverse of :func:`_damper_branch` for ``f ≥ 0`` (exactly 0 at ``f = 0``).

    With ``v = vk + w`` the branch reads ``α·w − β·√(w² + ε²) = Φ``, ``α, β = (1 ± r)/2``,
    whose root is ``w = (α·Φ + β·√(Φ² + r·ε²))/r``.
    """
    alpha = 0.5 * (1.0 + r)
    beta = 0.5 * (1.0 - r)
    re2 = r * eps * eps
    phi0 = -vk - (1.0 - r) * _ramp(-vk, eps)
    phi = f / c + phi0
    w = alpha * phi + beta * math.sqrt(phi * phi + re2)
    w0 = alpha * phi0 + beta * math.sqrt(phi0 * phi0 + re2)
    return (w - w0) / r


@njit(cache=True)
def damper_force(v: float, p: np.ndarray) -> float:
    """Damper force (N) at relative velocity ``v`` (m/s, > 0 compression)."""
    if v >= 0.0:
        return _damper_branch(v, p[P_CC], p[P_VKC], p[P_BLOW], p[P_KNEE])
    return -_damper_branch(-v, p[P_CR], p[P_VKR], p[P_BLOW], p[P_KNEE])


@njit(cache=True)
def damper_velocity(f: float, p: np.ndarray) -> float:
    """Inverse of :func:`damper_force`: velocity (m/s) that produces force ``f`` (N)."""
    if f >= 0.0:
        return _damper_branch_inv(f, p[P_CC], p[P_VKC], p[P_BLOW], p[P_KNEE])
    return -_damper_branch_inv(-f, p[P_CR], p[P_VKR], p[P_BLOW], p[P_KNEE])


@njit(cache=True)
def _contact_ramp(e: float, s: float) -> float:
    """C1 ramp: 0 for e ≤ 0, e²/(2s) up to s, then e − s/2."""
    if e <= 0.0:
        return 0.0
    if e < s:
        return 0.5 * e * e / s
    return e - 0.5 * s


@njit(cache=True)
def bump_stop_force(d: float, p: np.ndarray) -> float:
    """Bump-stop (δ > free travel) and rebound-stop (δ < −free travel) force, N."""
    ec = d - p[P_FREE_C]
    er = -d - p[P_FREE_R]
    f = 0.0
    if ec > 0.0:
        f += p[P_KBS] * _contact_ramp(ec, p[P_BS_SMOOTH]) + p[P_KBS3] * ec * ec * ec
    if er > 0.0:
        f -= p[P_KBS] * _contact_ramp(er, p[P_BS_SMOOTH]) + p[P_KBS3] * er * er * er
    return f


@njit(cache=True)
def _in_contact(d: float, p: np.ndarray) -> bool:
    return d > p[P_FREE_C] or d < -p[P_FREE_R]


@njit(cache=True)
def _dynamic_element(
    d: float, dd: float, dpb: float, dpr: float, y: float, p: np.ndarray, rates: np.ndarray
) -> tuple[float, float]:
    """Air spring and Maxwell damper of the dynamic reference.

    Writes ``rates = (d Δp_b/dt, d Δp_r/dt, dy/dt)``; returns (air-spring force, damper force).
    """
    n = p[P_NPOLY]
    p0 = p[P_P0]
    a0 = p[P_AE]
    da = p[P_DAE]
    ae = a0 + da * d
    vb = p[P_VB] - a0 * d - 0.5 * da * d * d
    vr = p[P_VR]
    pb = p0 + dpb
    pr = p0 + dpr
    rho_b = p[P_RHO0] * (pb / p0) ** (1.0 / n)
    rho_r = p[P_RHO0] * (pr / p0) ** (1.0 / n)
    dp = dpb - dpr
    dl = p[P_DPLAM]
    q = p[P_CDA] * math.sqrt(rho_b + rho_r) * dp / math.sqrt(math.sqrt(dp * dp + dl * dl))
    rates[0] = n * pb * (ae * dd - q / rho_b) / vb
    rates[1] = n * pr * q / (rho_r * vr)
    f_d = p[P_KSER] * (d - y)
    rates[2] = damper_velocity(f_d, p)
    f_air = p[P_NS] * ((p0 - p[P_PATM]) * da * d + dpb * ae)
    return f_air, f_d


@njit(cache=True)
def _rhs(
    kind: int,
    x: np.ndarray,
    zc: float,
    zdc: float,
    fa: float,
    p: np.ndarray,
    exps: np.ndarray,
    coef: np.ndarray,
    lo: np.ndarray,
    up: np.ndarray,
    mode: int,
    u: np.ndarray,
    lw: np.ndarray,
    dx: np.ndarray,
) -> tuple[float, int]:
    """State derivative ``dx``; returns (F_s, 1 if the surrogate input is outside its box).

    ``u`` (2,) and ``lw`` (:func:`~surrogates.models.lpr.lpr_scratch`) are work arrays.
    """
    d = x[0] - x[2]
    dd = x[1] - x[3]
    outside = 0
    if kind == 0:
        fs = p[P_K2] * d + p[P_C2] * dd
    elif kind == 1:
        fs = p[P_K2] * d * (1.0 + p[P_PROG] * d * d) + bump_stop_force(d, p) + damper_force(dd, p)
    elif kind == 2:
        f_air, f_d = _dynamic_element(d, dd, x[4], x[5], x[6], p, dx[4:])
        fs = f_air + f_d + bump_stop_force(d, p)
    else:
        u[0] = d
        u[1] = dd
        if lpr_is_outside(u, lo, up):
            outside = 1
        fs = lpr_eval_into(u, exps, coef, lo, up, mode, lw)
    dx[0] = x[1]
    dx[1] = (p[P_K1] * (zc - x[0]) + p[P_C1] * (zdc - x[1]) - fs - fa) / p[P_M1]
    dx[2] = x[3]
    dx[3] = (fs + fa) / p[P_M2]
    return fs, outside


# ============================================================================ kernels
@njit(cache=True)
def _advance(
    kind, state, z, zdot, k0, n_sub, dt, force_a, p, exps, coef, lo, up, mode,
    out_acc, out_force, out_count, out_div,
):  # fmt: skip
    """RK4 core shared by the four ``advance_<variant>`` kernels (see :func:`advance_linear`)."""
    n, s = state.shape
    x = np.empty(s)
    xt = np.empty(s)
    r1 = np.empty(s)
    r2 = np.empty(s)
    r3 = np.empty(s)
    r4 = np.empty(s)
    u = np.empty(2)
    lw = lpr_scratch(exps, lo, up)
    h6 = dt / 6.0
    dt8 = 0.125 * dt  # cubic Hermite midpoint of the track samples (module docstring)
    c3 = 1.5 / dt
    for i in range(n):
        kk = k0[i]
        if kk < 0 or kk + n_sub > z.shape[1] - 1:
            raise ValueError("track index out of range: need 0 <= k0 and k0 + n_sub <= N")
        fa = force_a[i]
        for j in range(s):
            x[j] = state[i, j]
        contact = 0
        ood = 0
        div = False
        for m in range(n_sub):
            ka = kk + m
            za = z[i, ka]
            zda = zdot[i, ka]
            zb = z[i, ka + 1]
            zdb = zdot[i, ka + 1]
            zm = 0.5 * (za + zb) + dt8 * (zda - zdb)
            zdm = c3 * (zb - za) - 0.25 * (zda + zdb)
            _, o1 = _rhs(kind, x, za, zda, fa, p, exps, coef, lo, up, mode, u, lw, r1)
            for j in range(s):
                xt[j] = x[j] + 0.5 * dt * r1[j]
            _, o2 = _rhs(kind, xt, zm, zdm, fa, p, exps, coef, lo, up, mode, u, lw, r2)
            for j in range(s):
                xt[j] = x[j] + 0.5 * dt * r2[j]
            _, o3 = _rhs(kind, xt, zm, zdm, fa, p, exps, coef, lo, up, mode, u, lw, r3)
            for j in range(s):
                xt[j] = x[j] + dt * r3[j]
            _, o4 = _rhs(kind, xt, zb, zdb, fa, p, exps, coef, lo, up, mode, u, lw, r4)
            ood += o1 + o2 + o3 + o4
            ok = True
            for j in range(s):
                xt[j] = x[j] + h6 * (r1[j] + 2.0 * r2[j] + 2.0 * r3[j] + r4[j])
                if not math.isfinite(xt[j]):
                    ok = False
            if abs(xt[0]) > DIVERGENCE_DISPLACEMENT or abs(xt[2]) > DIVERGENCE_DISPLACEMENT:
                ok = False
            if not ok:
                div = True
                break
            for j in range(s):
                x[j] = xt[j]
            if _in_contact(x[0] - x[2], p):
                contact += 1
        for j in range(s):
            state[i, j] = x[j]
        if not div:
            ke = kk + n_sub
            fs, _ = _rhs(kind, x, z[i, ke], zdot[i, ke], fa, p, exps, coef, lo, up, mode, u,
                         lw, r1)  # fmt: skip
            if math.isfinite(fs) and math.isfinite(r1[1]) and math.isfinite(r1[3]):
                out_acc[i, 0] = r1[1]
                out_acc[i, 1] = r1[3]
                out_force[i] = fs
            else:
                div = True
        if div:
            out_acc[i, 0] = 0.0
            out_acc[i, 1] = 0.0
            out_force[i] = 0.0
        out_count[i, 0] = contact
        out_count[i, 1] = ood
        out_div[i] = div


@njit(cache=True)
def advance_linear(
    state, z, zdot, k0, n_sub, dt, force_a, p, exps, coef, lo, up, mode,
    out_acc, out_force, out_count, out_div,
):  # fmt: skip
    """Advance ``n`` envs by ``n_sub`` RK4 substeps of ``dt`` (s), linear secondary suspension.

    All four ``advance_<variant>`` kernels share this signature and work in place.

    Parameters
    ----------
    state : float64 (n, s)
        States, updated in place (``s = STATE_SIZE[variant]``).
    z, zdot : float64 (n, N+1)
        Track displacement (m) and velocity (m/s) per env on the grid ``t_k = k·dt``.
    k0 : int64 (n,)
        Index of each env's current track sample; needs ``k0 + n_sub <= N``.
    n_sub : int
        Substeps per control step.
    dt : float
        Integration step, s.
    force_a : float64 (n,)
        Actuator force (N, pushes the carbody up and the bogie down), held over the step.
    p : float64 (N_PARAMS,)
        :meth:`VerticalVehicle.kernel_params`.
    exps, coef, lo, up, mode
        LPR arrays (:func:`surrogate_arrays`); used by ``advance_surrogate`` only.
    out_acc : float64 (n, 2)
        ``(ẍ1, ẍ2)`` at the end of the step, m/s² (0 for a diverged env).
    out_force : float64 (n,)
        Secondary-suspension force ``F_s`` at the end of the step, N.
    out_count : int64 (n, 2)
        Substeps in bump-stop contact; out-of-domain surrogate stage evaluations.
    out_div : bool (n,)
        True where the env diverged during this step (its state is frozen).
    """
    _advance(0, state, z, zdot, k0, n_sub, dt, force_a, p, exps, coef, lo, up, mode,
             out_acc, out_force, out_count, out_div)  # fmt: skip


@njit(cache=True)
def advance_static(
    state, z, zdot, k0, n_sub, dt, force_a, p, exps, coef, lo, up, mode,
    out_acc, out_force, out_count, out_div,
):  # fmt: skip
    """:func:`advance_linear` with the static nonlinear reference suspension."""
    _advance(1, state, z, zdot, k0, n_sub, dt, force_a, p, exps, coef, lo, up, mode,
             out_acc, out_force, out_count, out_div)  # fmt: skip


@njit(cache=True)
def advance_dynamic(
    state, z, zdot, k0, n_sub, dt, force_a, p, exps, coef, lo, up, mode,
    out_acc, out_force, out_count, out_div,
):  # fmt: skip
    """:func:`advance_linear` with the dynamic reference (air spring + Maxwell damper)."""
    _advance(2, state, z, zdot, k0, n_sub, dt, force_a, p, exps, coef, lo, up, mode,
             out_acc, out_force, out_count, out_div)  # fmt: skip


@njit(cache=True)
def advance_surrogate(
    state, z, zdot, k0, n_sub, dt, force_a, p, exps, coef, lo, up, mode,
    out_acc, out_force, out_count, out_div,
):  # fmt: skip
    """:func:`advance_linear` with the LPR surrogate ``F̂(δ, δ̇)`` as secondary suspension."""
    _advance(3, state, z, zdot, k0, n_sub, dt, force_a, p, exps, coef, lo, up, mode,
             out_acc, out_force, out_count, out_div)  # fmt: skip


KERNELS = {
    "linear": advance_linear,
    "static": advance_static,
    "dynamic": advance_dynamic,
    "surrogate": advance_surrogate,
}


def surrogate_arrays(
    surrogate: Any = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """LPR kernel arrays from a fitted model (or its ``kernel_arrays()`` tuple).

    ``None`` gives placeholder arrays for the variants that ignore them.
    """
    if surrogate is None:
        return np.zeros((1, 2), np.int64), np.zeros(1), np.zeros(2), np.ones(2), 0
    arrays = surrogate.kernel_arrays() if hasattr(surrogate, "kernel_arrays") else surrogate
    if not isinstance(arrays, (tuple, list)) or len(arrays) != 5:
        raise ValueError("surrogate must be a fitted LPR model or its kernel_arrays() tuple")
    exps, coef, lo, up, mode = arrays
    exps = np.ascontiguousarray(exps, dtype=np.int64)
    coef = np.ascontiguousarray(coef, dtype=np.float64)
    lo = np.ascontiguousarray(lo, dtype=np.float64)
    up = np.ascontiguousarray(up, dtype=np.float64)
    if exps.ndim != 2 or exps.shape[1] != 2 or lo.shape != (2,) or up.shape != (2,):
        raise ValueError(
            f"surrogate must have 2 inputs (δ, δ̇); got exponents of shape {exps.shape}"
        )
    if coef.shape != (exps.shape[0],):
        raise ValueError(f"surrogate coef has shape {coef.shape}, expected ({exps.shape[0]},)")
    return exps, coef, lo, up, int(mode)


def initial_state(variant: str, n: int = 1) -> np.ndarray:
    """Static equilibrium state(s), float64 (n, STATE_SIZE[variant]) of zeros."""
    _check_variant(variant)
    return np.zeros((n, STATE_SIZE[variant]))


def _check_variant(variant: str) -> int:
    if variant not in _KIND:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    return _KIND[variant]


# ========================================================================= simulation
@njit(cache=True)
def _simulate_loop(
    kind, state, z, zdot, every, dt, fa, p, exps, coef, lo, up, mode,
    rec_x, rec_acc, rec_fs, counts,
):  # fmt: skip
    """Run ``fa.size`` control steps of ``every`` substeps, recording after each; returns the
    number of completed steps (fewer if the run diverged)."""
    s = state.shape[1]
    dx = np.empty(s)
    u = np.empty(2)
    lw = lpr_scratch(exps, lo, up)
    fs, _ = _rhs(kind, state[0], z[0, 0], zdot[0, 0], fa[0] if fa.size > 0 else 0.0, p,
                 exps, coef, lo, up, mode, u, lw, dx)  # fmt: skip
    rec_x[0] = state[0]
    rec_acc[0, 0] = dx[1]
    rec_acc[0, 1] = dx[3]
    rec_fs[0] = fs
    k0 = np.zeros(1, np.int64)
    f1 = np.empty(1)
    acc = np.empty((1, 2))
    force = np.empty(1)
    cnt = np.zeros((1, 2), np.int64)
    div = np.zeros(1, np.bool_)
    for m in range(fa.size):
        k0[0] = m * every
        f1[0] = fa[m]
        _advance(kind, state, z, zdot, k0, every, dt, f1, p, exps, coef, lo, up, mode,
                 acc, force, cnt, div)  # fmt: skip
        counts[0] += cnt[0, 0]
        counts[1] += cnt[0, 1]
        if div[0]:
            return m
        rec_x[m + 1] = state[0]
        rec_acc[m + 1, 0] = acc[0, 0]
        rec_acc[m + 1, 1] = acc[0, 1]
        rec_fs[m + 1] = force[0]
    return fa.size


def simulate(
    variant: str,
    vehicle: VerticalVehicle,
    z: Any,
    zdot: Any,
    dt: float,
    force_a: Any = None,
    surrogate: Any = None,
    sample_every: int = 1,
    x0: Any = None,
) -> dict[str, Any]:
    """Simulate one vehicle over a sampled track input (for data collection).

    Parameters
    ----------
    variant
        One of ``VARIANTS``.
    z, zdot
        Track displacement (m) and velocity (m/s) sampled at ``dt``, shape (N+1,).
    dt
        Integration step, s.
    force_a
        Actuator force (N): ``None`` (zero), a scalar, or one value per recorded interval,
        shape (N // sample_every,), held over that interval.
    surrogate
        Fitted LPR model (or its ``kernel_arrays()``), required for ``"surrogate"``.
    sample_every
        Record every ``sample_every``-th step (the substeps of one kernel call).
    x0
        Initial state (``STATE_SIZE[variant]``,); default the static equilibrium.

    Returns
    -------
    dict
        ``t, x1, v1, x2, v2, a1, a2, F_s`` (n_samples,) in SI, ``states`` (n_samples, s),
        for ``"dynamic"`` also ``dp_b, dp_r`` (Pa) and ``y`` (m); ``contacts`` (substeps in
        bump-stop contact), ``out_of_domain`` (surrogate stage evaluations), ``diverged``.
        Surrogate training pairs are ``u = (x1 − x2, v1 − v2)`` and ``v = F_s`` (equal to
        ``m2·a2`` when ``force_a`` is zero). After a divergence the record stops there.
    """
    kind = _check_variant(variant)
    if not isinstance(vehicle, VerticalVehicle):
        raise ValueError(f"vehicle must be a VerticalVehicle, got {type(vehicle).__name__}")
    z = np.ascontiguousarray(z, dtype=float)
    zdot = np.ascontiguousarray(zdot, dtype=float)
    if z.ndim != 1 or z.size < 2:
        raise ValueError(f"z must be 1-D with at least 2 samples, got shape {z.shape}")
    if zdot.shape != z.shape:
        raise ValueError(f"zdot has shape {zdot.shape}, expected {z.shape} like z")
    if not (np.all(np.isfinite(z)) and np.all(np.isfinite(zdot))):
        raise ValueError("z and zdot must be finite")
    if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
    if isinstance(sample_every, bool) or not isinstance(sample_every, (int, np.integer)):
        raise ValueError(f"sample_every must be a positive integer, got {sample_every!r}")
    if sample_every < 1:
        raise ValueError(f"sample_every must be a positive integer, got {sample_every!r}")
    n_int = (z.size - 1) // sample_every
    if force_a is None:
        fa = np.zeros(n_int)
    elif np.ndim(force_a) == 0:
        fa = np.full(n_int, float(force_a))
    else:
        fa = np.asarray(force_a, dtype=float)
        if fa.shape != (n_int,):
            raise ValueError(f"force_a must be a scalar or have shape ({n_int},), got {fa.shape}")
    if not np.all(np.isfinite(fa)):
        raise ValueError("force_a must be finite")
    if variant == "surrogate" and surrogate is None:
        raise ValueError("surrogate is required for variant 'surrogate'")
    lpr = surrogate_arrays(surrogate if variant == "surrogate" else None)
    s = STATE_SIZE[variant]
    state = initial_state(variant)
    if x0 is not None:
        x0 = np.asarray(x0, dtype=float)
        if x0.shape != (s,) or not np.all(np.isfinite(x0)):
            raise ValueError(f"x0 must be finite with shape ({s},), got {x0.shape}")
        state[0] = x0
    rec_x = np.zeros((n_int + 1, s))
    rec_acc = np.zeros((n_int + 1, 2))
    rec_fs = np.zeros(n_int + 1)
    counts = np.zeros(2, np.int64)
    done = _simulate_loop(
        kind, state, z[None, :], zdot[None, :], sample_every, float(dt), fa,
        vehicle.kernel_params(), *lpr, rec_x, rec_acc, rec_fs, counts,
    )  # fmt: skip
    m = done + 1
    out: dict[str, Any] = {
        "t": np.arange(m) * sample_every * dt,
        "x1": rec_x[:m, 0],
        "v1": rec_x[:m, 1],
        "x2": rec_x[:m, 2],
        "v2": rec_x[:m, 3],
        "a1": rec_acc[:m, 0],
        "a2": rec_acc[:m, 1],
        "F_s": rec_fs[:m],
        "states": rec_x[:m],
        "contacts": int(counts[0]),
        "out_of_domain": int(counts[1]),
        "diverged": done < n_int,
    }
    if variant == "dynamic":
        out["dp_b"], out["dp_r"], out["y"] = rec_x[:m, 4], rec_x[:m, 5], rec_x[:m, 6]
    return out


@njit(cache=True)
def _element_loop(kind, d, dd, dt, p, out):
    """Secondary element driven by a prescribed δ(t), δ̇(t); out (N+1, 7):
    total, spring, damper, bump-stop force, Δp_b, Δp_r, y."""
    rates = np.empty(3)
    r1 = np.empty(3)
    r2 = np.empty(3)
    r3 = np.empty(3)
    r4 = np.empty(3)
    st = np.zeros(3)
    stt = np.empty(3)
    for k in range(d.size):
        if kind == 2 and k > 0:
            dm = 0.5 * (d[k - 1] + d[k]) + 0.125 * dt * (dd[k - 1] - dd[k])
            ddm = 1.5 / dt * (d[k] - d[k - 1]) - 0.25 * (dd[k - 1] + dd[k])
            _dynamic_element(d[k - 1], dd[k - 1], st[0], st[1], st[2], p, r1)
            for j in range(3):
                stt[j] = st[j] + 0.5 * dt * r1[j]
            _dynamic_element(dm, ddm, stt[0], stt[1], stt[2], p, r2)
            for j in range(3):
                stt[j] = st[j] + 0.5 * dt * r2[j]
            _dynamic_element(dm, ddm, stt[0], stt[1], stt[2], p, r3)
            for j in range(3):
                stt[j] = st[j] + dt * r3[j]
            _dynamic_element(d[k], dd[k], stt[0], stt[1], stt[2], p, r4)
            for j in range(3):
                st[j] += dt / 6.0 * (r1[j] + 2.0 * r2[j] + 2.0 * r3[j] + r4[j])
        if kind == 0:
            spring = p[P_K2] * d[k]
            damp = p[P_C2] * dd[k]
            bump = 0.0
        elif kind == 1:
            spring = p[P_K2] * d[k] * (1.0 + p[P_PROG] * d[k] * d[k])
            damp = damper_force(dd[k], p)
            bump = bump_stop_force(d[k], p)
        else:
            spring, damp = _dynamic_element(d[k], dd[k], st[0], st[1], st[2], p, rates)
            bump = bump_stop_force(d[k], p)
        out[k, 0] = spring + damp + bump
        out[k, 1] = spring
        out[k, 2] = damp
        out[k, 3] = bump
        out[k, 4] = st[0]
        out[k, 5] = st[1]
        out[k, 6] = st[2]


def element_response(
    variant: str, vehicle: VerticalVehicle, delta: Any, delta_dot: Any, dt: float
) -> dict[str, np.ndarray]:
    """Secondary-suspension force for a prescribed deflection history (characteristic curves).

    ``delta`` (m) and ``delta_dot`` (m/s) are sampled at ``dt`` (s), shape (N+1,); the
    dynamic element's internal states start at equilibrium and are integrated by RK4 with
    the same cubic Hermite midpoint rule as the vehicle kernels. Variants ``"linear"``,
    ``"static"``, ``"dynamic"``.

    Returns
    -------
    dict
        ``force`` (total), ``spring`` (air spring or spring), ``damper``, ``bump_stop`` in N;
        ``dp_b``, ``dp_r`` (Pa) and ``y`` (m) for ``"dynamic"`` (zeros otherwise).
    """
    kind = _check_variant(variant)
    if variant == "surrogate":
        raise ValueError("element_response needs a physical variant: linear, static or dynamic")
    d = np.ascontiguousarray(delta, dtype=float)
    dd = np.ascontiguousarray(delta_dot, dtype=float)
    if d.ndim != 1 or d.shape != dd.shape:
        raise ValueError(f"delta and delta_dot must be 1-D of equal length, got {d.shape}, "
                         f"{dd.shape}")  # fmt: skip
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be positive, got {dt!r}")
    out = np.empty((d.size, 7))
    _element_loop(kind, d, dd, float(dt), vehicle.kernel_params(), out)
    keys = ("force", "spring", "damper", "bump_stop", "dp_b", "dp_r", "y")
    return {k: out[:, i] for i, k in enumerate(keys)}
