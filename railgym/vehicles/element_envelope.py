"""The operating envelope of a suspension element: the track and speeds it was built for.

A surrogate element is backed by the reference runs it was fitted on and by the cases where
its accuracy was measured; outside them it may sit inside its training box (every input in
range) and still be far off the reference (docs/validation.md, *Validity flags*). An element
file states that envelope in its ``metadata.envelope``::

    "envelope": {"track_classes": [3, 4, 5, 6], "speed_factor": [0.7, 1.0]}

``track_classes``
    FRA classes (1..6) the element was built for (required).
``speed_factor``
    ``[low, high]``: running speeds as fractions of each class's maximum speed
    (:func:`railgym.track.class_speed`), bounds included; absent: no bound.
``speed``
    ``[low, high]``: running speeds in m/s, bounds included; absent: no bound.

A case is inside when its class is listed and its speed meets every bound given. The envelope
is of FRA track: an episode on a measured or user profile is outside it. An element without
an envelope (e.g. one fitted in this session) is never reported outside.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from typing import Any, NamedTuple

from railgym.track import class_speed

__all__ = [
    "ENVELOPE_KEY",
    "OperatingEnvelope",
    "design_envelope",
    "element_envelope",
    "EnvelopeCheck",
    "envelope_warning",
    "outside_envelope",
    "parse_envelope",
]

#: key of the envelope in an element file's ``metadata``
ENVELOPE_KEY = "envelope"
#: relative tolerance of the speed bounds (a speed given as ``factor · class_speed``)
_REL = 1e-9
_FIELDS = ("track_classes", "speed_factor", "speed")


class OperatingEnvelope(NamedTuple):
    """Track classes and speed bounds an element was built for (module docstring)."""

    track_classes: tuple[int, ...]  #: FRA classes
    speed_factor: tuple[float, float] | None = None  #: fractions of the class's maximum speed
    speed: tuple[float, float] | None = None  #: m/s

    def contains(self, track_class: int, speed: float, measured: bool = False) -> bool:
        """True when FRA ``track_class`` at ``speed`` (m/s) is inside; ``measured``: the
        episode runs a measured or user profile (never inside)."""
        if measured or int(track_class) not in self.track_classes:
            return False
        if self.speed_factor is not None:
            lo, hi = self.speed_factor
            f = speed / class_speed(int(track_class))
            if not lo * (1.0 - _REL) <= f <= hi * (1.0 + _REL):
                return False
        if self.speed is not None:
            lo, hi = self.speed
            if not lo * (1.0 - _REL) <= speed <= hi * (1.0 + _REL):
                return False
        return True

    def describe(self) -> str:
        """The envelope in words, e.g. ``FRA classes 3, 4, 5, 6 at 0.7–1 × each class's
        maximum speed``."""
        classes = ", ".join(str(c) for c in self.track_classes)
        speeds = []
        if self.speed_factor is not None:
            lo, hi = self.speed_factor
            span = f"{lo:g}" if lo == hi else f"up to {hi:g}" if lo == 0 else f"{lo:g}–{hi:g}"
            speeds.append(f"{span} × each class's maximum speed")
        if self.speed is not None:
            lo, hi = self.speed
            speeds.append(f"{lo:.4g}–{hi:.4g} m/s ({lo * 3.6:.0f}–{hi * 3.6:.0f} km/h)")
        where = f"FRA class{'es' if len(self.track_classes) > 1 else ''} {classes}"
        return where + (f" at {' and '.join(speeds)}" if speeds else " at any speed")

    def document(self) -> dict[str, Any]:
        """The ``metadata.envelope`` object of this envelope (JSON types)."""
        doc: dict[str, Any] = {"track_classes": list(self.track_classes)}
        for key in ("speed_factor", "speed"):
            bounds = getattr(self, key)
            if bounds is not None:
                doc[key] = list(bounds)
        return doc


def _bounds(value: Any, where: str, unit: str) -> tuple[float, float]:
    """``[low, high]`` of finite numbers with ``0 <= low <= high`` (``unit`` for messages)."""
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise ValueError(f"{where} must be [low, high] ({unit}), got {value!r}")
    for v in value:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise ValueError(f"{where} must hold two finite numbers ({unit}), got {value!r}")
    lo, hi = float(value[0]), float(value[1])
    if not 0.0 <= lo <= hi:
        raise ValueError(f"{where} must have 0 <= low <= high ({unit}), got {value!r}")
    return lo, hi


def parse_envelope(doc: Any, where: str = "metadata.envelope") -> OperatingEnvelope:
    """The :class:`OperatingEnvelope` of a ``metadata.envelope`` object; ``ValueError``
    naming the field (prefixed by ``where``) for anything else."""
    if not isinstance(doc, Mapping):
        raise ValueError(f"{where} must be an object with {', '.join(_FIELDS)}, got {doc!r}")
    unknown = sorted(set(doc) - set(_FIELDS))
    if unknown:
        raise ValueError(f"{where}.{unknown[0]} is not a known field (known: {', '.join(_FIELDS)})")
    classes = doc.get("track_classes")
    if (
        not isinstance(classes, list | tuple)
        or not classes
        or any(isinstance(c, bool) or not isinstance(c, int) or not 1 <= c <= 6 for c in classes)
    ):
        raise ValueError(
            f"{where}.track_classes must be a non-empty list of FRA classes 1..6, got {classes!r}"
        )
    factor = doc.get("speed_factor")
    speed = doc.get("speed")
    return OperatingEnvelope(
        tuple(sorted(set(int(c) for c in classes))),
        None if factor is None else _bounds(factor, f"{where}.speed_factor", "fractions"),
        None if speed is None else _bounds(speed, f"{where}.speed", "m/s"),
    )


def element_envelope(model: Any) -> OperatingEnvelope | None:
    """The envelope of an element's ``metadata_`` (set by :func:`surrogates.io.load`);
    ``None`` without one. A malformed envelope is a ``ValueError`` naming the field."""
    metadata = getattr(model, "metadata_", None)
    if not isinstance(metadata, Mapping) or metadata.get(ENVELOPE_KEY) is None:
        return None
    return parse_envelope(metadata[ENVELOPE_KEY])


def design_envelope(design: Any) -> OperatingEnvelope:
    """The envelope of a data-collection design: its ``track_classes`` with the range of its
    ``speed_factors`` (a :class:`~railgym.vehicles.collect_design.CollectionDesign`) or of its
    absolute ``speeds`` (m/s; where a design has both, the speeds are the ones run)."""
    speeds = tuple(getattr(design, "speeds", ()) or ())
    factors = tuple(getattr(design, "speed_factors", ()) or ())
    classes = tuple(sorted(set(int(c) for c in design.track_classes)))
    if speeds:
        return OperatingEnvelope(classes, speed=(float(min(speeds)), float(max(speeds))))
    return OperatingEnvelope(classes, speed_factor=(float(min(factors)), float(max(factors))))


def outside_envelope(
    envelope: OperatingEnvelope | None, track_class: int, speed: float, measured: bool = False
) -> bool:
    """True when an episode of FRA ``track_class`` at ``speed`` (m/s; ``measured``: on a
    measured or user profile) is outside ``envelope``; False without an envelope."""
    return envelope is not None and not envelope.contains(track_class, speed, measured)


def envelope_warning(
    envelope: OperatingEnvelope, track_class: int, speed: float, measured: bool = False
) -> str:
    """The text of the warning of an episode outside ``envelope`` (arguments as
    :func:`outside_envelope`)."""
    if measured:
        case = f"a measured or user profile at {speed:.4g} m/s"
    else:
        factor = speed / class_speed(int(track_class))
        case = (
            f"FRA class {int(track_class)} at {speed:.4g} m/s ({speed * 3.6:.0f} km/h, "
            f"{factor:.2f} × the class's maximum speed)"
        )
    return (
        f"the surrogate element was built for {envelope.describe()}; this episode runs {case}, "
        "outside that envelope: its accuracy there is not validated against the reference "
        "(info['outside_envelope'] is True for such episodes; docs/validation.md, Validity "
        "flags). Warned once per env."
    )


class EnvelopeCheck:
    """Whether a batch's episodes run outside ``envelope`` (``None``: never), with one
    ``UserWarning`` the first time (``env``: the env's name in it)."""

    def __init__(self, envelope: OperatingEnvelope | None, env: str) -> None:
        self.envelope, self.env, self.warned = envelope, env, False

    def __call__(self, track_class: int, speed: float, measured: bool = False) -> bool:
        """True when FRA ``track_class`` at ``speed`` (m/s; ``measured``: a measured or user
        profile) is outside the envelope; warns the first time."""
        outside = outside_envelope(self.envelope, track_class, speed, measured)
        if outside and not self.warned and self.envelope is not None:
            self.warned = True
            text = envelope_warning(self.envelope, track_class, speed, measured)
            warnings.warn(f"{self.env}: {text}", UserWarning, stacklevel=3)
        return outside
