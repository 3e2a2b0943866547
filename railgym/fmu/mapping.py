"""The mapping file of an FMU reference: which FMU variables the env writes and reads.

Schema (YAML, version 1; ``docs/fmi.md``)::

    version: 1
    fmu: vehicle.fmu              # optional: the FMU, relative to this file (else fmu=)
    env: vertical                 # the env the FMU stands in for (or vehicle)
    fmi_type: CoSimulation        # or ModelExchange (default: CoSimulation if the FMU has it)
    step: 0.001                   # communication / integration step, s (default: env dt)
    timeout: 10.0                 # wall-clock limit of one env step in the FMU, s (default 10)
    solver: rk4                   # model exchange: rk4 (railgym's, default) or cvode (FMPy's)
    tolerance: 1.0e-8             # solver: cvode: relative tolerance (absolute: × nominals)
    inputs:
      track:                      # one entry per wheelset, front to rear
        - {displacement: z, rate: zdot}
      actuator_force: [F_a]       # one entry per actuator (upwards on the carbody, N)
    outputs:                      # each value a variable name or {name: ..., unit: ...}
      carbody_acc: a2
      bogie_acc: a1
      deflection: {name: d, unit: mm}
      deflection_rate: dd
      carbody_vel: v2
      carbody_disp: x2            # optional (0 when absent)
      secondary_force: F_s        # optional, for collect (else m2·a2 − actuator force)

Each variable is a name or ``{name: NAME, unit: UNIT}``; the unit (default: the unit the FMU
declares for the variable; none declared means SI) must convert to the SI unit of the
quantity (:data:`UNITS`). Every error names the mapping file and the field, or the FMU file
and the variable.
"""

from __future__ import annotations

import zipfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple
from xml.etree import ElementTree

from railgym import _checks as val

__all__ = ["ENV_SIGNALS", "FMUError", "Mapping", "Signal", "UNITS", "load_mapping"]

#: SI unit → {accepted unit: factor to SI}
UNITS: dict[str, dict[str, float]] = {
    "m": {"m": 1.0, "mm": 1e-3, "cm": 1e-2},
    "m/s": {"m/s": 1.0, "mm/s": 1e-3, "cm/s": 1e-2, "km/h": 1.0 / 3.6},
    "m/s2": {"m/s2": 1.0, "m/s^2": 1.0, "m/s²": 1.0, "mm/s2": 1e-3, "mm/s^2": 1e-3},
    "N": {"N": 1.0, "kN": 1e3, "daN": 10.0},
}
#: per env: wheelsets, actuators, required outputs and optional outputs with their SI units
ENV_SIGNALS: dict[str, dict[str, Any]] = {
    "vertical": {
        "wheelsets": 1,
        "actuators": 1,
        "outputs": {
            "carbody_acc": "m/s2",
            "bogie_acc": "m/s2",
            "deflection": "m",
            "deflection_rate": "m/s",
            "carbody_vel": "m/s",
        },
        "optional": {"carbody_disp": "m", "secondary_force": "N"},
    },
    "vehicle": {
        "wheelsets": 4,
        "actuators": 2,
        "outputs": {
            **{f"acc_{p}": "m/s2" for p in ("front", "centre", "rear")},
            **{f"bogie_acc_{b}": "m/s2" for b in ("front", "rear")},
            **{f"deflection_{b}": "m" for b in ("front", "rear")},
            **{f"deflection_rate_{b}": "m/s" for b in ("front", "rear")},
            **{f"carbody_vel_{b}": "m/s" for b in ("front", "rear")},
        },
        "optional": {f"secondary_force_{b}": "N" for b in ("front", "rear")},
    },
}
FMI_TYPES = ("CoSimulation", "ModelExchange")
DEFAULT_TIMEOUT = 10.0
#: model-exchange solvers: railgym's fixed-step RK4 (the kernels' scheme), FMPy's CVode (BDF)
SOLVERS = ("rk4", "cvode")
DEFAULT_TOLERANCE = 1e-8


class FMUError(val.FieldError):
    """A bad FMU or mapping file: the message names the file and the variable or field."""


@dataclass(frozen=True)
class Signal:
    """One mapped FMU variable: its name, value reference and factor to SI."""

    field: str  #: field path in the mapping file
    name: str
    vr: int
    factor: float


@dataclass(frozen=True)
class Mapping:
    """A checked mapping file (:func:`load_mapping`)."""

    source: str  #: the mapping file
    fmu: Path
    env: str
    fmi_type: str
    step: float | None
    timeout: float
    track: tuple[tuple[Signal, Signal], ...]  #: (displacement, rate) per wheelset
    forces: tuple[Signal, ...]
    outputs: dict[str, Signal]
    interpolate: bool  #: co-simulation FMU takes input derivatives (canInterpolateInputs)
    solver: str = "rk4"  #: model exchange: ``"rk4"`` or ``"cvode"`` (:data:`SOLVERS`)
    tolerance: float = DEFAULT_TOLERANCE  #: relative tolerance of ``"cvode"``


def _read_text(path: Path, field: str) -> str:
    if not path.is_file():
        raise FMUError(field, f"{field} file {str(path)!r} does not exist", full=True)
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise FMUError(
            field, f"{field} file {str(path)!r} cannot be read: {exc}", full=True
        ) from None


def _model_description(fmu: Path) -> Any:
    import fmpy

    if not fmu.is_file():
        raise FMUError("fmu", f"fmu file {str(fmu)!r} does not exist", full=True)
    try:  # the version first: a valid FMI 1.0 or 3.0 FMU is not an invalid FMI 2.0 one
        with zipfile.ZipFile(fmu) as zf:
            version = ElementTree.fromstring(zf.read("modelDescription.xml")).get("fmiVersion")
        if version != "2.0":
            raise FMUError(
                "fmu", f"{fmu}: FMI version {version!r} is not supported (FMI 2.0 only)", full=True
            )
        md = fmpy.read_model_description(str(fmu))
    except FMUError:
        raise
    except Exception as exc:  # FMPy raises plain exceptions for a bad archive or XML
        raise FMUError("fmu", f"{fmu}: not a readable FMU: {exc}", full=True) from None
    platforms = fmpy.supported_platforms(str(fmu))
    if fmpy.platform not in platforms:
        raise FMUError(
            "fmu",
            f"{fmu}: no binary for this platform {fmpy.platform!r} (the FMU has "
            f"{[p for p in platforms if p != 'c-code'] or 'none'}; compile its sources)",
            full=True,
        )
    return md


def _signal(
    spec: Any,
    field: str,
    si: str,
    variables: dict[str, Any],
    fmu: Path,
    source: str,
    causalities: tuple[str, ...],
) -> Signal:
    if isinstance(spec, dict):
        f = val.Fields(spec, field)
        name = f.text("name")
        unit = f.get("unit", None)
        f.done()
        if unit is not None and not isinstance(unit, str):
            raise FMUError(f"{field}.unit", f"{source}: {field}.unit must be a string", full=True)
    elif isinstance(spec, str) and spec:
        name, unit = spec, None
    else:
        raise FMUError(
            field,
            f"{source}: {field} must be a variable name or {{name, unit}}, got {spec!r}",
            full=True,
        )
    var = variables.get(name)
    if var is None:
        raise FMUError(field, f"{source}: {field}: FMU {fmu} has no variable {name!r}", full=True)
    if var.type != "Real":
        raise FMUError(
            field, f"{source}: {field}: FMU variable {name!r} is {var.type}, not Real", full=True
        )
    if var.causality not in causalities:
        raise FMUError(
            field,
            f"{source}: {field}: FMU variable {name!r} has causality {var.causality!r}, "
            f"expected {' or '.join(causalities)}",
            full=True,
        )
    declared = var.unit or (var.declaredType.unit if var.declaredType is not None else None)
    unit = unit or declared or si
    factor = UNITS[si].get(unit)
    if factor is None:
        raise FMUError(
            field,
            f"{source}: {field}: unit {unit!r} of FMU variable {name!r} does not convert to "
            f"{si} (known: {sorted(UNITS[si])})",
            full=True,
        )
    return Signal(field, name, int(var.valueReference), factor)


@contextmanager
def _in_file(source: str) -> Iterator[None]:
    """Re-raise a field error of the mapping file as an :class:`FMUError` naming the file."""
    try:
        yield
    except val.FieldError as exc:
        raise FMUError(exc.field, f"{source}: {exc}", full=True) from None


class _Top(NamedTuple):
    """The top-level fields of a mapping file (``None``: not given)."""

    fmu: Any
    env: str
    fmi_type: Any
    step: float | None
    timeout: float
    solver: Any
    tolerance: float | None
    inputs: val.Fields
    outputs: val.Fields


def _top_fields(path: Path, source: str) -> _Top:
    """Read the mapping file's top level: every key known, numbers checked."""
    data = val.load_yaml(_read_text(path, "fmu_map"), source)
    f = val.Fields(data, "")
    with _in_file(source):
        f.integer("version", 1, 1)
        name = f.get("fmu", None)
        env_name = f.text("env")
        fmi_type = f.get("fmi_type", None)
        step = f.get("step", None)
        step = None if step is None else f.positive("step")
        timeout = f.positive("timeout") if "timeout" in f.data else DEFAULT_TIMEOUT
        solver = f.get("solver", None)
        tolerance = f.positive("tolerance", 0.1) if "tolerance" in f.data else None
        inputs = f.section("inputs")
        outputs = f.section("outputs")
        f.done()
    return _Top(name, env_name, fmi_type, step, timeout, solver, tolerance, inputs, outputs)


def _fmi_type(top: _Top, md: Any, fmu: Path, source: str) -> str:
    """The FMI type to run (the file's, else the FMU's first of :data:`FMI_TYPES`), checked
    against the FMU and the solver options."""
    kinds = [k for k, d in zip(FMI_TYPES, (md.coSimulation, md.modelExchange), strict=True) if d]
    fmi_type = kinds[0] if top.fmi_type is None else top.fmi_type
    if fmi_type not in FMI_TYPES:
        raise FMUError("fmi_type", f"{source}: fmi_type must be one of {FMI_TYPES}", full=True)
    solver = top.solver
    if solver is not None and (solver not in SOLVERS or fmi_type != "ModelExchange"):
        raise FMUError(
            "solver",
            f"{source}: solver must be one of {SOLVERS}, for fmi_type ModelExchange; got "
            f"{solver!r} with {fmi_type}",
            full=True,
        )
    if top.tolerance is not None and solver != "cvode":
        raise FMUError("tolerance", f"{source}: tolerance is for solver: cvode", full=True)
    if fmi_type not in kinds:
        raise FMUError(
            "fmi_type", f"{source}: FMU {fmu} has no {fmi_type} (it has {kinds})", full=True
        )
    return str(fmi_type)


def _input_signals(
    inputs: val.Fields, spec: dict[str, Any], variables: dict[str, Any], fmu: Path, source: str
) -> tuple[tuple[tuple[Signal, Signal], ...], tuple[Signal, ...]]:
    """The (displacement, rate) signals of each wheelset and the actuator-force signals."""
    ins = ("input",)
    with _in_file(source):
        track = val.sequence(inputs.get("track"), "inputs.track", spec["wheelsets"])
        forces = val.sequence(
            inputs.get("actuator_force"), "inputs.actuator_force", spec["actuators"]
        )
        inputs.done()
    pairs = []
    for i, entry in enumerate(track):
        with _in_file(source):
            t = val.Fields(entry, f"inputs.track[{i}]")
            d_spec, r_spec = t.get("displacement"), t.get("rate")
            t.done()
        pairs.append(
            (
                _signal(d_spec, t.field("displacement"), "m", variables, fmu, source, ins),
                _signal(r_spec, t.field("rate"), "m/s", variables, fmu, source, ins),
            )
        )
    force_sigs = tuple(
        _signal(s, f"inputs.actuator_force[{i}]", "N", variables, fmu, source, ins)
        for i, s in enumerate(forces)
    )
    return tuple(pairs), force_sigs


def _output_signals(
    outputs: val.Fields, spec: dict[str, Any], variables: dict[str, Any], fmu: Path, source: str
) -> dict[str, Signal]:
    """The signals of the env's required and optional outputs; an unknown key is an error."""
    known = {**spec["outputs"], **spec["optional"]}
    for key in outputs.data:
        if key not in known:
            raise FMUError(
                f"outputs.{key}",
                f"{source}: unknown field outputs.{key} (known: {sorted(known)})",
                full=True,
            )
    outs = {}
    for key, si in known.items():
        if key not in outputs.data:
            if key in spec["outputs"]:
                raise FMUError(f"outputs.{key}", f"{source}: outputs.{key} is missing", full=True)
            continue
        outs[key] = _signal(
            outputs.data[key], f"outputs.{key}", si, variables, fmu, source, ("output", "local")
        )
    return outs


def load_mapping(path: str | Path, fmu: str | Path | None = None, env: str = "vertical") -> Mapping:
    """Read and check the mapping file ``path`` against the FMU (``fmu``, else the file's
    ``fmu:`` relative to the mapping file) for ``env``; :class:`FMUError` on any problem."""
    path = Path(path)
    source = str(path)
    top = _top_fields(path, source)
    if top.env != env:
        raise FMUError("env", f"{source}: env is {top.env!r}, this env is {env!r}", full=True)
    if fmu is None:
        if top.fmu is None:
            raise FMUError("fmu", f"{source}: no fmu given (fmu= or the file's fmu:)", full=True)
        fmu = path.parent / str(top.fmu)
    fmu = Path(fmu)
    md = _model_description(fmu)
    fmi_type = _fmi_type(top, md, fmu, source)
    variables = {v.name: v for v in md.modelVariables}
    spec = ENV_SIGNALS[env]
    track, forces = _input_signals(top.inputs, spec, variables, fmu, source)
    outs = _output_signals(top.outputs, spec, variables, fmu, source)
    interpolate = fmi_type == "CoSimulation" and bool(md.coSimulation.canInterpolateInputs)
    return Mapping(
        source,
        fmu,
        env,
        fmi_type,
        top.step,
        top.timeout,
        track,
        forces,
        outs,
        interpolate,
        top.solver or "rk4",
        DEFAULT_TOLERANCE if top.tolerance is None else top.tolerance,
    )
