"""The data of a whole railway vehicle in the vertical plane
(:mod:`railgym.vehicles.vehicle.model`): carbody, bending mode, bogies and the one-bogie
suspension of each bogie, loaded from YAML."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from railgym import _checks as val
from railgym.vehicles.vertical.params import VerticalVehicle, load_vehicle

__all__ = [
    "BETA_L",
    "FLOOR_POINTS",
    "WholeVehicle",
    "check_geometry",
    "load_whole_vehicle",
    "mode_shape",
]

#: floor points where the carbody acceleration is reported: over the front bogie, centre,
#: over the rear bogie (multiples of the bogie semi-spacing ``a``)
FLOOR_POINTS = (1.0, 0.0, -1.0)
#: whole-vehicle fields that may be zero (the others must be positive)
_NON_NEGATIVE = ("bogie_semi_spacing", "semi_wheelbase", "bending_damping")
#: root of cos(βL)·cosh(βL) = 1 of the first free–free beam mode
BETA_L = 4.730040744862704


def mode_shape(x: Any, length: float) -> np.ndarray:
    """First free–free bending mode ``φ(x)`` of a uniform beam, ``φ(0) = 1`` (x from centre, m)."""
    bl = BETA_L
    sigma = (math.cosh(bl) - math.cos(bl)) / (math.sinh(bl) - math.sin(bl))

    def raw(s: np.ndarray) -> np.ndarray:
        u = bl * s
        return np.cosh(u) + np.cos(u) - sigma * (np.sinh(u) + np.sin(u))

    s = np.asarray(x, dtype=float) / length + 0.5
    return raw(s) / raw(np.asarray(0.5))


@dataclass(frozen=True)
class WholeVehicle:
    """Whole-vehicle data (SI), see ``configs/vehicles/manchester_whole.yaml``.

    ``suspension`` is the one-bogie model whose primary/secondary suspension data apply to
    each bogie; its ``m2`` is set to half the carbody (the air-spring preload).
    """

    name: str
    carbody_mass: float
    carbody_pitch_inertia: float
    carbody_length: float
    bending_frequency: float
    bending_damping: float
    bending_modal_mass: float
    bogie_mass: float
    bogie_pitch_inertia: float
    bogie_semi_spacing: float
    semi_wheelbase: float
    suspension: VerticalVehicle

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name in ("name", "suspension"):
                continue
            check = val.non_negative if f.name in _NON_NEGATIVE else val.positive
            object.__setattr__(
                self, f.name, check(getattr(self, f.name), f"whole_vehicle.{f.name}")
            )
        if 2.0 * self.bogie_semi_spacing >= self.carbody_length:
            raise val.FieldError(
                "whole_vehicle.bogie_semi_spacing",
                f"must lie within the carbody (2·a < carbody_length = {self.carbody_length} m), "
                f"got {self.bogie_semi_spacing!r}",
            )

    @property
    def wheelset_positions(self) -> np.ndarray:
        """Wheelset positions from the carbody centre, front to rear, m (4,)."""
        a, b = self.bogie_semi_spacing, self.semi_wheelbase
        return np.array([a + b, a - b, -a + b, -a - b])

    @property
    def floor_positions(self) -> np.ndarray:
        """Floor points of :data:`FLOOR_POINTS`, m (3,)."""
        return self.bogie_semi_spacing * np.array(FLOOR_POINTS)


_WHOLE_FIELDS = tuple(f.name for f in fields(WholeVehicle) if f.name not in ("name", "suspension"))


def _beside(base: Any, name_or_path: str | Path) -> Any:
    """``base:`` of a whole-vehicle file: a relative ``.yaml`` path is read beside that file
    (never from the working folder); a packaged name or an absolute path as given."""
    text = str(name_or_path)
    if isinstance(base, str | Path) and str(base).endswith(val.YAML_SUFFIXES):
        if text.endswith(val.YAML_SUFFIXES):
            return str(Path(text).parent / base)
    return base


def check_geometry(vehicle: WholeVehicle) -> None:
    """Refuse what cannot describe a vehicle (a file's, :func:`load_whole_vehicle`): bogies
    that overlap (b ≥ a), wheelsets beyond the carbody's ends (a + b > L/2), a pitch inertia
    no body of this mass and length has (above m·(L/2)², all the mass at the ends). Limits
    made in code (a = b = 0 to compare with the one-bogie model) are not refused."""
    a, b, length = vehicle.bogie_semi_spacing, vehicle.semi_wheelbase, vehicle.carbody_length
    if b >= a:
        raise val.FieldError(
            "whole_vehicle.semi_wheelbase",
            f"({b!r} m) must be less than bogie_semi_spacing ({a!r} m): the bogies' inner "
            "wheelsets would overlap",
        )
    if a + b > 0.5 * length:
        raise val.FieldError(
            "whole_vehicle.semi_wheelbase",
            f"({b!r} m): the outer wheelsets at ±(a + b) = ±{a + b:g} m lie beyond the "
            f"carbody's ends (carbody_length / 2 = {0.5 * length:g} m)",
        )
    top = vehicle.carbody_mass * (0.5 * length) ** 2
    if vehicle.carbody_pitch_inertia > top:
        raise val.FieldError(
            "whole_vehicle.carbody_pitch_inertia",
            f"({vehicle.carbody_pitch_inertia:g} kg·m²) exceeds carbody_mass·"
            f"(carbody_length/2)² = {top:g} kg·m², the most a body of that mass and length "
            "can have",
        )


def load_whole_vehicle(name_or_path: str | Path = "manchester_whole") -> WholeVehicle:
    """Load a whole vehicle: a packaged name or the path of a ``.yaml`` file with the
    sections ``base`` (name or path of the one-bogie vehicle; a relative path is read
    beside the file) and ``whole_vehicle``.

    The "name or path" rule is :func:`railgym._checks.resolve_yaml`'s; errors in a file
    name the file and the field.
    """
    text, source = val.resolve_yaml(name_or_path, "vehicle", "railgym", ("configs", "vehicles"))
    try:
        top = val.Fields(val.load_yaml(text, source), "")
        base = load_vehicle(_beside(top.get("base"), name_or_path))
        sec = top.section("whole_vehicle")
        values = {name: sec.get(name) for name in _WHOLE_FIELDS}
        sec.done()
        top.done()
        mass = val.positive(values["carbody_mass"], "whole_vehicle.carbody_mass")
        suspension = replace(base, m2=0.5 * mass)
        whole = WholeVehicle(name=str(name_or_path), suspension=suspension, **values)
        check_geometry(whole)
        return whole
    except val.FieldError as exc:
        if str(exc).startswith(source):
            raise
        raise type(exc)(exc.field, f"{source}: {exc}", full=True) from None
