"""Vertical vehicle parameters: validated dataclasses, the kernel parameter tuple, YAML loading.

:class:`VerticalVehicle` holds one bogie and its carbody share with the element sections of
``configs/vehicles/*.yaml``; :meth:`VerticalVehicle.kernel_params` turns it into the
:class:`SuspensionParams` NamedTuple that the compiled kernels read by field name. Every value
is checked by :mod:`railgym._checks`, and errors name the field path (``damper.c_rebound``)
and, when loaded from a file, the file.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from railgym import _checks as val
from surrogates.memory import KNOWN_PHYSICS

__all__ = [
    "P_C1",
    "P_C2",
    "P_K1",
    "P_K2",
    "P_M1",
    "P_M2",
    "AirSpring",
    "BumpStop",
    "Damper",
    "SUSPENSION_DTYPE",
    "StaticSpring",
    "SuspensionParams",
    "VerticalVehicle",
    "linear_model",
    "load_vehicle",
    "vehicle_from_dict",
]


class SuspensionParams(NamedTuple):
    """Parameters of the compiled vertical kernels, SI (one float per field).

    Built by :meth:`VerticalVehicle.kernel_params`; the ``P_*`` constants
    of this module are the field positions, for code that indexes it.
    """

    m1: float  #: bogie frame, kg
    m2: float  #: carbody share, kg
    k1: float  #: primary stiffness, N/m
    c1: float  #: primary damping, N·s/m
    k2: float  #: linear secondary stiffness, N/m
    c2: float  #: linear secondary damping, N·s/m
    free_c: float  #: bump-stop free travel in compression, m
    free_r: float  #: rebound-stop free travel, m
    k_bs: float  #: bump-stop ramp stiffness, N/m
    k_bs3: float  #: bump-stop cubic stiffness, N/m³
    bs_smooth: float  #: bump-stop onset length, m
    progression: float  #: static spring progression, 1/m²
    c_c: float  #: damper slope in compression, N·s/m
    c_r: float  #: damper slope in rebound, N·s/m
    vk_c: float  #: damper knee velocity in compression, m/s
    vk_r: float  #: damper knee velocity in rebound, m/s
    blowoff: float  #: slope ratio past the knee
    knee: float  #: knee smoothing, m/s
    k_series: float  #: damper series (bush/oil) stiffness, N/m
    n_springs: float  #: number of air springs
    area: float  #: effective area at static height, m²
    d_area: float  #: effective area gradient, m²/m
    v_bag: float  #: bag volume, m³
    v_res: float  #: reservoir volume, m³
    p0: float  #: static absolute pressure, Pa
    p_atm: float  #: atmospheric pressure, Pa
    n_poly: float  #: polytropic index
    rho0: float  #: gas density at p0, kg/m³
    cd_area: float  #: discharge coefficient × orifice area, m²
    dp_lam: float  #: laminar pressure of the orifice law, Pa

    def record(self) -> np.ndarray:
        """The same values as a structured array (1,) of :data:`SUSPENSION_DTYPE`, the form
        the step kernels take (numba dispatches it much faster than a 30-field tuple); fields
        are read by name in compiled code (``p[0].m1``)."""
        return np.array([tuple(self)], SUSPENSION_DTYPE)


#: positions of the linear parameters in :class:`SuspensionParams` (for indexing code)
P_M1, P_M2, P_K1, P_C1, P_K2, P_C2 = (
    SuspensionParams._fields.index(f) for f in ("m1", "m2", "k1", "c1", "k2", "c2")
)


#: structured dtype of :meth:`SuspensionParams.record`, one float64 field per parameter
SUSPENSION_DTYPE = np.dtype([(name, np.float64) for name in SuspensionParams._fields])


def linear_model(params: SuspensionParams) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Linear vertical model ``ẋ = A·x + B·F_a + E·f`` and its carbody acceleration.

    States ``x = [x1, v1, x2, v2]`` (m, m/s) from the static equilibrium, input ``F_a`` (N),
    linear secondary suspension ``k2, c2``; the track force ``f = k1·z + c1·ż`` is the
    disturbance (not returned). ``params`` is :meth:`VerticalVehicle.kernel_params` (the
    whole vehicle's model is :func:`railgym.vehicles.vehicle.model.linear_state_space`).

    Returns
    -------
    A (4, 4), B (4, 1), C (4,), D
        with ``ẍ2 = C·x + D·F_a`` (m/s²).
    """
    m1, m2, k1, c1, k2, c2 = params.m1, params.m2, params.k1, params.c1, params.k2, params.c2
    a = np.array(
        [
            [0.0, 1.0, 0.0, 0.0],
            [-(k1 + k2) / m1, -(c1 + c2) / m1, k2 / m1, c2 / m1],
            [0.0, 0.0, 0.0, 1.0],
            [k2 / m2, c2 / m2, -k2 / m2, -c2 / m2],
        ]
    )
    b = np.array([[0.0], [-1.0 / m1], [0.0], [1.0 / m2]])
    return a, b, a[3].copy(), 1.0 / m2


Rule = Callable[[Any, str], float]


def _fraction(v: Any, f: str) -> float:
    return val.in_range(v, f, 0.0, 1.0, lo_open=True)


def _polytropic(v: Any, f: str) -> float:
    return val.in_range(v, f, 1.0, 5.0 / 3.0)


def _check(obj: Any, section: str, rules: dict[str, Rule]) -> None:
    """Validate every numeric field of a frozen dataclass; store the canonical float."""
    for name, rule in rules.items():
        object.__setattr__(obj, name, rule(getattr(obj, name), f"{section}.{name}"))


P, NN, R = val.positive, val.non_negative, val.real


@dataclass(frozen=True)
class BumpStop:
    """Bump and rebound stops: free travel (m), ramp stiffness (N/m), cubic (N/m³)."""

    free_travel_compression: float
    free_travel_rebound: float
    stiffness: float
    cubic_stiffness: float
    smoothing: float

    def __post_init__(self) -> None:
        _check(
            self,
            "bump_stop",
            {
                "free_travel_compression": P,
                "free_travel_rebound": P,
                "stiffness": P,
                "cubic_stiffness": NN,
                "smoothing": P,
            },
        )


@dataclass(frozen=True)
class StaticSpring:
    """Progressive spring of the static reference: ``k2·δ·(1 + progression·δ²)`` (1/m²)."""

    progression: float

    def __post_init__(self) -> None:
        _check(self, "static_spring", {"progression": NN})


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
        _check(
            self,
            "damper",
            {
                "c_compression": P,
                "c_rebound": P,
                "knee_velocity_compression": P,
                "knee_velocity_rebound": P,
                "blowoff_ratio": _fraction,
                "knee_smoothing": P,
                "series_stiffness": P,
            },
        )


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
        count = val.integer(self.count, "air_spring.count")
        if count < 1:
            raise val.FieldError("air_spring.count", f"must be positive, got {count}")
        object.__setattr__(self, "count", count)
        _check(
            self,
            "air_spring",
            {
                "effective_area": P,
                "area_gradient": R,
                "bag_volume": P,
                "reservoir_volume": P,
                "polytropic_index": _polytropic,
                "atmospheric_pressure": P,
                "gas_constant": P,
                "temperature": P,
                "orifice_diameter": P,
                "discharge_coefficient": _fraction,
                "laminar_pressure": P,
            },
        )


@dataclass(frozen=True)
class VerticalVehicle:
    """One bogie and half a carbody (SI). See ``configs/vehicles/manchester.yaml``.

    Attributes
    ----------
    m1, m2 : bogie frame and carbody share, kg.
    k1, c1 : primary suspension of the bogie (all axleboxes), N/m and N·s/m.
    k2, c2 : nominal linear secondary suspension (both sides), N/m and N·s/m (a user's
        model: its linearisation, for controller design).
    gravity : m/s², sets the air-spring static pressure.
    bump_stop, static_spring, damper, air_spring : the element sections, each ``None`` where
        the vehicle has no such part. Without ``bump_stop`` the vehicle has no bump-stop law
        (no element adds one); the nonlinear reference models need ``damper`` and
        ``static_spring`` (static) or ``air_spring`` (dynamic): :meth:`require`.
    free_travel : secondary free travel, m (both directions), for a vehicle without
        ``bump_stop`` (with one, its free travels are the travel); ``None``: not known.
    """

    name: str
    m1: float
    m2: float
    k1: float
    c1: float
    k2: float
    c2: float
    gravity: float
    bump_stop: BumpStop | None = None
    static_spring: StaticSpring | None = None
    damper: Damper | None = None
    air_spring: AirSpring | None = None
    free_travel: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise val.FieldTypeError(
                "vehicle.name", f"must be a non-empty string, got {self.name!r}"
            )
        _check(
            self,
            "vehicle",
            {
                "m1": P,
                "m2": P,
                "k1": P,
                "c1": NN,
                "k2": P,
                "c2": NN,
                "gravity": P,
            },
        )
        for name, cls in _SECTIONS.items():
            if getattr(self, name) is not None and not isinstance(getattr(self, name), cls):
                raise val.FieldTypeError(name, f"must be a {cls.__name__} or None")
        if self.free_travel is not None:
            if self.bump_stop is not None:
                raise val.FieldError(
                    "vehicle.free_travel",
                    "is for a vehicle without bump stops (the bump_stop section gives the "
                    "free travels)",
                )
            object.__setattr__(self, "free_travel", P(self.free_travel, "vehicle.free_travel"))
        air = self.air_spring
        if air is None:
            return
        travel = self.travel[0] if math.isfinite(self.travel[0]) else DEFLECTION_SCALE
        v_min = air.bag_volume - air.effective_area * travel - 0.5 * air.area_gradient * travel**2
        if v_min <= 0.2 * air.bag_volume:
            raise val.FieldError(
                "air_spring.bag_volume",
                "is too small: the bag would lose over 80 % of its "
                f"volume within the free travel of {travel} m",
            )
        if air.effective_area + air.area_gradient * travel <= 0.0:
            raise val.FieldError(
                "air_spring.area_gradient", "makes the effective area non-positive"
            )
        p0 = self.static_pressure
        if not math.isfinite(p0) or not math.isfinite(self.air_spring_stiffness()[1]):
            raise val.FieldError("air_spring", "gives a non-finite static pressure or stiffness")

    def same_physics(self, other: Any) -> bool:
        """``other`` is a :class:`VerticalVehicle` with this one's parameters and sections,
        whatever its name (two loads of one file are equal; compare these, not the kernel
        parameters, whose fields of a missing section are ``nan``)."""
        return isinstance(other, VerticalVehicle) and replace(other, name=self.name) == self

    @property
    def travel(self) -> tuple[float, float]:
        """Free travel in compression and rebound, m (``inf`` where not known)."""
        if self.bump_stop is not None:
            return self.bump_stop.free_travel_compression, self.bump_stop.free_travel_rebound
        t = math.inf if self.free_travel is None else self.free_travel
        return t, t

    @property
    def deflection_scale(self) -> float:
        """Scale of the deflection in observations and rewards, m: the free travel in
        compression, else :data:`DEFLECTION_SCALE`."""
        t = self.travel[0]
        return t if math.isfinite(t) else DEFLECTION_SCALE

    @property
    def known_physics(self) -> tuple[str, ...]:
        """The known-physics terms a default element of this vehicle adds in the kernel
        (``("bump_stop",)`` when it has bump stops, else none)."""
        return ("bump_stop",) if self.bump_stop is not None else ()

    def check_known_physics(self, known: Any = None) -> tuple[str, ...]:
        """The known-physics terms of an element of this vehicle: ``known`` (entries of
        :data:`surrogates.memory.KNOWN_PHYSICS`) checked against :attr:`known_physics`, or
        (``None``) :attr:`known_physics` itself; a term the vehicle lacks is an error."""
        if known is None:
            return self.known_physics
        known = tuple(known)
        bad = [k for k in known if k not in KNOWN_PHYSICS]
        if bad:
            raise ValueError(f"known_physics entries must be in {KNOWN_PHYSICS}, got {bad}")
        missing = [k for k in known if k not in self.known_physics]
        if missing:
            raise val.FieldError(
                "known_physics",
                f"{missing} is not part of vehicle {self.name!r} (it has "
                f"{list(self.known_physics) or 'none'}): an element cannot add a law the "
                "vehicle does not have",
            )
        return known

    def require_variant(self, variant: str) -> None:
        """:meth:`require` the sections the kernel ``variant`` reads (``"static"``: damper and
        static spring; ``"dynamic"``: damper and air spring; the others: none)."""
        need = {"static": ("damper", "static_spring"), "dynamic": ("damper", "air_spring")}
        if variant in need:
            self.require(need[variant], f"the {variant} reference model")

    def require(self, sections: tuple[str, ...], what: str) -> None:
        """:class:`~railgym._checks.FieldError` naming the first of ``sections`` this vehicle
        lacks, with ``what`` (the model that needs it) in the message."""
        for name in sections:
            if getattr(self, name) is None:
                raise val.FieldError(
                    name,
                    f"section is missing in vehicle {self.name!r}: {what} needs it (a user's "
                    "model runs as backend='fmu', or as backend='surrogate' with an element "
                    "built from it)",
                )

    @property
    def static_pressure(self) -> float:
        """Absolute air-spring pressure at static equilibrium ``p0``, Pa (``nan`` without
        an air spring)."""
        air = self.air_spring
        if air is None:
            return math.nan
        return air.atmospheric_pressure + self.m2 * self.gravity / (air.count * air.effective_area)

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

    def kernel_params(self) -> SuspensionParams:
        """The kernels' named parameters (:class:`SuspensionParams`).

        A missing section gives: no bump-stop law (zero stiffness, the free travels of
        :attr:`travel`), a linear static spring, and ``nan`` for the damper and air-spring
        fields, which only the nonlinear references read (:meth:`require` refuses them); it
        is the one ``math.nan`` object, so that the tuples of two loads of one file compare
        equal (``==`` on tuples tests identity first).
        """
        b = self.bump_stop or _NO_BUMP_STOP
        s = self.static_spring or StaticSpring(0.0)
        d = self.damper or _NO_DAMPER
        a = self.air_spring or _NO_AIR_SPRING
        free_c, free_r = self.travel
        p0 = self.static_pressure
        params = SuspensionParams(
            m1=self.m1,
            m2=self.m2,
            k1=self.k1,
            c1=self.c1,
            k2=self.k2,
            c2=self.c2,
            free_c=free_c,
            free_r=free_r,
            k_bs=b.stiffness,
            k_bs3=b.cubic_stiffness,
            bs_smooth=b.smoothing,
            progression=s.progression,
            c_c=d.c_compression,
            c_r=d.c_rebound,
            vk_c=d.knee_velocity_compression,
            vk_r=d.knee_velocity_rebound,
            blowoff=d.blowoff_ratio,
            knee=d.knee_smoothing,
            k_series=d.series_stiffness,
            n_springs=float(a.count),
            area=a.effective_area,
            d_area=a.area_gradient,
            v_bag=a.bag_volume,
            v_res=a.reservoir_volume,
            p0=p0,
            p_atm=a.atmospheric_pressure,
            n_poly=a.polytropic_index,
            rho0=p0 / (a.gas_constant * a.temperature),
            cd_area=a.discharge_coefficient * math.pi * a.orifice_diameter**2 / 4.0,
            dp_lam=a.laminar_pressure,
        )
        return SuspensionParams(*(math.nan if math.isnan(v) else v for v in params))


_SECTIONS: dict[str, type] = {
    "bump_stop": BumpStop,
    "static_spring": StaticSpring,
    "damper": Damper,
    "air_spring": AirSpring,
}
#: deflection scale of observations and rewards for a vehicle that gives no free travel, m
DEFLECTION_SCALE = 0.04


def _placeholder(cls: type, **values: float) -> Any:
    """An unchecked section of ``cls`` with every field ``nan`` but ``values``: what the
    kernels read for a section the vehicle does not have."""
    obj = object.__new__(cls)
    for fl in fields(cls):
        object.__setattr__(obj, fl.name, values.get(fl.name, math.nan))
    return obj


#: the kernels' placeholders of missing sections: no bump-stop force; ``nan`` elsewhere
_NO_BUMP_STOP = _placeholder(BumpStop, stiffness=0.0, cubic_stiffness=0.0, smoothing=1.0)
_NO_DAMPER = _placeholder(Damper)
_NO_AIR_SPRING = _placeholder(AirSpring)


def _read_section(root: val.Fields, sec: str, cls: type, skip: tuple[str, ...] = ()) -> dict:
    f = root.section(sec)
    out = {fl.name: f.get(fl.name) for fl in fields(cls) if fl.name not in skip}
    f.done()
    return out


def vehicle_from_dict(d: Any, name: str = "vehicle") -> VerticalVehicle:
    """Build a validated :class:`VerticalVehicle` from a dict shaped like the YAML file: the
    ``vehicle`` block (``free_travel`` optional; ``name`` default ``name``) and any of the
    element sections (a missing one: the vehicle has no such part)."""
    root = val.Fields(d, "vehicle description")
    root.path = ""
    f = root.section("vehicle")
    kwargs = {
        fl.name: f.get(fl.name)
        for fl in fields(VerticalVehicle)
        if fl.name not in _SECTIONS and fl.name not in ("name", "free_travel")
    }
    kwargs["name"] = f.get("name", name)
    kwargs["free_travel"] = f.get("free_travel", None)
    f.done()
    for sec, cls in _SECTIONS.items():
        kwargs[sec] = cls(**_read_section(root, sec, cls)) if sec in root.data else None
    root.done()
    return VerticalVehicle(**kwargs)


def load_vehicle(name_or_path: str | Path | VerticalVehicle = "manchester") -> VerticalVehicle:
    """Load a vehicle: a packaged name (``"manchester"``) or the path of a ``.yaml`` file (a
    :class:`VerticalVehicle` is returned as it is).

    The "name or path" rule is :func:`railgym._checks.resolve_yaml`'s; errors in a file
    name the file and the field.
    """
    if isinstance(name_or_path, VerticalVehicle):
        return name_or_path
    text, source = val.resolve_yaml(name_or_path, "vehicle", "railgym", ("configs", "vehicles"))
    try:
        return vehicle_from_dict(val.load_yaml(text, source), Path(source).stem)
    except val.FieldError as exc:
        if str(exc).startswith(source):
            raise
        raise type(exc)(exc.field, f"{source}: {exc}", full=True) from None
