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
from importlib.resources import files
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from railgym.vehicles.crash.zone import _envelope

__all__ = [
    "LIMITS",
    "MAX_SPEED",
    "CarSpec",
    "Coupler",
    "CrashScenario",
    "CrushZone",
    "Obstacle",
    "check_int",
    "check_real",
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
}
#: largest initial speed override, m/s (``speed_kmh``'s limit)
MAX_SPEED = LIMITS["speed_kmh"][1] / 3.6


def check_real(
    name: str,
    value: Any,
    low: float | None = None,
    high: float | None = None,
    *,
    low_open: bool = False,
    high_open: bool = False,
) -> float:
    """``value`` as a float if it is a real number (Python or numpy, not a bool) within
    ``[low, high]`` (bounds ``None`` = unbounded; ``*_open`` excludes the bound); else
    ``ValueError`` naming ``name``."""
    if isinstance(value, bool | np.bool_) or not isinstance(
        value, int | float | np.integer | np.floating
    ):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise ValueError(f"{name} must be finite, got {value!r}")
    below = low is not None and (out <= low if low_open else out < low)
    above = high is not None and (out >= high if high_open else out > high)
    if below or above:
        lo = "unbounded" if low is None else ("(" if low_open else "[") + f"{low:g}"
        hi = "unbounded" if high is None else f"{high:g}" + (")" if high_open else "]")
        raise ValueError(f"{name} must be in {lo}, {hi}, got {value!r}")
    return out


def check_int(name: str, value: Any, low: int, high: int) -> int:
    """``value`` as an int if it is an integer (Python or numpy, not a bool) in [low, high];
    else ``ValueError`` naming ``name``."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if not low <= value <= high:
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {value!r}")
    return int(value)


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
            out = replace(out, n_cars=check_int("n_cars", n_cars, *LIMITS["n_cars"]))
        if speed is not None:
            speed = check_real("speed (m/s)", speed, 0.0, MAX_SPEED, low_open=True)
            out = replace(out, speed=speed)
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
        if isinstance(value, bool | np.bool_) or not isinstance(value, int | float | np.number):
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
        return self._within(key, value)

    def _within(self, key: str, value: float, label: str | None = None) -> float:
        """``value`` if within the documented :data:`LIMITS` of ``key`` (before any unit
        conversion)."""
        if key in LIMITS:
            lo, hi = LIMITS[key]
            if not lo <= value <= hi:
                raise ValueError(
                    f"{label or self.name(key)} must be in [{lo:g}, {hi:g}] (documented "
                    f"limits), got {value!r}"
                )
        return value

    def integer(self, key: str, default: int | None = None, lower: int = 1) -> int:
        value = self.data.get(key, default)
        ok = isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)
        if not ok or value < lower:
            raise ValueError(f"{self.name(key)} must be an integer ≥ {lower}, got {value!r}")
        return int(self._within(key, value))

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
            if isinstance(item, bool | np.bool_) or not isinstance(item, int | float | np.number):
                raise ValueError(f"{self.name(key)}[{i}] must be a number, got {item!r}")
            if not math.isfinite(item):
                raise ValueError(f"{self.name(key)}[{i}] must be finite, got {item!r}")
            if item <= 0:
                raise ValueError(f"{self.name(key)}[{i}] must be positive, got {item!r}")
            out[i] = self._within(key, float(item), f"{self.name(key)}[{i}]")
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
    )
