"""The mapping file of an FMU reference: which FMU variables the env writes and reads.

Schema (YAML, version 1; ``docs/fmi.md``)::

    version: 1
    fmu: vehicle.fmu              # optional: the FMU, relative to this file (else fmu=)
    vehicle: car.yaml             # optional: the FMU's vehicle, a YAML path relative to this
                                  # file or a packaged name (manchester)
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
    outputs:                      # a variable, an expression, {name: ...} or {expr: ...}
      carbody_acc: a2
      bogie_acc: der(v1)          # the runner's time derivative of v1
      deflection: x1 - x2
      deflection_rate: {expr: v1 - v2}
      carbody_vel: {name: v2, unit: m/s}
      carbody_disp: x2            # optional (0 when absent)
      secondary_force: F_s        # optional, for collect (else m2·a2 − actuator force)

An input is a variable name or ``{name: NAME, unit: UNIT}``. An output is one of

* a string that is the name of an FMU variable: that variable (so the ``der(x)`` variables of
  a model-exchange FMU are read, not differentiated), or ``{name: NAME, unit: UNIT}``;
* any other string, or ``{expr: EXPR, unit: UNIT}``: an expression of FMU variables
  (:mod:`railgym.fmu.expression`: numbers, names, ``"quoted names"``, ``+ - * /``, unary
  minus, parentheses, ``der(...)`` computed by the runner at the env's substep).

Units: ``unit:`` fills in a unit the FMU does not declare and never overrides one. A variable
is in the unit the FMU declares for it, else the mapping's ``unit:``, else SI; a ``unit:``
that disagrees with the declared unit is an error; the unit must convert to the SI unit of
the quantity (:data:`UNITS`). In an expression every variable is converted to SI by the unit
the FMU declares for it (none declared: taken as SI; a declared unit railgym does not know is
an error), and the expression's dimension, where those units give it (a number in a product
makes it unknown), must be the quantity's. ``unit:`` on an expression is the unit of its value
(converted to SI after evaluation, the variables taken as they are) and is refused when a
variable of the expression declares a unit. Every error names the mapping file and the field,
or the FMU file and the variable.
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
from railgym.fmu.expression import Dim, Expression, ExpressionError, dim_text, dimension, parse

__all__ = [
    "ENV_SIGNALS",
    "FMUError",
    "Mapping",
    "Output",
    "Signal",
    "UNITS",
    "fmu_vehicle",
    "load_mapping",
    "mapping_env",
    "mapping_vehicle",
    "same_vehicle",
]

#: SI unit → {accepted unit: factor to SI}
UNITS: dict[str, dict[str, float]] = {
    "m": {"m": 1.0, "mm": 1e-3, "cm": 1e-2},
    "m/s": {"m/s": 1.0, "mm/s": 1e-3, "cm/s": 1e-2, "km/h": 1.0 / 3.6},
    "m/s2": {"m/s2": 1.0, "m/s^2": 1.0, "m/s²": 1.0, "mm/s2": 1e-3, "mm/s^2": 1e-3},
    "N": {"N": 1.0, "kN": 1e3, "daN": 10.0},
}
#: SI units an expression's variables may declare besides those of :data:`UNITS` (factor 1)
SI_UNITS: dict[str, Dim] = {
    "1": (0, 0, 0),
    "rad": (0, 0, 0),
    "s": (0, 1, 0),
    "kg": (0, 0, 1),
    "rad/s": (0, -1, 0),
    "Pa": (-1, -2, 1),
    "N/m": (0, -2, 1),
    "N.s/m": (0, -1, 1),
}
#: SI unit → dimension (exponents of m, s, kg)
DIMS: dict[str, Dim] = {
    "m": (1, 0, 0),
    "m/s": (1, -1, 0),
    "m/s2": (1, -2, 0),
    "N": (1, -2, 1),
    **SI_UNITS,
}
#: unit → (its SI unit, factor to SI), every unit of :data:`UNITS` and :data:`SI_UNITS`
TO_SI: dict[str, tuple[str, float]] = {
    **{u: (si, f) for si, table in UNITS.items() for u, f in table.items()},
    **{u: (u, 1.0) for u in SI_UNITS},
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
class Output:
    """One mapped output: an FMU variable or an expression of them.

    Its SI value is ``expr`` evaluated with each variable of ``signals`` times its
    ``factor``, then times ``factor`` (the ``unit:`` of an expression, else 1)."""

    field: str  #: field path in the mapping file
    expr: Expression  #: one variable: :meth:`Expression.of` its name
    signals: tuple[Signal, ...]  #: the FMU variables it reads, in ``expr.names`` order
    factor: float = 1.0


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
    outputs: dict[str, Output]
    interpolate: bool  #: co-simulation FMU takes input derivatives (canInterpolateInputs)
    solver: str = "rk4"  #: model exchange: ``"rk4"`` or ``"cvode"`` (:data:`SOLVERS`)
    tolerance: float = DEFAULT_TOLERANCE  #: relative tolerance of ``"cvode"``
    #: ``vehicle:`` of the file: a YAML path (a relative one read beside the mapping file)
    #: or a packaged vehicle name; ``None`` when not given
    vehicle: str | None = None


def _read_text(path: Path, field: str) -> str:
    if path.is_dir():
        raise FMUError(
            field,
            f"{field} {str(path)!r} is a folder, not a file; give the mapping file (YAML) itself",
            full=True,
        )
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

    if fmu.is_dir():
        raise FMUError(
            "fmu",
            f"fmu {str(fmu)!r} is a folder, not a file; give the .fmu archive itself (zip an "
            "unpacked FMU's folder contents into one)",
            full=True,
        )
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


def _variable(
    name: str,
    field: str,
    variables: dict[str, Any],
    fmu: Path,
    source: str,
    causalities: tuple[str, ...],
    where: str = "",
) -> Any:
    """The FMU variable ``name`` (FMPy's), checked: it exists, is Real, has a causality of
    ``causalities``; ``where`` is appended to the messages."""
    var = variables.get(name)
    if var is None:
        raise FMUError(
            field, f"{source}: {field}: FMU {fmu} has no variable {name!r}{where}", full=True
        )
    if var.type != "Real":
        raise FMUError(
            field,
            f"{source}: {field}: FMU variable {name!r} is {var.type}, not Real{where}",
            full=True,
        )
    if var.causality not in causalities:
        raise FMUError(
            field,
            f"{source}: {field}: FMU variable {name!r} has causality {var.causality!r}, "
            f"expected {' or '.join(causalities)}{where}",
            full=True,
        )
    return var


def _declared(var: Any) -> str | None:
    """The unit the FMU declares for ``var`` (its own, else its type's), ``None``: none."""
    unit = var.unit or (var.declaredType.unit if var.declaredType is not None else None)
    return str(unit) if unit else None


def _with_unit(spec: dict, key: str, field: str, source: str) -> tuple[str, str | None]:
    """``spec[key]`` (a non-empty string) and its optional ``unit`` of the mapping entry
    ``{key: ..., unit: ...}`` at ``field``; any other key is an error."""
    with _in_file(source):
        f = val.Fields(spec, field)
        text = f.text(key)
        unit = f.get("unit", None)
        f.done()
    if unit is not None and not isinstance(unit, str):
        raise FMUError(f"{field}.unit", f"{source}: {field}.unit must be a string", full=True)
    return text, unit


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
        name, unit = _with_unit(spec, "name", field, source)
    elif isinstance(spec, str) and spec:
        name, unit = spec, None
    else:
        raise FMUError(
            field,
            f"{source}: {field} must be a variable name or {{name, unit}}, got {spec!r}",
            full=True,
        )
    var = _variable(name, field, variables, fmu, source, causalities)
    declared = _declared(var)
    table = UNITS[si]
    same = unit == declared or (unit in table and table[unit] == table.get(declared or ""))
    if unit is not None and declared is not None and not same:
        raise FMUError(
            field,
            f"{source}: {field}: the FMU declares {declared!r} for variable {name!r}; the "
            f"mapping's unit {unit!r} disagrees — remove unit: or fix the FMU",
            full=True,
        )
    unit = declared or unit or si
    factor = table.get(unit)
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
    vehicle: Any


def _document(path: Path, source: str) -> dict[str, Any]:
    """The mapping file's YAML document, a mapping (:class:`FMUError` naming the file)."""
    data = val.load_yaml(_read_text(path, "fmu_map"), source)
    if not isinstance(data, dict):
        got = "nothing" if data is None else f"a {_yaml_kind(data)}"
        raise FMUError(
            "fmu_map",
            f"{source}: the mapping file must be a YAML mapping (version:, env:, inputs:, "
            f"outputs:), got {got}",
            full=True,
        )
    return data


def _yaml_kind(data: Any) -> str:
    """The YAML name of a non-mapping document's type."""
    if isinstance(data, list):
        return "list"
    if isinstance(data, str):
        return "string"
    return "number" if isinstance(data, int | float) else type(data).__name__


def _top_fields(path: Path, source: str) -> _Top:
    """Read the mapping file's top level: every key known, numbers checked."""
    data = _document(path, source)
    f = val.Fields(data, "")
    with _in_file(source):
        f.integer("version", 1, 1)
        name = f.get("fmu", None)
        vehicle = f.get("vehicle", None)
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
    return _Top(
        name, env_name, fmi_type, step, timeout, solver, tolerance, inputs, outputs, vehicle
    )


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


_OUTPUT_FORMS = "a variable name, an expression, {name: ..., unit: ...} or {expr: ..., unit: ...}"


def _output(
    spec: Any, field: str, si: str, variables: dict[str, Any], fmu: Path, source: str
) -> Output:
    """The output at ``field`` (SI unit ``si``): a variable or an expression (module
    docstring: forms and the unit rule)."""
    causalities = ("output", "local")
    if isinstance(spec, dict) and ("name" in spec) == ("expr" in spec):
        raise FMUError(
            field,
            f"{source}: {field} needs name: (one FMU variable) or expr: (an expression), "
            "not both or neither",
            full=True,
        )
    if (isinstance(spec, str) and spec in variables) or (isinstance(spec, dict) and "name" in spec):
        sig = _signal(spec, field, si, variables, fmu, source, causalities)
        return Output(field, Expression.of(sig.name), (sig,))
    unit = None
    if isinstance(spec, dict):
        text, unit = _with_unit(spec, "expr", field, source)
    elif isinstance(spec, str):
        text = spec
    else:
        raise FMUError(field, f"{source}: {field} must be {_OUTPUT_FORMS}, got {spec!r}", full=True)
    in_text = f" in the expression {text!r}"
    try:
        expr = parse(text)
    except ExpressionError as exc:
        raise FMUError(field, f"{source}: {field}: {exc}{in_text}", full=True) from None
    signals: list[Signal] = []
    dims: dict[str, Dim | None] = {}
    for name, col in zip(expr.names, expr.columns, strict=True):
        where = f" (column {col} of the expression {text!r})"
        sig, dims[name] = _expression_variable(name, field, unit, variables, fmu, source, where)
        signals.append(sig)
    scale = 1.0
    if unit is not None:
        if unit not in UNITS[si]:
            raise FMUError(
                f"{field}.unit",
                f"{source}: {field}.unit {unit!r} does not convert to {si} "
                f"(known: {sorted(UNITS[si])})",
                full=True,
            )
        scale = UNITS[si][unit]
    try:
        got = dimension(expr, dims)
    except ExpressionError as exc:
        raise FMUError(field, f"{source}: {field}: {exc}{in_text}", full=True) from None
    if got is not None and got != DIMS[si]:
        raise FMUError(
            field,
            f"{source}: {field}: the expression {text!r} is in {dim_text(got)} (by the units "
            f"the FMU declares), {field} is in {si}",
            full=True,
        )
    return Output(field, expr, tuple(signals), scale)


def _expression_variable(
    name: str,
    field: str,
    unit: str | None,
    variables: dict[str, Any],
    fmu: Path,
    source: str,
    where: str,
) -> tuple[Signal, Dim | None]:
    """The signal of variable ``name`` of the expression at ``field`` (``unit``: its
    ``unit:``) with its factor to SI, and its dimension (``None``: no declared unit)."""
    var = _variable(name, field, variables, fmu, source, ("output", "local"), where)
    declared = _declared(var)
    if declared is not None and unit is not None:
        raise FMUError(
            field,
            f"{source}: {field}: unit: {unit!r} is the unit of an expression of variables "
            f"without a declared unit, but the FMU declares {declared!r} for variable "
            f"{name!r}{where} — remove unit: (the variables are then converted by their "
            "declared units)",
            full=True,
        )
    if declared is None:
        return Signal(field, name, int(var.valueReference), 1.0), None
    if declared not in TO_SI:
        raise FMUError(
            field,
            f"{source}: {field}: the FMU declares unit {declared!r} for variable "
            f"{name!r}{where}, which railgym does not convert (known: {sorted(TO_SI)})",
            full=True,
        )
    var_si, factor = TO_SI[declared]
    return Signal(field, name, int(var.valueReference), factor), DIMS[var_si]


def _output_signals(
    outputs: val.Fields, spec: dict[str, Any], variables: dict[str, Any], fmu: Path, source: str
) -> dict[str, Output]:
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
        outs[key] = _output(outputs.data[key], f"outputs.{key}", si, variables, fmu, source)
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
        _vehicle(top.vehicle, path, source),
    )


def _vehicle(value: Any, path: Path, source: str) -> str | None:
    """The ``vehicle:`` of the mapping file ``path``: a relative ``.yaml``/``.yml`` path is
    the file beside the mapping (never one of the working folder; a missing one is an
    :class:`FMUError` naming that path), an absolute path or a packaged name as given;
    ``None`` when absent."""
    if value is None:
        return None
    if not isinstance(value, str) or not value:
        raise FMUError(
            "vehicle",
            f"{source}: vehicle must be a vehicle YAML path (relative to the mapping file) or "
            f"a packaged vehicle name, got {value!r}",
            full=True,
        )
    if not value.endswith(val.YAML_SUFFIXES) or Path(value).is_absolute():
        return value
    local = path.parent / value
    if not local.is_file():
        raise FMUError(
            "vehicle",
            f"{source}: vehicle {value!r} is read beside the mapping file, and {str(local)!r} "
            "does not exist (give a path relative to the mapping file, an absolute path or a "
            "packaged vehicle name)",
            full=True,
        )
    return str(local)


def mapping_env(path: str | Path) -> str:
    """The mapping file's ``env:`` (:data:`ENV_SIGNALS`'s keys); any other value, or none, is
    an :class:`FMUError` naming the file. Only this key is read; the whole file is checked
    by :func:`load_mapping`."""
    source = str(path)
    env = _document(Path(path), source).get("env")
    if env not in ENV_SIGNALS:
        raise FMUError(
            "env", f"{source}: env must be one of {sorted(ENV_SIGNALS)}, got {env!r}", full=True
        )
    return str(env)


def mapping_vehicle(path: str | Path, env: str | None = None) -> str | None:
    """The mapping file's top-level ``vehicle:`` (the description of the FMU's vehicle): a
    path relative to the mapping file, resolved, or a packaged name; ``None`` when absent.
    Only this key (and ``env``, checked when given) is read; the whole file is checked by
    :func:`load_mapping`."""
    path = Path(path)
    source = str(path)
    data = _document(path, source)
    if env is not None and data.get("env", env) != env:
        raise FMUError("env", f"{source}: env is {data['env']!r}, this env is {env!r}", full=True)
    return _vehicle(data.get("vehicle"), path, source)


def fmu_vehicle(
    fmu_map: str | Path, vehicle: Any = None, flag: str = "vehicle=", env: str | None = None
) -> Any:
    """The vehicle description of the FMU of ``fmu_map``: ``vehicle`` (name, YAML path or
    ``VerticalVehicle``), else the mapping's ``vehicle:``; neither (or both, naming different
    files or names) is an :class:`FMUError` naming ``flag``. ``env``: checked against the
    mapping's ``env:``."""
    mapped = mapping_vehicle(fmu_map, env)
    if vehicle is None and mapped is None:
        raise FMUError(
            "vehicle",
            f"the FMU of {fmu_map} needs its vehicle description (masses, suspension, travel): "
            f"give {flag}your_vehicle.yaml or vehicle: in the mapping file (docs/fmi.md); "
            "railgym's own vehicle is never assumed for an FMU",
            full=True,
        )
    if vehicle is not None and mapped is not None and not same_vehicle(vehicle, mapped):
        raise FMUError(
            "vehicle",
            f"{flag}{vehicle} disagrees with the mapping's vehicle: {mapped} ({fmu_map}); give "
            "one of the two",
            full=True,
        )
    return mapped if vehicle is None else vehicle


def same_vehicle(a: Any, b: Any) -> bool:
    """``a`` and ``b`` name the same vehicle: the same file, or the same text."""
    pa, pb = Path(str(a)), Path(str(b))
    if pa.is_file() and pb.is_file():
        return pa.resolve() == pb.resolve()
    return str(a) == str(b)
