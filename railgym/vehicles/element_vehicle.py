"""The vehicle an element was built for: recorded in its file, checked where it runs.

``railgym collect`` writes the one-bogie vehicle it collected on into the element's
``metadata.vehicle`` (:func:`vehicle_document`: the vehicle file's sections, SI, with the
file it came from). An env that runs a user's element (``surrogate=``) on the surrogate
backend then runs it on that vehicle or refuses (:func:`check_element_vehicle`): without
``vehicle=`` an element of another vehicle than the packaged one is an error naming the
vehicle it needs, and a ``vehicle=`` whose parameters differ from the recorded ones is an
error naming the fields that differ. An element without the record (``surrogates build``
from a table, files written before 0.5.0) runs on the ``vehicle=`` given, the packaged one
by default.
"""

from __future__ import annotations

import json
from dataclasses import asdict, fields, replace
from pathlib import Path
from typing import Any

from railgym import _checks as val
from railgym.vehicles.vertical.params import VerticalVehicle, vehicle_from_dict

__all__ = ["check_element_vehicle", "recorded_vehicle", "vehicle_document"]

#: the sections of a vehicle file besides ``vehicle``
_SECTIONS = ("bump_stop", "static_spring", "damper", "air_spring")


def vehicle_document(vehicle: VerticalVehicle, file: str | None = None) -> dict[str, Any]:
    """``vehicle`` as the sections of its YAML file (what :func:`vehicle_from_dict` reads),
    plus ``file``: where it was loaded from (a path or a packaged name; ``None``: unknown)."""
    top = {
        f.name: getattr(vehicle, f.name)
        for f in fields(VerticalVehicle)
        if f.name not in _SECTIONS and not (f.name == "free_travel" and vehicle.free_travel is None)
    }
    doc: dict[str, Any] = {"vehicle": top}
    for name in _SECTIONS:
        section = getattr(vehicle, name)
        if section is not None:
            doc[name] = asdict(section)
    return {"file": file, "description": doc}


def recorded_vehicle(surrogate: Any) -> tuple[VerticalVehicle, str | None] | None:
    """The vehicle recorded in an element (a model with ``metadata_`` or the path of its
    JSON file) and the file it came from; ``None`` when the element records none."""
    if isinstance(surrogate, str | Path):
        try:
            doc = json.loads(Path(surrogate).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None  # the env's loader reports an unreadable element
        metadata = doc.get("metadata") if isinstance(doc, dict) else None
    else:
        metadata = getattr(surrogate, "metadata_", None)
    record = metadata.get("vehicle") if isinstance(metadata, dict) else None
    if record is None:
        return None
    try:
        record = val.mapping(record, "metadata.vehicle")
        vehicle = vehicle_from_dict(record.get("description"), "element's vehicle")
    except val.FieldError as exc:
        raise val.FieldError("surrogate", f"has a malformed metadata.vehicle: {exc}") from None
    return vehicle, record.get("file")


def _differences(a: VerticalVehicle, b: VerticalVehicle) -> list[str]:
    """The fields (``section.field``) where ``a`` and ``b`` differ, names aside."""
    da, db = vehicle_document(a)["description"], vehicle_document(b)["description"]
    out = []
    for section in dict.fromkeys([*da, *db]):
        sa, sb = da.get(section), db.get(section)
        if sa is None or sb is None:
            out.append(f"{section} (in one only)")
            continue
        out += [f"{section}.{k}" for k in sa if k != "name" and sa[k] != sb.get(k)]
    return out


def check_element_vehicle(
    surrogate: Any, given: Any, model: Any, default: str, env: str = "vertical"
) -> None:
    """Refuse a user's element (``surrogate``) on a vehicle it was not built for.

    ``given``: the user's ``vehicle=`` (``None``: not given); ``model``: the loaded vehicle
    the env runs (a whole vehicle: its one-bogie ``suspension``, compared but for ``m2``,
    which is half the whole vehicle's carbody); ``default``: the packaged vehicle of
    ``vehicle=None``; ``env``: the env, for the messages. Raises
    :class:`~railgym._checks.FieldError` naming ``vehicle``.
    """
    found = recorded_vehicle(surrogate)
    if found is None:
        return
    recorded, file = found
    runs = getattr(model, "suspension", model)
    if runs is not model:  # a whole vehicle: m2 is half its carbody, not the element's
        recorded = replace(recorded, m2=runs.m2)
    if recorded.same_physics(runs):
        return
    name = repr(str(surrogate)) if isinstance(surrogate, str | Path) else "the element"
    built = f"vehicle {recorded.name!r}" + (f" ({file})" if file else "")
    if given is None:
        raise val.FieldError(
            "vehicle",
            f"is not given, and surrogate {name} was built for {built} (its metadata.vehicle), "
            f"not railgym's packaged {default!r}: give vehicle= that vehicle's file "
            "(railgym evaluate: --vehicle); an element runs on the vehicle it was built for",
        )
    diff = ", ".join(_differences(recorded, runs)[:6])
    raise val.FieldError(
        "vehicle",
        f"{given!r} is not the vehicle surrogate {name} was built for ({built}, its "
        f"metadata.vehicle) in the {env} env: {diff} differ; give that vehicle, or collect "
        "an element on this one (railgym collect --vehicle)",
    )
