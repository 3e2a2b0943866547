"""Crash scenarios: validated parameters of a train running into a wall or an obstacle.

Everything is SI inside (m, s, kg, N); the scenario files in ``railgym/configs/crash/*.yaml``
use mm, kN, t and km/h and are converted once by :func:`load_scenario`.

Sign convention
---------------
``x`` points in the direction of travel, towards the barrier; every displacement is measured
from the position at first contact (t = 0). A crush zone's crush ``δ`` and force ``f`` are
positive in compression. For the wall zone (the lead car's front end) ``δ = x_front``; for the
zone between car k and car k+1 ``δ = x_front(k+1) − x_rear(k)``. The lead car obeys
``m_1 ẍ_1 = −f_wall + f_12 − friction`` and car 2 ``m_2 ẍ_2 = −f_12 − friction``. The paper's
eq. (4) uses the opposite interface argument ``x_1 − x_2`` (negative in compression), i.e.
``G_2(x_1 − x_2) = −f_12(x_2 − x_1)``; its ``G_1(x_1)`` is our ``f_wall(x_1)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from railgym import _checks as val
from railgym.vehicles.crash.criteria import CriteriaLimits
from railgym.vehicles.crash.zone import envelope_force

__all__ = [
    "LIMITS",
    "MAX_SPEED",
    "CarSpec",
    "Coupler",
    "CrashScenario",
    "CrushZone",
    "Envelope",
    "Obstacle",
    "load_scenario",
    "parse_scenario",
    "scenario_names",
]

#: scenario names packaged in railgym/configs/crash
_CONFIG_DIR = ("configs", "crash")
_MAX_BASE_DEPTH = 8
#: documented physical limits of the scenario fields, inclusive, in the file's units (a field
#: outside them is an error naming it: it would overflow in the conversion to SI, or shrink the
#: reference model's stable time step until an episode takes minutes)
LIMITS: dict[str, tuple[float, float]] = {
    "speed_kmh": (1.0, 500.0),
    "friction": (0.0, 1.0),
    "gravity": (1.0, 100.0),
    "n_cars": (1, 50),
    "mass_t": (1.0, 1000.0),
    "face_mass_t": (0.1, 1000.0),
    "length_m": (1.0, 100.0),
    "cab_length_m": (0.0, 100.0),
    "n_nodes": (2, 100),
    "EA_MN": (1.0, 1e6),
    "stroke_mm": (0.01, 1e5),
    "force_kN": (0.01, 1e5),
    "absorber_stroke_mm": (0.01, 1e5),
    "unloading_stiffness_kN_per_mm": (1e-3, 1e5),
    "fold_wavelength_mm": (1.0, 1e4),
    "slack_mm": (0.0, 1e3),
    "stiffness_kN_per_mm": (1e-3, 1e5),
    "payload_t": (0.0, 1000.0),
    "mean_decel_g": (0.0, 1e3),
    "peak_decel_g": (0.0, 1e3),
    "moving_average_g": (0.0, 1e3),
    "intrusion_mm": (0.0, 1e5),
}
#: largest initial speed override, m/s (``speed_kmh``'s limit)
MAX_SPEED = LIMITS["speed_kmh"][1] / 3.6


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
            [envelope_force(x, s, f, s.size, self.fold_amplitude, self.fold_wavelength) for x in d]
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
class Envelope:
    """Impact envelope: what each ``reset`` of the env draws, uniformly, from its ``np_random``.

    Attributes
    ----------
    speed : (low, high) initial speed, m/s (low = high: fixed).
    payload_lead, payload_passenger : (low, high) mass added to the lead car and, drawn
        separately, to each passenger car, kg.
    """

    speed: tuple[float, float]
    payload_lead: tuple[float, float] = (0.0, 0.0)
    payload_passenger: tuple[float, float] = (0.0, 0.0)

    def payload_ranges(self, n_cars: int) -> np.ndarray:
        """(cars, 2) payload range of each car, kg."""
        return np.array([self.payload_lead] + [self.payload_passenger] * (n_cars - 1))


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
    envelope : the impact envelope the env draws from (``None``: every episode at ``speed``).
    criteria : acceptance limits of the crash criteria
        (:class:`~railgym.vehicles.crash.criteria.CriteriaLimits`).
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
    envelope: Envelope | None = None
    criteria: CriteriaLimits = CriteriaLimits()

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
            out = replace(out, n_cars=val.integer(n_cars, "n_cars", *LIMITS["n_cars"]))
        if speed is not None:
            speed = val.in_range(speed, "speed (m/s)", 0.0, MAX_SPEED, lo_open=True)
            out = replace(out, speed=speed)
        return out


class _Fields(val.Fields):
    """:class:`railgym._checks.Fields` of one scenario mapping: unknown keys rejected up
    front, numbers checked against the documented :data:`LIMITS` in the file's units, i.e.
    before any unit conversion."""

    def __init__(self, data: Any, path: str, known: tuple[str, ...]) -> None:
        super().__init__(data, path)
        unknown = sorted(set(map(str, self.data)) - set(known))
        if unknown:
            raise val.FieldError(
                self.field(unknown[0]), f"is not a known field (known: {list(known)})"
            )

    def has(self, key: str) -> bool:
        return self.data.get(key) is not None

    def name(self, key: str) -> str:
        return self.field(key)

    def number(
        self,
        key: str,
        default: float | None = None,
        positive: bool = True,
        upper: float | None = None,
    ) -> float:
        value = self.get(key, None)
        value = default if value is None else value
        if value is None:
            raise val.FieldError(self.field(key), "is missing")
        return self._checked(key, value, self.field(key), positive, upper)

    def _checked(
        self, key: str, value: Any, label: str, positive: bool = True, upper: float | None = None
    ) -> float:
        """``value`` as a finite float, positive (or non-negative), below ``upper`` and within
        the :data:`LIMITS` of ``key``; errors name ``label``."""
        out = val.real(value, label)
        if positive and out <= 0:
            raise val.FieldError(label, f"must be positive, got {value!r}")
        if not positive and out < 0:
            raise val.FieldError(label, f"must be non-negative, got {value!r}")
        if upper is not None and out >= upper:
            raise val.FieldError(label, f"must be below {upper}, got {value!r}")
        if key in LIMITS:
            lo, hi = LIMITS[key]
            if not lo <= out <= hi:
                raise val.FieldError(
                    label, f"must be in [{lo:g}, {hi:g}] (documented limits), got {value!r}"
                )
        return out

    def integer(self, key: str, default: int | None = None, lower: int = 1) -> int:
        value = self.get(key, default)
        if isinstance(value, np.ndarray) and value.ndim == 0:
            value = value[()]
        ok = isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)
        if not ok or value < lower:
            raise val.FieldTypeError(
                self.field(key), f"must be an integer ≥ {lower}, got {value!r}"
            )
        return int(self._checked(key, value, self.field(key)))

    def text(self, key: str, default: str | None = None) -> str:  # type: ignore[override]
        value = self.get(key, default)
        if not isinstance(value, str):
            raise val.FieldTypeError(self.field(key), f"must be a string, got {value!r}")
        return value.strip()

    def array(self, key: str) -> np.ndarray:
        value = self.get(key, None)
        if not isinstance(value, list) or not value:
            raise val.FieldError(self.field(key), "must be a non-empty list of numbers")
        label = self.field(key)
        return np.array([self._checked(key, v, f"{label}[{i}]") for i, v in enumerate(value)])

    def range(
        self, key: str, default: Any = None, limits: str | None = None
    ) -> tuple[float, float] | None:
        """A ``[low, high]`` pair (or one number: ``low = high``) within the :data:`LIMITS` of
        ``limits`` (default ``key``), low ≤ high; ``None`` if absent."""
        value = self.get(key, None)
        value = default if value is None else value
        if value is None:
            return None
        label = self.field(key)
        items = value if isinstance(value, list) else [value]
        if len(items) not in (1, 2):
            raise val.FieldError(label, f"must be a number or [low, high], got {value!r}")
        lim = limits or key
        lo, hi = (
            self._checked(lim, v, f"{label}[{i}]" if len(items) == 2 else label, False)
            for i, v in enumerate(items * (3 - len(items)))
        )
        if lo > hi:
            raise val.FieldError(label, f"must be [low, high] with low ≤ high, got {value!r}")
        return lo, hi

    def sub(self, key: str, known: tuple[str, ...]) -> _Fields:
        if key not in self.data:
            raise val.FieldError(self.field(key), "is missing")
        return _Fields(self.get(key), self.field(key), known)


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
    """Raw ``crash`` mapping of a packaged scenario name or a YAML path
    (:func:`railgym._checks.resolve_yaml`) and the file's folder (``None`` if packaged)."""
    text, source = val.resolve_yaml(name_or_path, "crash scenario", "railgym", _CONFIG_DIR)
    doc = val.load_yaml(text, source)
    if not isinstance(doc, dict) or not isinstance(doc.get("crash"), dict):
        raise val.FieldError(source, "must hold a mapping under the key 'crash'", full=False)
    packaged = not str(name_or_path).endswith(val.YAML_SUFFIXES)
    return doc["crash"], None if packaged else Path(source).parent


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
        raise val.FieldTypeError("crash.base", f"must be a scenario name or path, got {base!r}")
    if folder is not None and (folder / base).is_file():
        base = str(folder / base)
    merged = _deep_merge(_resolve(base, depth + 1), raw)
    merged.pop("base")
    return merged


def scenario_names() -> list[str]:
    """Names of the packaged crash scenarios."""
    folder = resources.files("railgym").joinpath(*_CONFIG_DIR)
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
    top = (
        "base",
        "name",
        "description",
        "sources",
        "speed_kmh",
        "friction",
        "gravity",
        "n_cars",
        "barrier",
        "cars",
        "zones",
        "envelope",
        "criteria",
    )
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
        envelope=_parse_envelope(r) if r.has("envelope") else None,
        criteria=_parse_criteria(r) if r.has("criteria") else CriteriaLimits(),
    )


def _parse_envelope(r: _Fields) -> Envelope:
    """``crash.envelope``: ``speed_kmh`` (a number or [low, high], default the scenario's
    speed) and ``payload_t`` (``lead`` and ``passenger``, each a number or [low, high], t)."""
    e = r.sub("envelope", ("speed_kmh", "payload_t"))
    speed = e.range("speed_kmh", r.get("speed_kmh"))
    if speed is None:
        raise val.FieldError(e.field("speed_kmh"), "is missing")
    if speed[0] < LIMITS["speed_kmh"][0]:
        raise val.FieldError(e.field("speed_kmh"), f"must be at least 1 km/h, got {speed[0]!r}")
    lead = passenger = (0.0, 0.0)
    if e.has("payload_t"):
        p = e.sub("payload_t", ("lead", "passenger"))
        lead = p.range("lead", 0.0, "payload_t")
        passenger = p.range("passenger", 0.0, "payload_t")
    return Envelope(
        speed=(speed[0] / 3.6, speed[1] / 3.6),
        payload_lead=(lead[0] * 1e3, lead[1] * 1e3),
        payload_passenger=(passenger[0] * 1e3, passenger[1] * 1e3),
    )


def _parse_criteria(r: _Fields) -> CriteriaLimits:
    """``crash.criteria``: limits ``mean_decel_g``, ``peak_decel_g``, ``moving_average_g`` (g)
    and ``intrusion_mm``; an absent limit keeps its :class:`CriteriaLimits` default."""
    c = r.sub("criteria", ("mean_decel_g", "peak_decel_g", "moving_average_g", "intrusion_mm"))
    d = CriteriaLimits()
    keys = ("mean_decel_g", "peak_decel_g", "moving_average_g")
    g = {k: c.number(k, positive=False) if c.has(k) else getattr(d, k) for k in keys}
    intr = (
        c.number("intrusion_mm", positive=False) * 1e-3 if c.has("intrusion_mm") else d.intrusion_m
    )
    return CriteriaLimits(intrusion_m=intr, **g)
