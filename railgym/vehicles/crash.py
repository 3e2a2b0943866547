"""Longitudinal train-crash models: a fine reference model and the paper's surrogate model.

Pure physics (no gymnasium). Everything is SI inside (m, s, kg, N); the scenario files in
``railgym/configs/crash/*.yaml`` use mm, kN, t and km/h and are converted once by
:func:`load_scenario`.

Sign convention
---------------
``x`` points in the direction of travel, towards the barrier; every displacement is measured
from the position at first contact (t = 0). A crush zone's crush ``δ`` and force ``f`` are
positive in compression. For the wall zone (the lead car's front end) ``δ = x_front``; for the
zone between car k and car k+1 ``δ = x_front(k+1) − x_rear(k)``. The lead car obeys
``m_1 ẍ_1 = −f_wall + f_12 − friction`` and car 2 ``m_2 ẍ_2 = −f_12 − friction``. The paper's
eq. (4) uses the opposite interface argument ``x_1 − x_2`` (negative in compression), i.e.
``G_2(x_1 − x_2) = −f_12(x_2 − x_1)``; its ``G_1(x_1)`` is our ``f_wall(x_1)``.

Reference model (:func:`simulate_reference`)
--------------------------------------------
Our stand-in for the paper's LS-DYNA model, about an order of magnitude finer than eq. (4):

* each car is a chain of ``n_nodes`` lumped masses (row-sum lumping of bar elements: the end
  nodes carry half the share of the inner nodes) joined by elastic carbody links of stiffness
  ``EA / ℓ`` with viscous damping ``c = 2 ζ √(k m_red)``, so carbody elasticity and stress
  waves exist;
* each crush zone is a hysteretic elastoplastic element (:func:`zone_force`): a loading
  envelope (the scenario's piecewise-linear force–crush stages times a progressive-folding
  wave ``1 + A sin(2π (δ − δ_1)/λ)`` beyond the first point ``δ_1``), elastic unloading from
  the current point with the documented unloading stiffness ``k_u``, reloading along the same
  line back to the envelope, and permanent set ``δ_p`` (the crush at zero force). This is the
  "explicit loading envelope with elastic unloading" law used in public lumped-mass crash
  codes (the alternative being a Bouc–Wen element); see ``/work/shared/reference-data.md``,
  "Crash energy management";
* contact is unilateral (a zone never pulls); between cars the coupler's draft gear carries
  tension: linear spring ``k_t`` with damping ratio ``ζ_t``, engaged once the zone has opened
  by more than the slack beyond its permanent set (the coupler is shortened by the crushed
  tube: tension ``f = k_t (δ − δ_p + s)`` for ``δ < δ_p − s``);
* wheel–rail friction on every mass ``f_c m g tanh(v / v_ε)`` (regularised sign,
  ``v_ε = 0.01 m/s``);
* velocity Verlet (explicit, velocity-dependent forces from the predicted velocity
  ``v + a dt``) with ``dt = safety · 2 / ω_max`` where ``ω_max² = max_i 2 Σ_e k_e / m_i``
  (Gershgorin bound of M⁻¹K over the links, zones' ``k_u`` and couplers' ``k_t``), rounded
  down so that a whole number of steps fits in ``sample_dt``;
* energies: kinetic, elastic (links + elastic part of zones and couplers), plastic dissipation
  per zone (work into the zone minus its elastic energy), friction work, damping work.

Surrogate model (:func:`build_crash_surrogate`, :func:`simulate_surrogate`)
---------------------------------------------------------------------------
Paper eq. (4): one mass per car (plus the obstacle, if any); the wall element's feature is
``u = x_lead − x_barrier`` (``x_barrier = 0`` for a rigid wall), the interface's
``u = x_{k+1} − x_k``, both from the cars' centre-of-mass displacements, as the paper's
``(x_1, f_1)`` and ``(x_1 − x_2, f_2)``. Two element variants:

``"paper"``
    one LPR for the loading branch and one for the unloading branch, switched by the sign of
    the crush rate ``u̇`` (paper section 3.1); the training samples are split by
    :func:`surrogates.features.split_branches`. Each LPR's output is clipped to the force
    range of its branch's data: the unloading branch is fitted on few samples (the rebound)
    and, unclipped, its extrapolation throws the cars apart. Being memoryless, this variant
    can push at any crush (e.g. the loading force at rest when ``u̇`` is a hair above zero).
``"hysteretic"``
    the loading LPR is the envelope (fitted on virgin-loading samples only); unloading and
    reloading follow a straight line of stiffness ``k̂_u`` (estimated from the unloading samples)
    from the largest crush reached, with permanent set, exactly like the reference law; so the
    element dissipates energy only on the envelope. Interface tension, if the data have any, is a
    fitted linear spring ``k̂_t`` with slack ``ŝ`` beyond the permanent set.

A wall element never pulls (``f ≥ 0``) in either variant. LPR degrees are chosen by 10-fold
cross-validation (:func:`surrogates.selection.select_kfold`).

Batch stepping (:func:`crash_batch_model`)
------------------------------------------
For the gymnasium env: either model of a scenario advanced sample by sample for many trains
in one compiled call, with a controllable absorber in every zone: a force scale per zone
multiplies its loading envelope (surrogate: its element force) up to the absorber stroke
(:func:`absorber_zone_force`). With all scales 1 it reproduces :func:`simulate_reference` and
:func:`simulate_surrogate` step for step.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from importlib.resources import files
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import yaml
from numba import njit

from surrogates.features import LOADING, split_branches
from surrogates.models.lpr import lpr_eval_into, lpr_scratch
from surrogates.selection import factory_for, select_kfold

#: friction regularisation velocity of tanh(v / v_ε), m/s
V_EPS = 0.01
#: scenario names packaged in railgym/configs/crash
_CONFIG_DIR = ("configs", "crash")
_MAX_BASE_DEPTH = 8


# =============================================================================== scenarios
@dataclass(frozen=True)
class Coupler:
    """Draft gear of a coupler in tension.

    Attributes
    ----------
    slack : free play before tension engages, m.
    stiffness : tension stiffness ``k_t``, N/m.
    damping_ratio : viscous damping ratio of the coupler between the two cars' masses.
    """

    slack: float
    stiffness: float
    damping_ratio: float


@dataclass(frozen=True)
class CrushZone:
    """Force–crush characteristic of one crush zone (compression positive).

    The loading envelope starts at the origin and runs linearly through the points
    ``(stroke[i], force[i])``; beyond the last point the force stays at ``force[-1]``.

    Attributes
    ----------
    name : zone name (``"wall"``, ``"interface"``, ``"obstacle"``).
    stroke : crush of each point, m (strictly increasing, > 0).
    force : force of each point, N (> 0).
    absorber_stroke : crush at which the energy absorbers are used up and the carbody
        structure (survival space) starts to crush, m.
    unloading_stiffness : ``k_u`` of elastic unloading/reloading, N/m.
    fold_amplitude : relative amplitude ``A`` of the progressive-folding wave.
    fold_wavelength : fold wavelength ``λ``, m.
    coupler : draft gear in tension, or ``None`` (the zone never carries tension).
    """

    name: str
    stroke: tuple[float, ...]
    force: tuple[float, ...]
    absorber_stroke: float
    unloading_stiffness: float
    fold_amplitude: float
    fold_wavelength: float
    coupler: Coupler | None = None

    def envelope(self, crush: Any) -> np.ndarray:
        """Loading-envelope force (N) at ``crush`` (m), folding wave included."""
        d = np.atleast_1d(np.asarray(crush, dtype=float))
        s, f = np.asarray(self.stroke), np.asarray(self.force)
        return np.array(
            [_envelope(x, s, f, s.size, self.fold_amplitude, self.fold_wavelength) for x in d]
        )

    def absorber_energy(self) -> float:
        """Energy (J) the mean envelope (without folding wave) absorbs up to ``absorber_stroke``."""
        s = np.concatenate(([0.0], self.stroke))
        f = np.concatenate(([0.0], self.force))
        grid = np.linspace(0.0, self.absorber_stroke, 4001)
        return float(np.trapezoid(np.interp(grid, s, f), grid))


@dataclass(frozen=True)
class CarSpec:
    """One car: lumped-mass chain parameters.

    Attributes
    ----------
    name : ``"lead"`` or ``"passenger"``.
    mass : total mass, kg.
    length : carbody length, m.
    n_nodes : number of lumped masses in the reference model (≥ 2).
    axial_rigidity : carbody ``EA``, N.
    damping_ratio : damping ratio ``ζ`` of each carbody link.
    cab_length : driver's cab length, m (0 for a car without cab).
    """

    name: str
    mass: float
    length: float
    n_nodes: int
    axial_rigidity: float
    damping_ratio: float
    cab_length: float = 0.0


@dataclass(frozen=True)
class Obstacle:
    """A free deformable obstacle ahead of the train.

    In the reference model it is two masses (its struck face and the rest) joined by the
    obstacle's own crush zone; in the surrogate it is one mass.

    Attributes
    ----------
    mass : total mass, kg.
    face_mass : mass of the struck face, kg (< mass).
    friction : friction coefficient of the obstacle on the ground.
    zone : the obstacle's force–crush characteristic.
    """

    mass: float
    face_mass: float
    friction: float
    zone: CrushZone


@dataclass(frozen=True)
class CrashScenario:
    """A validated crash scenario, SI units.

    Attributes
    ----------
    name, description : identification.
    sources : where the numbers come from.
    speed : initial speed of the train, m/s.
    friction : wheel–rail friction coefficient ``f_c``.
    gravity : m/s².
    n_cars : lead car + ``n_cars − 1`` passenger cars.
    lead, passenger : car parameters.
    wall : crush zone at the lead car's front end (meets the wall or the obstacle).
    interface : crush zone between two cars (two coupled car ends in series).
    obstacle : ``None`` for a rigid wall, else the free obstacle.
    """

    name: str
    description: str
    sources: tuple[str, ...]
    speed: float
    friction: float
    gravity: float
    n_cars: int
    lead: CarSpec
    passenger: CarSpec
    wall: CrushZone
    interface: CrushZone
    obstacle: Obstacle | None = None

    @property
    def car_masses(self) -> np.ndarray:
        """Mass of each car, front to back, kg."""
        return np.array([self.lead.mass] + [self.passenger.mass] * (self.n_cars - 1))

    @property
    def kinetic_energy(self) -> float:
        """Initial kinetic energy of the train, J."""
        return 0.5 * float(self.car_masses.sum()) * self.speed**2

    def with_overrides(
        self, n_cars: int | None = None, speed: float | None = None
    ) -> CrashScenario:
        """Copy with another number of cars and/or initial speed (m/s)."""
        out = self
        if n_cars is not None:
            if isinstance(n_cars, bool) or not isinstance(n_cars, int | np.integer) or n_cars < 1:
                raise ValueError(f"n_cars must be an integer ≥ 1, got {n_cars!r}")
            out = replace(out, n_cars=int(n_cars))
        if speed is not None:
            if not (isinstance(speed, int | float) and math.isfinite(speed) and speed > 0):
                raise ValueError(f"speed must be a positive finite number (m/s), got {speed!r}")
            out = replace(out, speed=float(speed))
        return out


class _Fields:
    """Reads one YAML mapping, naming each field by its dotted path in errors."""

    def __init__(self, data: Any, path: str, known: tuple[str, ...]) -> None:
        if not isinstance(data, dict):
            raise ValueError(f"{path} must be a mapping, got {type(data).__name__}")
        unknown = sorted(set(map(str, data)) - set(known))
        if unknown:
            raise ValueError(f"{path}.{unknown[0]} is not a known field (known: {list(known)})")
        self.data, self.path = data, path

    def has(self, key: str) -> bool:
        return self.data.get(key) is not None

    def name(self, key: str) -> str:
        return f"{self.path}.{key}"

    def number(
        self,
        key: str,
        default: float | None = None,
        positive: bool = True,
        upper: float | None = None,
    ) -> float:
        value = self.data.get(key, default)
        if value is None:
            raise ValueError(f"{self.name(key)} is missing")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"{self.name(key)} must be a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"{self.name(key)} must be finite, got {value!r}")
        if positive and value <= 0:
            raise ValueError(f"{self.name(key)} must be positive, got {value!r}")
        if not positive and value < 0:
            raise ValueError(f"{self.name(key)} must be non-negative, got {value!r}")
        if upper is not None and value >= upper:
            raise ValueError(f"{self.name(key)} must be below {upper}, got {value!r}")
        return value

    def integer(self, key: str, default: int | None = None, lower: int = 1) -> int:
        value = self.data.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int) or value < lower:
            raise ValueError(f"{self.name(key)} must be an integer ≥ {lower}, got {value!r}")
        return value

    def text(self, key: str, default: str | None = None) -> str:
        value = self.data.get(key, default)
        if not isinstance(value, str):
            raise ValueError(f"{self.name(key)} must be a string, got {value!r}")
        return value.strip()

    def array(self, key: str) -> np.ndarray:
        value = self.data.get(key)
        if not isinstance(value, list) or not value:
            raise ValueError(f"{self.name(key)} must be a non-empty list of numbers")
        out = np.empty(len(value))
        for i, item in enumerate(value):
            if isinstance(item, bool) or not isinstance(item, int | float):
                raise ValueError(f"{self.name(key)}[{i}] must be a number, got {item!r}")
            if not math.isfinite(item):
                raise ValueError(f"{self.name(key)}[{i}] must be finite, got {item!r}")
            if item <= 0:
                raise ValueError(f"{self.name(key)}[{i}] must be positive, got {item!r}")
            out[i] = item
        return out

    def sub(self, key: str, known: tuple[str, ...]) -> _Fields:
        if key not in self.data:
            raise ValueError(f"{self.name(key)} is missing")
        return _Fields(self.data[key], self.name(key), known)


_ZONE_KEYS = (
    "stroke_mm",
    "force_kN",
    "absorber_stroke_mm",
    "unloading_stiffness_kN_per_mm",
    "fold_amplitude",
    "fold_wavelength_mm",
    "coupler",
)
_CAR_KEYS = ("mass_t", "length_m", "n_nodes", "EA_MN", "damping_ratio", "cab_length_m")


def _parse_zone(z: _Fields, name: str, allow_coupler: bool) -> CrushZone:
    stroke = z.array("stroke_mm") * 1e-3
    force = z.array("force_kN") * 1e3
    if stroke.size != force.size:
        raise ValueError(
            f"{z.name('force_kN')} has {force.size} points but {z.name('stroke_mm')} has "
            f"{stroke.size}"
        )
    steps = np.diff(stroke)
    if np.any(steps <= 0):
        i = int(np.nonzero(steps <= 0)[0][0]) + 1
        raise ValueError(f"{z.name('stroke_mm')}[{i}] must be larger than the point before it")
    ku = z.number("unloading_stiffness_kN_per_mm") * 1e6
    amp = z.number("fold_amplitude", default=0.0, positive=False, upper=0.5)
    lam = z.number("fold_wavelength_mm", default=150.0) * 1e-3
    absorber = z.number("absorber_stroke_mm") * 1e-3
    # the loading path follows the envelope only if no part of it is steeper than k_u, and
    # the permanent set grows monotonically only if no descent is steeper than -k_u
    slopes = np.abs(np.diff(force) / steps) if steps.size else np.zeros(1)
    folding = float(np.max(slopes)) * (1 + amp) + amp * 2 * math.pi / lam * float(force.max())
    steepest = max(force[0] / stroke[0], folding)
    if ku < steepest:
        raise ValueError(
            f"{z.name('unloading_stiffness_kN_per_mm')} must be at least the steepest slope of "
            f"the envelope with its folding wave ({steepest * 1e-6:.4g} kN/mm), got {ku * 1e-6:.4g}"
        )
    coupler = None
    if z.has("coupler"):
        if not allow_coupler:
            raise ValueError(f"{z.name('coupler')} is not allowed: this zone cannot carry tension")
        c = z.sub("coupler", ("slack_mm", "stiffness_kN_per_mm", "damping_ratio"))
        coupler = Coupler(
            slack=c.number("slack_mm", positive=False) * 1e-3,
            stiffness=c.number("stiffness_kN_per_mm") * 1e6,
            damping_ratio=c.number("damping_ratio", default=0.0, positive=False, upper=1.0),
        )
    return CrushZone(
        name=name,
        stroke=tuple(stroke.tolist()),
        force=tuple(force.tolist()),
        absorber_stroke=absorber,
        unloading_stiffness=ku,
        fold_amplitude=amp,
        fold_wavelength=lam,
        coupler=coupler,
    )


def _parse_car(c: _Fields, name: str) -> CarSpec:
    return CarSpec(
        name=name,
        mass=c.number("mass_t") * 1e3,
        length=c.number("length_m"),
        n_nodes=c.integer("n_nodes", default=8, lower=2),
        axial_rigidity=c.number("EA_MN") * 1e6,
        damping_ratio=c.number("damping_ratio", default=0.05, positive=False, upper=1.0),
        cab_length=c.number("cab_length_m", default=0.0, positive=False),
    )


def _deep_merge(base: dict, over: dict) -> dict:
    """``base`` updated recursively by ``over`` (mappings merge, everything else replaces)."""
    out = dict(base)
    for k, v in over.items():
        both = isinstance(v, dict) and isinstance(out.get(k), dict)
        out[k] = _deep_merge(out[k], v) if both else v
    return out


def _read_yaml(name_or_path: str | Path) -> tuple[dict, Path | None]:
    """Raw ``crash`` mapping of a packaged scenario name or a YAML path."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or p.exists():
        if not p.is_file():
            raise ValueError(f"scenario file {str(p)!r} does not exist")
        text, folder = p.read_text(encoding="utf-8"), p.parent
    else:
        res = files("railgym").joinpath(*_CONFIG_DIR, f"{name_or_path}.yaml")
        if not res.is_file():
            raise ValueError(
                f"unknown crash scenario {str(name_or_path)!r}; packaged: {scenario_names()}"
            )
        text, folder = res.read_text(encoding="utf-8"), None
    doc = yaml.safe_load(text)
    if not isinstance(doc, dict) or not isinstance(doc.get("crash"), dict):
        raise ValueError(f"{name_or_path}: the file must hold a mapping under the key 'crash'")
    return doc["crash"], folder


def _resolve(name_or_path: str | Path, depth: int = 0) -> dict:
    """Raw mapping with its ``base`` chain merged in (``base`` names a packaged scenario or a
    YAML file next to this one)."""
    if depth > _MAX_BASE_DEPTH:
        raise ValueError(f"crash.base: chain of base scenarios deeper than {_MAX_BASE_DEPTH}")
    raw, folder = _read_yaml(name_or_path)
    base = raw.get("base")
    if base is None:
        return raw
    if not isinstance(base, str):
        raise ValueError(f"crash.base must be a scenario name or path, got {base!r}")
    if folder is not None and (folder / base).is_file():
        base = str(folder / base)
    merged = _deep_merge(_resolve(base, depth + 1), raw)
    merged.pop("base")
    return merged


def scenario_names() -> list[str]:
    """Names of the packaged crash scenarios."""
    folder = files("railgym").joinpath(*_CONFIG_DIR)
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))


def load_scenario(name_or_path: str | Path = "paper") -> CrashScenario:
    """Load and validate a crash scenario, converting it to SI.

    Parameters
    ----------
    name_or_path : a packaged scenario name (see :func:`scenario_names`) or a YAML file path.
        A file may name a ``base`` scenario whose fields it overrides.

    Raises
    ------
    ValueError naming the offending field, e.g. ``crash.zones.wall.force_kN[2] must be positive``.
    """
    return parse_scenario(_resolve(name_or_path))


def parse_scenario(raw: dict) -> CrashScenario:
    """Validate the raw ``crash`` mapping of a scenario file (see :func:`load_scenario`)."""
    top = ("base", "name", "description", "sources", "speed_kmh", "friction", "gravity",
           "n_cars", "barrier", "cars", "zones")  # fmt: skip
    r = _Fields(raw, "crash", top)
    sources = raw.get("sources", [])
    if not isinstance(sources, list) or not all(isinstance(s, str) for s in sources):
        raise ValueError("crash.sources must be a list of strings")
    cars = r.sub("cars", ("lead", "passenger"))
    zones = r.sub("zones", ("wall", "interface"))
    barrier = r.sub("barrier", ("type", "mass_t", "face_mass_t", "friction", "zone"))
    kind = barrier.text("type")
    obstacle = None
    if kind == "obstacle":
        mass = barrier.number("mass_t") * 1e3
        face = barrier.number("face_mass_t") * 1e3
        if face >= mass:
            raise ValueError(f"{barrier.name('face_mass_t')} must be below mass_t")
        obstacle = Obstacle(
            mass=mass,
            face_mass=face,
            friction=barrier.number("friction", default=0.0, positive=False),
            zone=_parse_zone(barrier.sub("zone", _ZONE_KEYS), "obstacle", False),
        )
    elif kind != "rigid_wall":
        raise ValueError(f"crash.barrier.type must be 'rigid_wall' or 'obstacle', got {kind!r}")
    return CrashScenario(
        name=r.text("name"),
        description=r.text("description", default=""),
        sources=tuple(sources),
        speed=r.number("speed_kmh") / 3.6,
        friction=r.number("friction", positive=False),
        gravity=r.number("gravity", default=9.81),
        n_cars=r.integer("n_cars", default=2),
        lead=_parse_car(cars.sub("lead", _CAR_KEYS), "lead"),
        passenger=_parse_car(cars.sub("passenger", _CAR_KEYS), "passenger"),
        wall=_parse_zone(zones.sub("wall", _ZONE_KEYS), "wall", False),
        interface=_parse_zone(zones.sub("interface", _ZONE_KEYS), "interface", True),
        obstacle=obstacle,
    )


# ===================================================================== zone law (numba)
@njit(cache=True)
def _envelope(d: float, s: np.ndarray, f: np.ndarray, n: int, amp: float, lam: float) -> float:
    """Loading-envelope force (N) at crush ``d`` (m): origin → points, then constant; times the
    folding wave ``1 + amp sin(2π (d − s[0]) / lam)`` beyond the first point."""
    if d <= 0.0:
        return 0.0
    if d <= s[0]:
        return f[0] * d / s[0]
    if d >= s[n - 1]:
        base = f[n - 1]
    else:
        k = 1
        while s[k] < d:
            k += 1
        base = f[k - 1] + (d - s[k - 1]) / (s[k] - s[k - 1]) * (f[k] - f[k - 1])
    return base * (1.0 + amp * math.sin(2.0 * math.pi * (d - s[0]) / lam))


@njit(cache=True)
def zone_force(
    d: float, dp: float, s: np.ndarray, f: np.ndarray, n: int, amp: float, lam: float, ku: float
) -> tuple[float, float]:
    """Hysteretic crush-zone law: force (N, ≥ 0) and updated permanent set (m).

    Elastic trial ``k_u (d − dp)``: no force in a gap, elastic below the envelope, and on the
    envelope the force follows it while the permanent set moves to ``d − f_env / k_u``.
    """
    return absorber_zone_force(d, dp, s, f, n, amp, lam, ku, math.inf, 1.0)


@njit(cache=True)
def absorber_zone_force(
    d: float, dp: float, s: np.ndarray, f: np.ndarray, n: int, amp: float, lam: float, ku: float,
    absorber: float, scale: float,
) -> tuple[float, float]:  # fmt: skip
    """:func:`zone_force` with a controllable absorber: the loading envelope up to the absorber
    stroke ``absorber`` (m) is multiplied by ``scale``; beyond it (the carbody structure) and
    the unloading stiffness are unchanged."""
    trial = ku * (d - dp)
    if trial <= 0.0:
        return 0.0, dp
    env = _envelope(d, s, f, n, amp, lam)
    if d <= absorber:
        env *= scale
    if trial >= env:
        return env, d - env / ku
    return trial, dp


# ============================================================ reference model (numba)
@dataclass
class _Chain:
    """Node/element arrays of the reference model (front to back)."""

    m: np.ndarray
    v0: np.ndarray
    mu: np.ndarray
    link_k: np.ndarray  # per element between node e and e+1 (0 for zones)
    link_c: np.ndarray
    elem_zone: np.ndarray  # zone instance of element e, −1 for a link
    wall_zone: int  # zone instance at a fixed wall ahead of node 0, −1 if none
    zone_type: np.ndarray  # type table row of each zone instance
    zone_cc: np.ndarray  # coupler damping coefficient of each instance, N s/m
    t_s: np.ndarray  # (types, P) stroke points
    t_f: np.ndarray
    t_n: np.ndarray
    t_amp: np.ndarray
    t_lam: np.ndarray
    t_ku: np.ndarray
    t_kt: np.ndarray
    t_slack: np.ndarray
    t_abs: np.ndarray  # absorber stroke of each type, m
    body_start: np.ndarray
    body_end: np.ndarray
    body_names: list[str]
    zone_names: list[str]
    zone_front: np.ndarray  # front node of each zone instance (−1 = fixed wall)
    zone_back: np.ndarray
    omega_max: float


def _build_chain(sc: CrashScenario) -> _Chain:
    types = [sc.wall, sc.interface] + ([sc.obstacle.zone] if sc.obstacle else [])
    P = max(len(z.stroke) for z in types)
    t_s = np.ones((len(types), P))
    t_f = np.zeros((len(types), P))
    for i, z in enumerate(types):
        t_s[i, : len(z.stroke)] = z.stroke
        t_f[i, : len(z.force)] = z.force
    t_n = np.array([len(z.stroke) for z in types], dtype=np.int64)
    t_kt = np.array([z.coupler.stiffness if z.coupler else 0.0 for z in types])
    t_slack = np.array([z.coupler.slack if z.coupler else 0.0 for z in types])

    m: list[float] = []
    v0: list[float] = []
    mu: list[float] = []
    link_k: list[float] = []
    link_c: list[float] = []
    elem_zone: list[int] = []
    zone_type: list[int] = []
    zone_cc: list[float] = []
    zone_front: list[int] = []
    zone_back: list[int] = []
    zone_names: list[str] = []
    bodies: dict[str, tuple[int, int]] = {}

    def add_zone(t: int, name: str, front: int, back: int, cc: float) -> int:
        zone_type.append(t)
        zone_cc.append(cc)
        zone_front.append(front)
        zone_back.append(back)
        zone_names.append(name)
        return len(zone_type) - 1

    wall_zone = -1
    if sc.obstacle is None:
        wall_zone = add_zone(0, "wall", -1, 0, 0.0)
    else:
        ob = sc.obstacle
        m += [ob.mass - ob.face_mass, ob.face_mass]
        v0 += [0.0, 0.0]
        mu += [ob.friction] * 2
        bodies["obstacle"] = (0, 2)
        link_k.append(0.0)
        link_c.append(0.0)
        elem_zone.append(add_zone(2, "obstacle", 0, 1, 0.0))
    masses = sc.car_masses
    for k in range(sc.n_cars):
        car = sc.lead if k == 0 else sc.passenger
        first = len(m)
        if first > 0:  # element joining the previous body to this car
            link_k.append(0.0)
            link_c.append(0.0)
            if k == 0:
                elem_zone.append(add_zone(0, "wall", first - 1, first, 0.0))
            else:
                cc = 0.0
                if sc.interface.coupler is not None:
                    mred = masses[k - 1] * masses[k] / (masses[k - 1] + masses[k])
                    cp = sc.interface.coupler
                    cc = 2 * cp.damping_ratio * math.sqrt(cp.stiffness * mred)
                elem_zone.append(add_zone(1, f"interface_{k}", first - 1, first, cc))
        n = car.n_nodes
        mi = np.full(n, car.mass / (n - 1))
        mi[[0, -1]] *= 0.5
        m += mi.tolist()
        v0 += [sc.speed] * n
        mu += [sc.friction] * n
        k_link = car.axial_rigidity / (car.length / (n - 1))
        for j in range(n - 1):
            mred = mi[j] * mi[j + 1] / (mi[j] + mi[j + 1])
            link_k.append(k_link)
            link_c.append(2 * car.damping_ratio * math.sqrt(k_link * mred))
            elem_zone.append(-1)
        bodies["lead" if k == 0 else f"car{k + 1}"] = (first, first + n)

    m_arr = np.array(m)
    # Gershgorin bound of M⁻¹K: ω² ≤ max_i 2 Σ_e k_e / m_i
    k_elem = np.array(link_k)
    ztype = np.array(zone_type, dtype=np.int64)
    kz = np.array([max(types[t].unloading_stiffness, t_kt[t]) for t in zone_type])
    for e, z in enumerate(elem_zone):
        if z >= 0:
            k_elem[e] = kz[z]
    k_node = np.zeros(m_arr.size)
    k_node[:-1] += k_elem
    k_node[1:] += k_elem
    if wall_zone >= 0:
        k_node[0] += kz[wall_zone]
    omega_max = float(np.sqrt(np.max(2.0 * k_node / m_arr)))
    names = [n for n in bodies if n != "obstacle"] + (["obstacle"] if "obstacle" in bodies else [])
    return _Chain(
        m=m_arr,
        v0=np.array(v0),
        mu=np.array(mu),
        link_k=np.array(link_k),
        link_c=np.array(link_c),
        elem_zone=np.array(elem_zone, dtype=np.int64),
        wall_zone=wall_zone,
        zone_type=ztype,
        zone_cc=np.array(zone_cc),
        t_s=t_s,
        t_f=t_f,
        t_n=t_n,
        t_amp=np.array([z.fold_amplitude for z in types]),
        t_lam=np.array([z.fold_wavelength for z in types]),
        t_ku=np.array([z.unloading_stiffness for z in types]),
        t_kt=t_kt,
        t_slack=t_slack,
        t_abs=np.array([z.absorber_stroke for z in types]),
        body_start=np.array([bodies[n][0] for n in names], dtype=np.int64),
        body_end=np.array([bodies[n][1] for n in names], dtype=np.int64),
        body_names=names,
        zone_names=zone_names,
        zone_front=np.array(zone_front, dtype=np.int64),
        zone_back=np.array(zone_back, dtype=np.int64),
        omega_max=omega_max,
    )


@njit(cache=True)
def _chain_forces(
    x, v, dp, m, mu, g, veps, link_k, link_c, elem_zone, zone_type, zone_cc,
    zone_front, zone_back, t_s, t_f, t_n, t_amp, t_lam, t_ku, t_kt, t_slack, t_abs, scale,
    F, fz, fzel, fd, ff, dz,
):  # fmt: skip
    """Nodal forces ``F`` at state (x, v); updates the permanent sets ``dp`` in place.

    ``scale`` (per zone instance) multiplies each zone's envelope up to its type's absorber
    stroke ``t_abs`` (:func:`absorber_zone_force`).

    Also returns per zone instance: conservative force ``fz`` (zone + coupler spring), its
    elastic energy ``fzel``, crush ``dz``; per element: damping force ``fd``; per node: friction
    magnitude along v, ``ff`` (the force is ``−ff``).
    """
    N = x.shape[0]
    for i in range(N):
        ff[i] = mu[i] * m[i] * g * math.tanh(v[i] / veps)
        F[i] = -ff[i]
    for z in range(zone_type.shape[0]):
        t = zone_type[z]
        fr = zone_front[z]
        bk = zone_back[z]
        d = x[bk] - (x[fr] if fr >= 0 else 0.0)
        rate = v[bk] - (v[fr] if fr >= 0 else 0.0)
        dz[z] = d
        f, dp[z] = absorber_zone_force(d, dp[z], t_s[t], t_f[t], t_n[t], t_amp[t], t_lam[t],
                                       t_ku[t], t_abs[t], scale[z])
        el = 0.5 * f * f / t_ku[t]
        damp = 0.0
        if f == 0.0 and t_kt[t] > 0.0 and d < dp[z] - t_slack[t]:
            ext = d - dp[z] + t_slack[t]
            f = t_kt[t] * ext
            el = 0.5 * t_kt[t] * ext * ext
            damp = zone_cc[z] * rate
        fz[z] = f
        fzel[z] = el
        if fr >= 0:
            F[fr] += f + damp
        F[bk] -= f + damp
        if bk > 0:
            fd[bk - 1] = damp
    for e in range(N - 1):
        if elem_zone[e] >= 0:
            continue
        d = x[e + 1] - x[e]
        fd[e] = link_c[e] * (v[e + 1] - v[e])
        f = link_k[e] * d + fd[e]
        F[e] += f
        F[e + 1] -= f


@njit(cache=True)
def _reference_kernel(
    m, v0, mu, g, veps, link_k, link_c, elem_zone, zone_type, zone_cc, zone_front,
    zone_back, t_s, t_f, t_n, t_amp, t_lam, t_ku, t_kt, t_slack, t_abs, body_start, body_end,
    dt, n_sub, n_samples, stop, v_stop, f_stop,
):  # fmt: skip
    """Velocity-Verlet integration of the chain; samples every ``n_sub`` steps."""
    N = m.shape[0]
    nz = zone_type.shape[0]
    nb = body_start.shape[0]
    x = np.zeros(N)
    v = v0.copy()
    vp = np.empty(N)
    dp = np.zeros(nz)
    F = np.zeros(N)
    fz = np.zeros(nz)
    fzel = np.zeros(nz)
    fd = np.zeros(max(N - 1, 1))
    ff = np.zeros(N)
    dz = np.zeros(nz)
    scale = np.ones(nz)
    fz_o = np.zeros(nz)
    fd_o = np.zeros(max(N - 1, 1))
    ff_o = np.zeros(N)
    dz_o = np.zeros(nz)
    wz = np.zeros(nz)
    w_fric = 0.0
    w_damp = 0.0
    out_xb = np.zeros((n_samples, nb))
    out_vb = np.zeros((n_samples, nb))
    out_ab = np.zeros((n_samples, nb))
    out_dz = np.zeros((n_samples, nz))
    out_fz = np.zeros((n_samples, nz))
    out_dp = np.zeros((n_samples, nz))
    out_e = np.zeros((n_samples, 5))  # kinetic, elastic links, elastic zones, friction, damping
    out_pl = np.zeros((n_samples, nz))

    _chain_forces(x, v, dp, m, mu, g, veps, link_k, link_c, elem_zone, zone_type, zone_cc,
                  zone_front, zone_back, t_s, t_f, t_n, t_amp, t_lam, t_ku, t_kt, t_slack,
                  t_abs, scale, F, fz, fzel, fd, ff, dz)  # fmt: skip
    a = F / m
    dx = np.empty(N)
    n_out = 0
    for k in range(n_samples):
        if k > 0:
            for _ in range(n_sub):
                fz_o[:] = fz
                fd_o[:] = fd
                ff_o[:] = ff
                dz_o[:] = dz
                for i in range(N):
                    dx[i] = v[i] * dt + 0.5 * a[i] * dt * dt
                    x[i] += dx[i]
                    vp[i] = v[i] + a[i] * dt
                _chain_forces(x, vp, dp, m, mu, g, veps, link_k, link_c, elem_zone, zone_type,
                              zone_cc, zone_front, zone_back, t_s, t_f, t_n, t_amp, t_lam,
                              t_ku, t_kt, t_slack, t_abs, scale, F, fz, fzel, fd, ff,
                              dz)  # fmt: skip
                for i in range(N):
                    a_new = F[i] / m[i]
                    v[i] += 0.5 * (a[i] + a_new) * dt
                    a[i] = a_new
                for z in range(nz):
                    wz[z] += 0.5 * (fz_o[z] + fz[z]) * (dz[z] - dz_o[z])
                for e in range(N - 1):
                    w_damp += 0.5 * (fd_o[e] + fd[e]) * (dx[e + 1] - dx[e])
                for i in range(N):
                    w_fric += 0.5 * (ff_o[i] + ff[i]) * dx[i]
        # ---- sample
        ke = 0.0
        for i in range(N):
            ke += 0.5 * m[i] * v[i] * v[i]
        el = 0.0
        for e in range(N - 1):
            if elem_zone[e] < 0:
                d = x[e + 1] - x[e]
                el += 0.5 * link_k[e] * d * d
        elz = 0.0
        for z in range(nz):
            elz += fzel[z]
            out_pl[k, z] = wz[z] - fzel[z]
            out_dz[k, z] = dz[z]
            out_fz[k, z] = fz[z] + (fd[zone_back[z] - 1] if zone_front[z] >= 0 else 0.0)
            out_dp[k, z] = dp[z]
        out_e[k, 0] = ke
        out_e[k, 1] = el
        out_e[k, 2] = elz
        out_e[k, 3] = w_fric
        out_e[k, 4] = w_damp
        for b in range(nb):
            mb = 0.0
            for i in range(body_start[b], body_end[b]):
                mb += m[i]
                out_xb[k, b] += m[i] * x[i]
                out_vb[k, b] += m[i] * v[i]
                out_ab[k, b] += F[i]
            out_xb[k, b] /= mb
            out_vb[k, b] /= mb
            out_ab[k, b] /= mb
        n_out = k + 1
        if stop and k > 0:
            over = True
            for z in range(nz):
                fr = zone_front[z]
                rate = v[zone_back[z]] - (v[fr] if fr >= 0 else 0.0)
                if fz[z] > f_stop or rate > v_stop:
                    over = False
                    break
            if over:
                break
    return out_xb, out_vb, out_ab, out_dz, out_fz, out_dp, out_e, out_pl, n_out


@dataclass
class CrashResult:
    """Time histories of a crash simulation, sampled every ``sample_dt``.

    Attributes
    ----------
    t : (n,) time, s.
    x, v, a : (n, bodies) centre-of-mass displacement (m), velocity (m/s) and acceleration
        (m/s²) of each body; bodies are the cars front to back, then the obstacle if any.
    body_names : names of the bodies (``"lead"``, ``"car2"``, ..., ``"obstacle"``).
    zone_names : names of the zone instances (``"wall"``, ``"interface_1"``, ...).
    crush, force : (n, zones) crush (m) and force (N, compression positive) of each zone; for
        the surrogate, the element feature ``u`` (m) and force.
    permanent_set : (n, zones) permanent set of each zone, m.
    energy : dict of (n,) or (n, zones) arrays, J: ``kinetic``, ``elastic`` (total),
        ``plastic`` (per zone), ``friction``, ``damping``; empty for the surrogate.
    initial_kinetic_energy : J.
    dt : integration time step, s.
    wall_time : wall-clock time of the integration (compiled kernel only), s.
    scenario : the simulated scenario.
    model : ``"reference"`` or ``"surrogate:<variant>"``.
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    body_names: list[str]
    zone_names: list[str]
    crush: np.ndarray
    force: np.ndarray
    permanent_set: np.ndarray
    energy: dict[str, np.ndarray]
    initial_kinetic_energy: float
    dt: float
    wall_time: float
    scenario: CrashScenario
    model: str = "reference"
    extra: dict[str, Any] = field(default_factory=dict)

    def energy_residual(self) -> np.ndarray:
        """(n,) relative energy-balance error ``(E_0 − Σ energies) / E_0`` (reference only)."""
        if not self.energy:
            raise ValueError(f"{self.model} results carry no energy histories")
        e = self.energy
        total = (
            e["kinetic"] + e["elastic"] + e["plastic"].sum(axis=1) + e["friction"] + e["damping"]
        )
        return (self.initial_kinetic_energy - total) / self.initial_kinetic_energy

    def intrusion(self) -> dict[str, float]:
        """Largest crush beyond each zone's absorber stroke (structure crush), m."""
        sc = self.scenario
        zones = {"wall": sc.wall, "obstacle": sc.obstacle.zone if sc.obstacle else None}
        out = {}
        for j, name in enumerate(self.zone_names):
            zone = zones.get(name, sc.interface)
            out[name] = max(0.0, float(self.permanent_set[:, j].max()) - zone.absorber_stroke)
        return out


def reference_time_step(
    scenario: CrashScenario, sample_dt: float = 1e-3, safety: float = 0.2
) -> tuple[float, int]:
    """Integration step of the reference model and the number of steps per sample.

    ``dt = safety · 2 / ω_max`` rounded down to ``sample_dt / n_sub``.
    """
    chain = _build_chain(scenario)
    return _steps(sample_dt, safety * 2.0 / chain.omega_max)


def _steps(sample_dt: float, dt_max: float) -> tuple[float, int]:
    n_sub = max(1, math.ceil(sample_dt / dt_max - 1e-9))
    return sample_dt / n_sub, n_sub


def _check_run(duration: float, sample_dt: float) -> None:
    for name, value in (("duration", duration), ("sample_dt", sample_dt)):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive finite number (s), got {value!r}")
    if sample_dt > duration:
        raise ValueError(f"sample_dt ({sample_dt} s) must not exceed duration ({duration} s)")


def simulate_reference(
    scenario: CrashScenario | str,
    n_cars: int | None = None,
    speed: float | None = None,
    duration: float = 2.0,
    sample_dt: float = 1e-3,
    safety: float = 0.2,
    stop_when_over: bool = True,
    v_stop: float = 0.01,
    f_stop: float = 1e3,
) -> CrashResult:
    """Run the reference lumped-mass crash model.

    Parameters
    ----------
    scenario : a :class:`CrashScenario` or a name/path for :func:`load_scenario`.
    n_cars, speed : optional overrides (number of cars; initial speed in m/s).
    duration : longest simulated time, s.
    sample_dt : output interval, s.
    safety : time-step safety factor on ``2 / ω_max`` (0 < safety ≤ 1).
    stop_when_over : end at the first sample where no zone carries more than ``f_stop`` (N) of
        compression and no zone closes faster than ``v_stop`` (m/s): all cars at rest or
        rebounding away.
    """
    sc = load_scenario(scenario) if isinstance(scenario, str | Path) else scenario
    sc = sc.with_overrides(n_cars=n_cars, speed=speed)
    _check_run(duration, sample_dt)
    if not 0 < safety <= 1:
        raise ValueError(f"safety must be in (0, 1], got {safety!r}")
    ch = _build_chain(sc)
    dt, n_sub = _steps(sample_dt, safety * 2.0 / ch.omega_max)
    n_samples = int(round(duration / sample_dt)) + 1
    t0 = time.perf_counter()
    xb, vb, ab, dz, fz, dpz, e, pl, n = _reference_kernel(
        ch.m, ch.v0, ch.mu, sc.gravity, V_EPS, ch.link_k, ch.link_c, ch.elem_zone, ch.zone_type,
        ch.zone_cc, ch.zone_front, ch.zone_back, ch.t_s, ch.t_f,
        ch.t_n, ch.t_amp, ch.t_lam, ch.t_ku, ch.t_kt, ch.t_slack, ch.t_abs, ch.body_start,
        ch.body_end,
        dt, n_sub, n_samples, stop_when_over, v_stop, f_stop,
    )  # fmt: skip
    wall = time.perf_counter() - t0
    return CrashResult(
        t=np.arange(n) * sample_dt,
        x=xb[:n],
        v=vb[:n],
        a=ab[:n],
        body_names=ch.body_names,
        zone_names=ch.zone_names,
        crush=dz[:n],
        force=fz[:n],
        permanent_set=dpz[:n],
        energy={
            "kinetic": e[:n, 0],
            "elastic": e[:n, 1] + e[:n, 2],
            "elastic_links": e[:n, 1],
            "elastic_zones": e[:n, 2],
            "plastic": pl[:n],
            "friction": e[:n, 3],
            "damping": e[:n, 4],
        },
        initial_kinetic_energy=float(0.5 * np.sum(ch.m * ch.v0**2)),
        dt=dt,
        wall_time=wall,
        scenario=sc,
        model="reference",
        extra={"omega_max": ch.omega_max, "n_sub": n_sub, "safety": safety},
    )


# ===================================================================== surrogate model
#: element variants of the surrogate model
VARIANTS = ("paper", "hysteretic")


@dataclass
class CrashElement:
    """One surrogate crash element (paper eq. 4), fitted on reference time histories.

    Attributes
    ----------
    name : ``"wall"`` (lead car against the barrier) or ``"interface"`` (between two cars).
    variant : ``"paper"`` or ``"hysteretic"`` (see the module docstring).
    loading : LPR of the loading branch (``"paper"``) or of the envelope (``"hysteretic"``),
        force (N) of the feature ``u`` (m).
    unloading : LPR of the unloading branch (``"paper"`` only).
    unloading_stiffness : ``k̂_u`` of elastic unloading/reloading, N/m (estimated for both
        variants, used by ``"hysteretic"``).
    tension_stiffness, slack : fitted coupler tension ``k̂_t`` (N/m; 0 = none) and slack ``ŝ``
        (m) beyond the permanent set (``"hysteretic"``).
    unilateral : the element never pulls and carries no force for ``u ≤ 0`` (the wall).
    force_range : (branch → (lowest, highest) training force, N); each LPR's output is clipped
        to its branch's range, so that a branch extrapolated beyond its data (the paper
        variant's unloading branch, fitted on a narrow set) cannot produce unseen forces.
    selection : 10-fold cross-validation table of each fitted LPR (branch → SelectionResult).
    n_samples : number of training samples of each branch.
    """

    name: str
    variant: str
    loading: Any
    unloading: Any
    unloading_stiffness: float
    tension_stiffness: float
    slack: float
    unilateral: bool
    force_range: dict[str, tuple[float, float]]
    selection: dict[str, Any]
    n_samples: dict[str, int]

    @property
    def degrees(self) -> dict[str, int]:
        """Chosen LPR degree of each branch."""
        out = {"loading": _degree(self.loading)}
        if self.unloading is not None:
            out["unloading"] = _degree(self.unloading)
        return out


@dataclass
class CrashSurrogate:
    """The surrogate elements of one model: ``elements["wall"]`` and ``elements["interface"]``."""

    variant: str
    elements: dict[str, CrashElement]
    source: str
    build_time: float


def _degree(model: Any) -> int:
    d = model.degree
    return int(d[0] if isinstance(d, tuple) else d)


TrainingSet = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def crash_training_data(result: CrashResult, branch_tol: float = 0.01) -> dict[str, TrainingSet]:
    """Surrogate training data ``(u, f, u̇, loading, series)`` per element type.

    ``u`` from the cars' centre-of-mass displacements: wall ``x_lead − x_barrier``, interface
    ``x_{k+1} − x_k`` (all interfaces pooled); ``f`` the zone's force (N); ``u̇`` by
    :func:`numpy.gradient` of each series (m/s); ``loading`` the loading-branch mask of
    :func:`surrogates.features.split_branches` (sign of the crush rate with hysteresis
    ``branch_tol`` × the 90th percentile of |u̇|; its default 0.05, i.e. ~0.5 m/s in a 40 km/h
    crash, would label the slow rebound as loading); ``series`` the index of the time
    history each sample comes from (one per interface).
    """
    t = result.t
    if t.size < 3:
        raise ValueError("result has fewer than 3 samples: too short to train on")
    names = result.body_names
    x_bar = result.x[:, names.index("obstacle")] if "obstacle" in names else 0.0
    n_cars = result.scenario.n_cars
    series: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {"wall": [], "interface": []}
    wall = result.force[:, result.zone_names.index("wall")]
    series["wall"].append((result.x[:, 0] - x_bar, wall))
    for k in range(1, n_cars):
        j = result.zone_names.index(f"interface_{k}")
        series["interface"].append((result.x[:, k] - result.x[:, k - 1], result.force[:, j]))
    out = {}
    for key, items in series.items():
        if items:
            u = np.concatenate([s[0] for s in items])
            f = np.concatenate([s[1] for s in items])
            rate = np.concatenate([np.gradient(s[0], t) for s in items])
            load = np.concatenate(
                [split_branches(s[0], t, tol=branch_tol) == LOADING for s in items]
            )
            series_id = np.repeat(np.arange(len(items)), t.size)
            out[key] = (u, f, rate, load, series_id)
    return out


def virgin_loading(
    u: np.ndarray, rate: np.ndarray, series: np.ndarray | None = None, tol: float = 1e-4
) -> np.ndarray:
    """Mask of the samples on the virgin loading path: crush growing and within ``tol`` (m) of
    the largest crush reached so far in the same time history (``series``, default one)."""
    series = np.zeros(u.size, dtype=np.int64) if series is None else series
    out = np.zeros(u.size, dtype=bool)
    for k in np.unique(series):
        i = series == k
        out[i] = (rate[i] > 0.0) & (u[i] >= np.maximum.accumulate(u[i]) - tol)
    return out


def _fit_lpr(u: np.ndarray, f: np.ndarray, max_degree: int, seed: int) -> tuple[Any, Any]:
    """LPR of f(u) with the degree chosen by 10-fold CV (``clip`` extrapolation)."""
    n = u.size
    if n < 4:
        raise ValueError(f"too few training samples ({n}) to fit a surrogate branch")
    make = factory_for("lpr", extrapolation="clip")
    cands = list(range(1, min(max_degree, n - 2) + 1))
    sel = select_kfold(make, cands, u[:, None], f, k=min(10, n), seed=seed)
    return make(sel.best).fit(u[:, None], f), sel


def _unloading_stiffness(
    u: np.ndarray, f: np.ndarray, rate: np.ndarray, series: np.ndarray
) -> float:
    """Least-squares slope (N/m) of Δf against Δu over consecutive unloading samples under load."""
    du, df = np.diff(u), np.diff(f)
    ok = (rate[1:] < 0) & (rate[:-1] < 0) & (f[1:] > 0) & (f[:-1] > 0) & (du < 0) & (df < 0)
    ok &= series[1:] == series[:-1]
    if np.count_nonzero(ok) < 2:
        raise ValueError("the training data hold no elastic unloading: k_u cannot be estimated")
    return float(np.sum(df[ok] * du[ok]) / np.sum(du[ok] ** 2))


def build_crash_surrogate(
    reference: CrashResult,
    variant: str = "hysteretic",
    seed: int = 0,
    max_degree: int = 30,
) -> CrashSurrogate:
    """Fit the surrogate elements of paper eq. (4) on a reference result.

    Parameters
    ----------
    reference : output of :func:`simulate_reference`.
    variant : ``"paper"`` (loading/unloading LPR switched by the crush rate) or
        ``"hysteretic"`` (LPR envelope + elastic unloading, energy-consistent).
    seed : seed of the cross-validation folds.
    max_degree : largest LPR degree tried by 10-fold cross-validation.
    """
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    if reference.model != "reference":
        raise ValueError(f"reference must be a reference-model result, got {reference.model!r}")
    t0 = time.perf_counter()
    elements = {}
    for name, (u, f, rate, loading, series) in crash_training_data(reference).items():
        unilateral = name == "wall"
        sel: dict[str, Any] = {}
        n: dict[str, int] = {}
        kt = slack = 0.0
        unload = None
        if variant == "paper":
            lo, un = loading, ~loading
            load, sel["loading"] = _fit_lpr(u[lo], f[lo], max_degree, seed)
            unload, sel["unloading"] = _fit_lpr(u[un], f[un], max_degree, seed)
            n = {"loading": int(lo.sum()), "unloading": int(un.sum())}
            rng = {"loading": (f[lo].min(), f[lo].max()), "unloading": (f[un].min(), f[un].max())}
            ku = _unloading_stiffness(u, f, rate, series)
        else:
            vg = virgin_loading(u, rate, series) & (f > 0)
            uu = np.concatenate(([0.0], u[vg]))
            ff = np.concatenate(([0.0], f[vg]))
            load, sel["loading"] = _fit_lpr(uu, ff, max_degree, seed)
            ku = _unloading_stiffness(u, f, rate, series)
            n = {"loading": int(uu.size)}
            rng = {"loading": (0.0, ff.max())}
            tension = f < 0
            if not unilateral and np.count_nonzero(tension) >= 5:
                # f = k_t (u − u_0) on the tension samples; slack measured from the final set
                A = np.column_stack([u[tension], np.ones(np.count_nonzero(tension))])
                (kt, c), *_ = np.linalg.lstsq(A, f[tension], rcond=None)
                up = _permanent_set_history(u, series, load, ku)
                slack = max(0.0, float(up[tension].mean() + c / kt)) if kt > 0 else 0.0
                kt = max(float(kt), 0.0)
                n["tension"] = int(np.count_nonzero(tension))
        elements[name] = CrashElement(
            name=name,
            variant=variant,
            loading=load,
            unloading=unload,
            unloading_stiffness=ku,
            tension_stiffness=kt,
            slack=slack,
            unilateral=unilateral,
            force_range={k: (float(a), float(b)) for k, (a, b) in rng.items()},
            selection=sel,
            n_samples=n,
        )
    return CrashSurrogate(
        variant=variant,
        elements=elements,
        source=reference.scenario.name,
        build_time=time.perf_counter() - t0,
    )


def _permanent_set_history(
    u: np.ndarray, series: np.ndarray, envelope: Any, ku: float
) -> np.ndarray:
    """Permanent set (m) along each feature history ``u`` under the hysteretic element law."""
    env = envelope.predict(u[:, None])
    up = np.zeros_like(u)
    cur = 0.0
    for i in range(u.size):
        if i > 0 and series[i] != series[i - 1]:
            cur = 0.0
        if env[i] > 0 and ku * (u[i] - cur) >= env[i]:
            cur = u[i] - env[i] / ku
        up[i] = cur
    return up


@njit(cache=True)
def _lpr_work(lpr):
    """Scratch of :func:`surrogates.models.lpr.lpr_eval_into` for every packed LPR model of
    ``lpr`` (:func:`_pack_models`): float64 (models, d + 4, L), one common width ``L``."""
    E, _, LO, UP, _, _ = lpr
    n, T, d = E.shape
    every = E.reshape(n * T, d)  # the largest degree of all models sets the common width
    first = lpr_scratch(every, LO[0], UP[0])
    work = np.empty((n, first.shape[0], first.shape[1]))
    work[0] = first
    for k in range(1, n):
        work[k] = lpr_scratch(every, LO[k], UP[k])
    return work


@njit(cache=True, inline="always")
def _element_model(u, rate, up, variant, unilateral, ku, i_load, i_unload):
    """Index of the LPR model the element law (:func:`_element_force`) reads at feature ``u``,
    rate ``u̇`` and permanent set ``up``; −1 where it needs none."""
    if unilateral and u <= 0.0:
        return -1
    if variant == 0:
        return i_load if rate >= 0.0 else i_unload
    return i_load if ku * (u - up) > 0.0 else -1


@njit(cache=True, inline="always")
def _element_force(u, up, f_lpr, f_min, f_max, s, variant, unilateral, ku, kt, slack):
    """Force (N, compression positive) and new permanent set of one surrogate element.

    ``f_lpr`` is the value at ``u`` of the LPR model chosen by :func:`_element_model` and
    ``[f_min, f_max]`` that model's force range, N (unused where it chose none). ``s``
    multiplies the LPR force (controllable absorber, 1 beyond the absorber stroke, as
    :func:`absorber_zone_force`). ``variant`` 0 is ``"paper"``, 1 ``"hysteretic"``; ``k_u``,
    ``k_t`` (N/m) and ``slack`` (m) as in :class:`CrashElement`.
    """
    if unilateral and u <= 0.0:
        return 0.0, up
    if variant == 0:
        f = s * min(max(f_lpr, f_min), f_max)
        if unilateral and f < 0.0:
            f = 0.0
        return f, up
    trial = ku * (u - up)
    if trial > 0.0:
        env = s * min(f_lpr, f_max)
        if env <= 0.0:
            return 0.0, up
        if trial >= env:
            return env, u - env / ku
        return trial, up
    if kt > 0.0 and u < up - slack:
        return kt * (u - up + slack), up
    return 0.0, up


# The two surrogate kernels below evaluate the elements in their own loop body (tuples unpacked
# once per call): behind a helper taking the packed arrays, numba's reference counting of
# those arrays cost more than the physics (measured 2 × the whole kernel time).
@njit(cache=True)
def _surrogate_kernel(m, mu, v0, g, veps, elements, types, lpr, dt, n_sub, n_samples, stop,
                      v_stop, f_stop):  # fmt: skip
    """Velocity-Verlet integration of the n-mass surrogate model (paper eq. 4).

    ``elements`` (elements, 3) = front body (−1 = wall), back body, type; ``types`` = (int
    (types, 4): variant, loading model, unloading model, unilateral; float (types, 4): k_u, k_t,
    slack, absorber stroke); ``lpr`` = (exponents, coef, lower, upper, mode, force range) per
    LPR model (:func:`_pack_models`). (Tables rather than one array per quantity: each array
    passed into a compiled function costs about 0.08 µs, a sizeable part of an env step.)
    """
    el_front, el_back, el_type = elements[:, 0], elements[:, 1], elements[:, 2]
    variant, i_load, i_unload, unilateral = types[0].T
    ku, kt, slack, _ = types[1].T
    E, C, LO, UP, MODE, FR = lpr
    nb = m.shape[0]
    ne = el_type.shape[0]
    x = np.zeros(nb)
    v = v0.copy()
    vp = v0.copy()
    a = np.zeros(nb)
    up = np.zeros(ne)
    F = np.zeros(nb)
    fel = np.zeros(ne)
    uel = np.zeros(ne)
    ubuf = np.zeros(1)
    work = _lpr_work(lpr)
    out_x = np.zeros((n_samples, nb))
    out_v = np.zeros((n_samples, nb))
    out_a = np.zeros((n_samples, nb))
    out_u = np.zeros((n_samples, ne))
    out_f = np.zeros((n_samples, ne))
    out_up = np.zeros((n_samples, ne))
    n_out = 0
    for k in range(n_samples):
        # sample 0: forces at the initial state; then n_sub steps per sample
        for _ in range(n_sub if k > 0 else 1):
            if k > 0:
                for j in range(nb):
                    x[j] += v[j] * dt + 0.5 * a[j] * dt * dt
                    vp[j] = v[j] + a[j] * dt
            for j in range(nb):
                F[j] = -mu[j] * m[j] * g * math.tanh(vp[j] / veps)
            for e in range(ne):
                fr, bk, ty = el_front[e], el_back[e], el_type[e]
                u = x[bk] - (x[fr] if fr >= 0 else 0.0)
                rate = vp[bk] - (vp[fr] if fr >= 0 else 0.0)
                mdl = _element_model(u, rate, up[e], variant[ty], unilateral[ty], ku[ty],
                                     i_load[ty], i_unload[ty])  # fmt: skip
                f_lpr = f_min = f_max = 0.0
                if mdl >= 0:
                    ubuf[0] = u
                    f_lpr = lpr_eval_into(ubuf, E[mdl], C[mdl], LO[mdl], UP[mdl], MODE[mdl],
                                          work[mdl])  # fmt: skip
                    f_min, f_max = FR[mdl, 0], FR[mdl, 1]
                f, up[e] = _element_force(u, up[e], f_lpr, f_min, f_max, 1.0, variant[ty],
                                          unilateral[ty], ku[ty], kt[ty], slack[ty])  # fmt: skip
                fel[e] = f
                uel[e] = u
                if fr >= 0:
                    F[fr] += f
                F[bk] -= f
            for j in range(nb):
                a_new = F[j] / m[j]
                if k > 0:
                    v[j] += 0.5 * (a[j] + a_new) * dt
                a[j] = a_new
        out_x[k] = x
        out_v[k] = v
        out_a[k] = a
        out_u[k] = uel
        out_f[k] = fel
        out_up[k] = up
        n_out = k + 1
        if stop and k > 0:
            over = True
            for e in range(ne):
                fr = el_front[e]
                rate = v[el_back[e]] - (v[fr] if fr >= 0 else 0.0)
                if fel[e] > f_stop or rate > v_stop:
                    over = False
                    break
            if over:
                break
    return out_x, out_v, out_a, out_u, out_f, out_up, n_out


def _pack_models(models: list[Any], ranges: list[tuple[float, float]]) -> tuple[np.ndarray, ...]:
    """Kernel arrays of several 1-input LPR models, zero-padded to a common term count, and
    their output ranges (models, 2)."""
    arrays = [mdl.kernel_arrays() for mdl in models]
    T = max(a[0].shape[0] for a in arrays)
    E = np.zeros((len(arrays), T, 1), dtype=np.int64)
    C = np.zeros((len(arrays), T))
    LO = np.zeros((len(arrays), 1))
    UP = np.zeros((len(arrays), 1))
    MODE = np.zeros(len(arrays), dtype=np.int64)
    for i, (e, c, lo, up, mode) in enumerate(arrays):
        if e.shape[1] != 1:
            raise ValueError(f"surrogate element model {i} has {e.shape[1]} inputs, expected 1")
        E[i, : e.shape[0]] = e
        C[i, : c.size] = c
        LO[i], UP[i], MODE[i] = lo, up, mode
    return E, C, LO, UP, MODE, np.array(ranges, dtype=np.float64).reshape(len(arrays), 2)


@dataclass
class _System:
    """Kernel arrays of the surrogate model of one scenario (paper eq. 4)."""

    m: np.ndarray  # body masses: cars front to back, then the obstacle if any, kg
    mu: np.ndarray
    v0: np.ndarray  # initial velocities, m/s
    body_names: list[str]
    zone_names: list[str]
    elements: np.ndarray  # (elements, 3): front body (−1 = wall), back body, type
    types: tuple[np.ndarray, np.ndarray]  # int and float table of _surrogate_kernel
    lpr: tuple[np.ndarray, ...]


def _surrogate_system(sc: CrashScenario, surrogate: CrashSurrogate) -> _System:
    """Bodies, elements and packed LPR models of ``surrogate`` on scenario ``sc``."""
    for key in ("wall", "interface"):
        if key not in surrogate.elements and (key == "wall" or sc.n_cars > 1):
            raise ValueError(f"surrogate has no {key!r} element")
    masses = list(sc.car_masses)
    mu = [sc.friction] * sc.n_cars
    v0 = [sc.speed] * sc.n_cars
    names = ["lead"] + [f"car{k + 1}" for k in range(1, sc.n_cars)]
    wall_front = -1
    if sc.obstacle is not None:
        masses.append(sc.obstacle.mass)
        mu.append(sc.obstacle.friction)
        v0.append(0.0)
        names.append("obstacle")
        wall_front = sc.n_cars
    el_front = np.array([wall_front] + list(range(sc.n_cars - 1)), dtype=np.int64)
    el_back = np.arange(sc.n_cars, dtype=np.int64)
    el_type = np.array([0] + [1] * (sc.n_cars - 1), dtype=np.int64)
    el_names = ["wall"] + [f"interface_{k}" for k in range(1, sc.n_cars)]
    types = [surrogate.elements["wall"], surrogate.elements.get("interface")]
    types = [ty for ty in types if ty is not None]
    models, ranges, load_idx, unload_idx = [], [], [], []
    for ty in types:
        load_idx.append(len(models))
        models.append(ty.loading)
        ranges.append(ty.force_range["loading"])
        unload_idx.append(len(models) if ty.unloading is not None else load_idx[-1])
        if ty.unloading is not None:
            models.append(ty.unloading)
            ranges.append(ty.force_range["unloading"])
    absorber = [sc.wall.absorber_stroke, sc.interface.absorber_stroke]
    type_arrays = (
        np.array([[VARIANTS.index(ty.variant), i, j, ty.unilateral]
                  for ty, i, j in zip(types, load_idx, unload_idx, strict=True)], np.int64),
        np.array([[ty.unloading_stiffness, ty.tension_stiffness, ty.slack, s]
                  for ty, s in zip(types, absorber[: len(types)], strict=True)]),
    )  # fmt: skip
    return _System(
        m=np.array(masses),
        mu=np.array(mu),
        v0=np.array(v0),
        body_names=names,
        zone_names=el_names,
        elements=np.stack([el_front, el_back, el_type], axis=1),
        types=type_arrays,
        lpr=_pack_models(models, ranges),
    )


def simulate_surrogate(
    scenario: CrashScenario | str,
    surrogate: CrashSurrogate,
    n_cars: int | None = None,
    speed: float | None = None,
    duration: float = 2.0,
    sample_dt: float = 1e-3,
    dt: float = 5e-4,
    stop_when_over: bool = True,
    v_stop: float = 0.01,
    f_stop: float = 1e3,
) -> CrashResult:
    """Run the surrogate crash model (paper eq. 4): one mass per car (+ obstacle).

    Parameters
    ----------
    scenario : a :class:`CrashScenario` or a name/path for :func:`load_scenario`.
    surrogate : elements from :func:`build_crash_surrogate`.
    n_cars, speed : optional overrides (number of cars; initial speed in m/s).
    duration, sample_dt : longest simulated time and output interval, s.
    dt : largest integration step, s (rounded down to divide ``sample_dt``). The default
        5e-4 s is ``ω dt ≈ 0.07`` for the paper scenario's stiffest surrogate mode
        (``ω² ≈ 2 (k̂_u,wall + k̂_u,interface) / m_1``, ω ≈ 140 rad/s); 2.5e-4 s changes the
        eq. 9 errors by < 2 %.
    stop_when_over, v_stop, f_stop : stop as :func:`simulate_reference` does.

    Returns
    -------
    :class:`CrashResult` with ``crush``/``force`` holding each element's feature ``u`` and force
    and ``permanent_set`` its permanent set in ``u``; ``energy`` is empty.
    """
    sc = load_scenario(scenario) if isinstance(scenario, str | Path) else scenario
    sc = sc.with_overrides(n_cars=n_cars, speed=speed)
    _check_run(duration, sample_dt)
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive finite number (s), got {dt!r}")
    dt, n_sub = _steps(sample_dt, dt)
    sy = _surrogate_system(sc, surrogate)
    n_samples = int(round(duration / sample_dt)) + 1
    t0 = time.perf_counter()
    xo, vo, ao, uo, fo, upo, n = _surrogate_kernel(
        sy.m, sy.mu, sy.v0, sc.gravity, V_EPS, sy.elements, sy.types, sy.lpr,
        dt, n_sub, n_samples, stop_when_over, v_stop, f_stop,
    )  # fmt: skip
    wall = time.perf_counter() - t0
    return CrashResult(
        t=np.arange(n) * sample_dt,
        x=xo[:n],
        v=vo[:n],
        a=ao[:n],
        body_names=sy.body_names,
        zone_names=sy.zone_names,
        crush=uo[:n],
        force=fo[:n],
        permanent_set=upo[:n],
        energy={},
        initial_kinetic_energy=float(0.5 * np.sum(sy.m * sy.v0**2)),
        dt=dt,
        wall_time=wall,
        scenario=sc,
        model=f"surrogate:{surrogate.variant}",
    )


def crash_errors(prediction: CrashResult, truth: CrashResult) -> dict[str, np.ndarray]:
    """Paper eq. (9) average absolute errors per car over the common samples.

    Returns ``{"x": (cars,) m, "v": (cars,) m/s, "a": (cars,) m/s²}``.
    """
    if not np.isclose(prediction.t[1] - prediction.t[0], truth.t[1] - truth.t[0]):
        raise ValueError("prediction and truth must share the sample interval")
    n = min(prediction.t.size, truth.t.size)
    cars = truth.scenario.n_cars
    if prediction.scenario.n_cars != cars:
        raise ValueError("prediction and truth have different numbers of cars")
    out = {}
    for key in ("x", "v", "a"):
        diff = getattr(prediction, key)[:n, :cars] - getattr(truth, key)[:n, :cars]
        out[key] = np.mean(np.abs(diff), axis=0)
    return out


# ======================================================== batch stepping (gymnasium envs)
#: models of :func:`crash_batch_model`
BATCH_BACKENDS = ("reference", "surrogate")


class BatchOutputs(NamedTuple):
    """What the batch kernels report after each call, one row per simulation.

    Attributes
    ----------
    x, v, a : (n, bodies) centre-of-mass displacement (m), velocity (m/s) and acceleration
        (m/s²) of each body (cars front to back, then the obstacle if any).
    crush : (n, zones) crush of each zone (surrogate: element feature ``u``), m.
    force : (n, zones) zone force, compression positive (coupler damping included), N.
    rate : (n, zones) closing rate of each zone, m/s.
    work : (n, zones) net work done on each zone since the start, J.
    dissipated : (n, 2) friction work and carbody/coupler damping work since the start, J.
    stored : (n,) kinetic energy plus elastic carbody energy, J.
    """

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    crush: np.ndarray
    force: np.ndarray
    rate: np.ndarray
    work: np.ndarray
    dissipated: np.ndarray
    stored: np.ndarray


@njit(cache=True)
def _healthy(x, v, a, limit):  # fmt: skip
    """True if every entry is finite and |x|, |v| ≤ ``limit``."""
    for j in range(x.shape[0]):
        if not (abs(x[j]) <= limit and abs(v[j]) <= limit and math.isfinite(a[j])):
            return False
    return True


@njit(cache=True)
def reference_batch_step(state, out, params, scale, active, init, dt, n_sub, limit, div):
    """Advance every ``active`` reference simulation by ``n_sub`` velocity-Verlet steps.

    Parameters
    ----------
    state : (x, v, a, dp, fz, fd, ff) node and zone arrays from
        :meth:`CrashBatchModel.new_state`, updated in place.
    out : :class:`BatchOutputs`; ``crush``, ``work`` and ``dissipated`` are also read back.
    params : static arrays of :attr:`CrashBatchModel.params`.
    scale : (n, zones) absorber force scale of each zone (:func:`absorber_zone_force`).
    active : (n,) which simulations to advance.
    init : evaluate the forces at the current state instead of stepping (after a reset).
    dt, n_sub : integration step (s) and number of steps.
    limit : a simulation whose |x| (m) or |v| (m/s) exceeds ``limit`` or that becomes
        non-finite keeps its state from before the call and gets ``div[i] = True``.
    """
    x, v, a, dp, fz, fd, ff = state
    (m, mu, g, veps, link_k, link_c, elem_zone, zone_type, zone_cc, zone_front, zone_back,
     t_s, t_f, t_n, t_amp, t_lam, t_ku, t_kt, t_slack, t_abs, body_start,
     body_end) = params  # fmt: skip
    N = m.shape[0]
    nz = zone_type.shape[0]
    nodes = np.empty((8, N))
    xl, vl, al, vp, F, dx, ffl, ff_o = (nodes[0], nodes[1], nodes[2], nodes[3], nodes[4],
                                        nodes[5], nodes[6], nodes[7])  # fmt: skip
    zones = np.empty((7, nz))
    dpl, fzl, fz_o, fzel, dzl, dz_o, wzl = (zones[0], zones[1], zones[2], zones[3], zones[4],
                                            zones[5], zones[6])  # fmt: skip
    fdl, fd_o = np.empty(fd.shape[1]), np.empty(fd.shape[1])
    for i in range(x.shape[0]):
        if not active[i]:
            continue
        xl[:], vl[:], al[:], dpl[:], fzl[:] = x[i], v[i], a[i], dp[i], fz[i]
        fdl[:], ffl[:], dzl[:], wzl[:] = fd[i], ff[i], out.crush[i], out.work[i]
        w_fric, w_damp = out.dissipated[i, 0], out.dissipated[i, 1]
        sc = scale[i]
        if init:
            _chain_forces(xl, vl, dpl, m, mu, g, veps, link_k, link_c, elem_zone, zone_type,
                          zone_cc, zone_front, zone_back, t_s, t_f, t_n, t_amp, t_lam, t_ku,
                          t_kt, t_slack, t_abs, sc, F, fzl, fzel, fdl, ffl, dzl)  # fmt: skip
            for j in range(N):
                al[j] = F[j] / m[j]
        for _ in range(0 if init else n_sub):
            fz_o[:], fd_o[:], ff_o[:], dz_o[:] = fzl, fdl, ffl, dzl
            for j in range(N):
                dx[j] = vl[j] * dt + 0.5 * al[j] * dt * dt
                xl[j] += dx[j]
                vp[j] = vl[j] + al[j] * dt
            _chain_forces(xl, vp, dpl, m, mu, g, veps, link_k, link_c, elem_zone, zone_type,
                          zone_cc, zone_front, zone_back, t_s, t_f, t_n, t_amp, t_lam, t_ku,
                          t_kt, t_slack, t_abs, sc, F, fzl, fzel, fdl, ffl, dzl)  # fmt: skip
            for j in range(N):
                a_new = F[j] / m[j]
                vl[j] += 0.5 * (al[j] + a_new) * dt
                al[j] = a_new
            for z in range(nz):
                wzl[z] += 0.5 * (fz_o[z] + fzl[z]) * (dzl[z] - dz_o[z])
            for e in range(N - 1):
                w_damp += 0.5 * (fd_o[e] + fdl[e]) * (dx[e + 1] - dx[e])
            for j in range(N):
                w_fric += 0.5 * (ff_o[j] + ffl[j]) * dx[j]
        if not _healthy(xl, vl, al, limit):
            div[i] = True
            continue
        x[i], v[i], a[i], dp[i], fz[i], fd[i], ff[i] = xl, vl, al, dpl, fzl, fdl, ffl
        out.crush[i], out.work[i] = dzl, wzl
        out.dissipated[i, 0], out.dissipated[i, 1] = w_fric, w_damp
        energy = 0.0
        for j in range(N):
            energy += 0.5 * m[j] * vl[j] * vl[j]
            if j < N - 1 and elem_zone[j] < 0:
                energy += 0.5 * link_k[j] * (xl[j + 1] - xl[j]) ** 2
        out.stored[i] = energy
        for z in range(nz):
            fr, bk = zone_front[z], zone_back[z]
            out.force[i, z] = fzl[z] + (fdl[bk - 1] if fr >= 0 else 0.0)
            out.rate[i, z] = vl[bk] - (vl[fr] if fr >= 0 else 0.0)
        for b in range(body_start.shape[0]):
            mb = sx = sv = sf = 0.0
            for j in range(body_start[b], body_end[b]):
                mb += m[j]
                sx += m[j] * xl[j]
                sv += m[j] * vl[j]
                sf += F[j]
            out.x[i, b], out.v[i, b], out.a[i, b] = sx / mb, sv / mb, sf / mb


@njit(cache=True)
def surrogate_batch_step(state, out, params, scale, active, init, dt, n_sub, limit, div):
    """:func:`reference_batch_step` for the surrogate model (paper eq. 4).

    ``state`` = (x, v, a, up, fel, ff) per body and element; ``params`` = (m, mu, g, v_ε,
    elements, types, lpr) as in :func:`_surrogate_kernel`. No dampers: ``dissipated[:, 1]``
    stays 0.
    """
    x, v, a, up, fel, ff = state
    m, mu, g, veps, elements, types, lpr = params
    el_front, el_back, el_type = elements[:, 0], elements[:, 1], elements[:, 2]
    variant, i_load, i_unload, unilateral = types[0].T
    ku, kt, slack, absorber = types[1].T
    E, C, LO, UP, MODE, FR = lpr
    N = m.shape[0]
    ne = el_front.shape[0]
    nodes = np.empty((8, N))
    xl, vl, al, vp, F, dx, ffl, ff_o = (nodes[0], nodes[1], nodes[2], nodes[3], nodes[4],
                                        nodes[5], nodes[6], nodes[7])  # fmt: skip
    els = np.empty((6, ne))
    upl, fl, f_o, ul, u_o, wl = els[0], els[1], els[2], els[3], els[4], els[5]
    ubuf = np.zeros(1)
    work = _lpr_work(lpr)
    ox, ov, oa, crush, force, rate_out, work_done, dissipated, stored = out
    # rows are copied element by element: a row view per array and train costs two atomic
    # reference-count operations, about a quarter of the time of a step of 1024 trains
    for i in range(x.shape[0]):
        if not active[i]:
            continue
        for j in range(N):
            xl[j], vl[j], al[j], ffl[j] = x[i, j], v[i, j], a[i, j], ff[i, j]
        for e in range(ne):
            upl[e], fl[e], ul[e], wl[e] = up[i, e], fel[i, e], crush[i, e], work_done[i, e]
        w_fric = dissipated[i, 0]
        # init: forces at the current state; else n_sub velocity-Verlet steps
        for _ in range(1 if init else n_sub):
            if init:
                vp[:] = vl
            else:
                f_o[:], ff_o[:], u_o[:] = fl, ffl, ul
                for j in range(N):
                    dx[j] = vl[j] * dt + 0.5 * al[j] * dt * dt
                    xl[j] += dx[j]
                    vp[j] = vl[j] + al[j] * dt
            for j in range(N):
                ffl[j] = mu[j] * m[j] * g * math.tanh(vp[j] / veps)
                F[j] = -ffl[j]
            for e in range(ne):
                fr, bk, ty = el_front[e], el_back[e], el_type[e]
                u = xl[bk] - (xl[fr] if fr >= 0 else 0.0)
                rate = vp[bk] - (vp[fr] if fr >= 0 else 0.0)
                mdl = _element_model(u, rate, upl[e], variant[ty], unilateral[ty], ku[ty],
                                     i_load[ty], i_unload[ty])  # fmt: skip
                f_lpr = f_min = f_max = 0.0
                if mdl >= 0:
                    ubuf[0] = u
                    f_lpr = lpr_eval_into(ubuf, E[mdl], C[mdl], LO[mdl], UP[mdl], MODE[mdl],
                                          work[mdl])  # fmt: skip
                    f_min, f_max = FR[mdl, 0], FR[mdl, 1]
                s = scale[i, e] if u <= absorber[ty] else 1.0
                f, upl[e] = _element_force(u, upl[e], f_lpr, f_min, f_max, s, variant[ty],
                                           unilateral[ty], ku[ty], kt[ty], slack[ty])  # fmt: skip
                fl[e] = f
                ul[e] = u
                if fr >= 0:
                    F[fr] += f
                F[bk] -= f
            for j in range(N):
                a_new = F[j] / m[j]
                if not init:
                    vl[j] += 0.5 * (al[j] + a_new) * dt
                    w_fric += 0.5 * (ff_o[j] + ffl[j]) * dx[j]
                al[j] = a_new
            if not init:
                for e in range(ne):
                    wl[e] += 0.5 * (f_o[e] + fl[e]) * (ul[e] - u_o[e])
        if not _healthy(xl, vl, al, limit):
            div[i] = True
            continue
        energy = 0.0
        for j in range(N):
            x[i, j], v[i, j], a[i, j], ff[i, j] = xl[j], vl[j], al[j], ffl[j]
            ox[i, j], ov[i, j], oa[i, j] = xl[j], vl[j], al[j]
            energy += 0.5 * m[j] * vl[j] * vl[j]
        stored[i] = energy
        dissipated[i, 0] = w_fric
        for e in range(ne):
            up[i, e], fel[i, e] = upl[e], fl[e]
            crush[i, e], force[i, e], work_done[i, e] = ul[e], fl[e], wl[e]
            fr = el_front[e]
            rate_out[i, e] = vl[el_back[e]] - (vl[fr] if fr >= 0 else 0.0)


@dataclass(frozen=True)
class CrashBatchModel:
    """A scenario's reference or surrogate model, ready for batch stepping.

    Made by :func:`crash_batch_model`. Holds no simulation state: :meth:`new_state` and
    :meth:`new_outputs` allocate the arrays of ``n`` simulations, :meth:`reset` puts one at
    first contact, :meth:`step` advances the active ones by ``sample_dt`` in one compiled call.

    Attributes
    ----------
    backend : ``"reference"`` or ``"surrogate"``.
    scenario : the simulated scenario (its ``speed`` is the nominal initial speed).
    sample_dt : time advanced by one :meth:`step`, s.
    dt, n_sub : integration step (s) and steps per :meth:`step`.
    params : static kernel arrays.
    masses : mass of each integration node (reference) or body (surrogate), kg.
    v_unit : initial velocity of each node per unit train speed (1 train, 0 obstacle).
    body_names, zone_names : as in :class:`CrashResult`.
    zone_absorber : absorber stroke of each zone, m.
    """

    backend: str
    scenario: CrashScenario
    sample_dt: float
    dt: float
    n_sub: int
    params: tuple
    masses: np.ndarray
    v_unit: np.ndarray
    body_names: list[str]
    zone_names: list[str]
    zone_absorber: np.ndarray

    def new_state(self, n: int) -> tuple[np.ndarray, ...]:
        """Zeroed kernel state of ``n`` simulations."""
        N, nz = self.masses.size, len(self.zone_names)
        node = [np.zeros((n, N)) for _ in range(3)]
        zone = [np.zeros((n, nz)) for _ in range(2)]
        damp = [np.zeros((n, max(N - 1, 1)))] if self.backend == "reference" else []
        return (*node, *zone, *damp, np.zeros((n, N)))

    def new_outputs(self, n: int) -> BatchOutputs:
        """Zeroed outputs of ``n`` simulations."""
        nb, nz = len(self.body_names), len(self.zone_names)
        return BatchOutputs(*(np.zeros((n, nb)) for _ in range(3)),
                            *(np.zeros((n, nz)) for _ in range(4)),
                            np.zeros((n, 2)), np.zeros(n))  # fmt: skip

    def reset(self, state: tuple, out: BatchOutputs, i: int, speed: float) -> None:
        """Simulation ``i`` at first contact, the train at ``speed`` (m/s); call :meth:`step`
        with ``init=True`` afterwards to evaluate its forces."""
        for arr in (*state, *out):
            arr[i] = 0.0
        state[1][i] = self.v_unit * speed

    def step(
        self,
        state: tuple,
        out: BatchOutputs,
        scale: np.ndarray,
        active: np.ndarray,
        div: np.ndarray,
        init: bool = False,
        limit: float = 1e3,
    ) -> None:
        """Advance the ``active`` simulations by ``sample_dt`` (:func:`reference_batch_step`)."""
        kernel = reference_batch_step if self.backend == "reference" else surrogate_batch_step
        kernel(state, out, self.params, scale, active, init, self.dt, self.n_sub, limit, div)


def crash_batch_model(
    scenario: CrashScenario | str,
    backend: str = "reference",
    sample_dt: float = 1e-3,
    surrogate: CrashSurrogate | None = None,
    safety: float = 0.2,
    dt: float = 5e-4,
) -> CrashBatchModel:
    """Batch-steppable model of a scenario.

    Parameters
    ----------
    scenario : a :class:`CrashScenario` or a name/path for :func:`load_scenario`.
    backend : ``"reference"`` (lumped-mass chain, :func:`simulate_reference`) or
        ``"surrogate"`` (paper eq. 4, :func:`simulate_surrogate`; needs ``surrogate``).
    sample_dt : time advanced per :meth:`CrashBatchModel.step`, s.
    safety : reference time-step safety factor; dt : largest surrogate step, s (both as in
        the ``simulate_*`` functions, which the batch kernels reproduce step for step).
    """
    sc = load_scenario(scenario) if isinstance(scenario, str | Path) else scenario
    if backend not in BATCH_BACKENDS:
        raise ValueError(f"backend must be one of {BATCH_BACKENDS}, got {backend!r}")
    _check_run(sample_dt, sample_dt)
    if backend == "reference":
        if not 0 < safety <= 1:
            raise ValueError(f"safety must be in (0, 1], got {safety!r}")
        ch = _build_chain(sc)
        step, n_sub = _steps(sample_dt, safety * 2.0 / ch.omega_max)
        params = (ch.m, ch.mu, sc.gravity, V_EPS, ch.link_k, ch.link_c, ch.elem_zone,
                  ch.zone_type, ch.zone_cc, ch.zone_front, ch.zone_back, ch.t_s, ch.t_f, ch.t_n,
                  ch.t_amp, ch.t_lam, ch.t_ku, ch.t_kt, ch.t_slack, ch.t_abs, ch.body_start,
                  ch.body_end)  # fmt: skip
        return CrashBatchModel(
            backend=backend, scenario=sc, sample_dt=float(sample_dt), dt=step, n_sub=n_sub,
            params=params, masses=ch.m, v_unit=ch.v0 / sc.speed, body_names=ch.body_names,
            zone_names=ch.zone_names, zone_absorber=ch.t_abs[ch.zone_type],
        )  # fmt: skip
    if surrogate is None:
        raise ValueError("surrogate is required for backend='surrogate'")
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive finite number (s), got {dt!r}")
    sy = _surrogate_system(sc, surrogate)
    step, n_sub = _steps(sample_dt, dt)
    return CrashBatchModel(
        backend=backend, scenario=sc, sample_dt=float(sample_dt), dt=step, n_sub=n_sub,
        params=(sy.m, sy.mu, sc.gravity, V_EPS, sy.elements, sy.types, sy.lpr), masses=sy.m,
        v_unit=sy.v0 / sc.speed, body_names=sy.body_names, zone_names=sy.zone_names,
        zone_absorber=sy.types[1][sy.elements[:, 2], 3],
    )  # fmt: skip
