"""FMUs of railgym's built-in reference models (FMI 2.0, C), and their mapping files.

:func:`export_reference_fmu` writes the one-bogie vertical reference model
(``VerticalSuspension-v1`` with ``backend="reference"``: the ``"dynamic"`` variant of
:mod:`railgym.vehicles.vertical`) as a standalone FMU for model exchange and/or
co-simulation, with the mapping file (:mod:`railgym.fmu.mapping`) that makes it the reference
of ``backend="fmu"``. The C laws (``railgym/fmu/c/vertical_model.h``) are those of
:mod:`railgym.vehicles.vertical.elements`; co-simulation integrates with the kernels' RK4 at
the env's step ``dt`` and, given the inputs' time derivatives (``canInterpolateInputs``), feeds
its stages the same cubic Hermite track input as the kernels.
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path
from typing import Any, NamedTuple

import yaml

from railgym import _checks as val
from railgym.fmu.description import Variable, describe
from railgym.track import EPISODE_DURATION
from railgym.vehicles.vehicle.model import DEFAULT_DT as VEHICLE_DT
from railgym.vehicles.vehicle.model import kernel_params as vehicle_params
from railgym.vehicles.vehicle.params import load_whole_vehicle
from railgym.vehicles.vertical.kernels import DEFAULT_DT
from railgym.vehicles.vertical.params import load_vehicle
from surrogates.fmi.export import guid_of, identifier, write_fmu

__all__ = ["ENVS", "KINDS", "export_reference_fmu", "reference_mapping"]

ENVS = ("vertical", "vehicle")
KINDS = ("me", "cs", "both")

#: (name, unit, description) of the vertical model's inputs, outputs and states
VERTICAL_INPUTS = (
    ("z", "m", "track vertical irregularity under the bogie, upwards"),
    ("zdot", "m/s", "its time derivative"),
    ("actuator_force", "N", "actuator force, upwards on the carbody, downwards on the bogie"),
)
VERTICAL_OUTPUTS = (
    ("carbody_acc", "m/s2", "carbody vertical acceleration"),
    ("bogie_acc", "m/s2", "bogie vertical acceleration"),
    ("deflection", "m", "secondary-suspension deflection x1 - x2, compression positive"),
    ("deflection_rate", "m/s", "its time derivative"),
    ("carbody_vel", "m/s", "carbody vertical velocity"),
    ("carbody_disp", "m", "carbody vertical displacement from the static equilibrium"),
    ("secondary_force", "N", "secondary-suspension force (air spring, damper, bump stops)"),
)
VERTICAL_STATES = (
    ("x1", "m", "bogie displacement"),
    ("v1", "m/s", "bogie velocity"),
    ("x2", "m", "carbody displacement"),
    ("v2", "m/s", "carbody velocity"),
    ("dp_bag", "Pa", "air-spring bag pressure minus its static value"),
    ("dp_res", "Pa", "reservoir pressure minus its static value"),
    ("y_damper", "m", "damper internal displacement (Maxwell element)"),
)
_BOGIES = ("front", "rear")
#: the whole vehicle's (VerticalVehicle-v1) inputs, outputs and states
VEHICLE_INPUTS = (
    *(
        v
        for j in range(1, 5)
        for v in (
            (f"z_{j}", "m", f"track height under wheelset {j} (1 front … 4 rear)"),
            (f"zdot_{j}", "m/s", f"its time derivative at wheelset {j}"),
        )
    ),
    *(
        (f"actuator_force_{b}", "N", f"actuator force at the {b} bogie, up on the carbody")
        for b in _BOGIES
    ),
)
VEHICLE_OUTPUTS = (
    *(
        (f"acc_{p}", "m/s2", f"carbody floor acceleration, {p}")
        for p in ("front", "centre", "rear")
    ),
    *((f"bogie_acc_{b}", "m/s2", f"{b} bogie acceleration") for b in _BOGIES),
    *((f"deflection_{b}", "m", f"{b} secondary deflection, compression positive") for b in _BOGIES),
    *((f"deflection_rate_{b}", "m/s", f"its time derivative, {b}") for b in _BOGIES),
    *((f"carbody_vel_{b}", "m/s", f"carbody velocity over the {b} bogie") for b in _BOGIES),
    *((f"secondary_force_{b}", "N", f"{b} secondary-suspension force") for b in _BOGIES),
)
VEHICLE_STATES = (
    ("z_c", "m", "carbody bounce"),
    ("theta_c", "rad", "carbody pitch"),
    ("q", "m", "carbody first bending, centre deflection"),
    ("z_b0", "m", "front bogie bounce"),
    ("theta_b0", "rad", "front bogie pitch"),
    ("z_b1", "m", "rear bogie bounce"),
    ("theta_b1", "rad", "rear bogie pitch"),
    ("v_c", "m/s", "carbody bounce rate"),
    ("omega_c", "rad/s", "carbody pitch rate"),
    ("qdot", "m/s", "bending rate"),
    ("v_b0", "m/s", "front bogie bounce rate"),
    ("omega_b0", "rad/s", "front bogie pitch rate"),
    ("v_b1", "m/s", "rear bogie bounce rate"),
    ("omega_b1", "rad/s", "rear bogie pitch rate"),
    *(
        v
        for i, b in enumerate(_BOGIES)
        for v in (
            (f"dp_bag{i}", "Pa", f"{b} air-spring bag pressure minus its static value"),
            (f"dp_res{i}", "Pa", f"{b} reservoir pressure minus its static value"),
            (f"y_damper{i}", "m", f"{b} damper internal displacement"),
        )
    ),
)
C_FILES = ("model.c", "suspension.h")
#: s, the episode length of both envs (their default ``duration``): the stop time of the FMU's
#: default experiment, whose step is the FMU's RK4 step
EPISODE_S = EPISODE_DURATION


def c_struct(name: str, values: dict[str, float]) -> str:
    """C definition of a constant struct ``name`` of doubles with the fields ``values``."""
    return "\n".join(
        [
            "static const struct {",
            *(f"    double {k};" for k in values),
            f"}} {name} = {{",
            *(f"    {float(v)!r}, /* {k} */" for k, v in values.items()),
            "};",
        ]
    )


def _template(name: str) -> str:
    return (resources.files("railgym.fmu") / "c" / name).read_text()


def reference_mapping(
    fmu_name: str, env: str = "vertical", vehicle: str = "manchester"
) -> dict[str, object]:
    """The mapping document (:mod:`railgym.fmu.mapping`) of an exported reference FMU of
    ``vehicle`` (its description travels in the mapping's ``vehicle:``)."""
    if env == "vertical":
        track = [{"displacement": "z", "rate": "zdot"}]
        forces = ["actuator_force"]
        outputs = VERTICAL_OUTPUTS
    else:
        track = [{"displacement": f"z_{j}", "rate": f"zdot_{j}"} for j in range(1, 5)]
        forces = [f"actuator_force_{b}" for b in _BOGIES]
        outputs = VEHICLE_OUTPUTS
    return {
        "version": 1,
        "fmu": fmu_name,
        "env": env,
        "vehicle": _whole_name(vehicle) if env == "vehicle" else str(vehicle),
        "inputs": {"track": track, "actuator_force": forces},
        "outputs": {name: name for name, _, _ in outputs},
    }


class _ReferenceModel(NamedTuple):
    """What an FMU of one reference model is made of."""

    structs: dict[str, dict[str, float]]  #: C struct name → the kernel's constants
    model_h: str  #: the C header of the model's equations
    default_dt: float  #: the reference backend's RK4 step, s
    variables: tuple[tuple, tuple, tuple]  #: (name, unit, description) of inputs, outputs, states
    description: str  #: of the model, for the model description


def _whole_name(vehicle: str) -> str:
    """The whole-vehicle description of ``vehicle=`` (``manchester``: ``manchester_whole``)."""
    return "manchester_whole" if vehicle == "manchester" else str(vehicle)


def _require(suspension: Any, what: str, vehicle: str) -> None:
    """A FieldError naming the first section of the dynamic reference model (damper, air
    spring) that ``suspension`` lacks: the FMU's C constants would be undefined."""
    try:
        suspension.require(("damper", "air_spring"), what)
    except val.FieldError as exc:
        raise val.FieldError(exc.field, f"vehicle {str(vehicle)!r}: {exc}", full=True) from None


def _reference_model(env: str, vehicle: str, flexible: bool) -> _ReferenceModel:
    """The reference model of ``env`` (``vehicle``, ``flexible`` as the env's)."""
    what = "the reference FMU (export-reference-fmu)"
    if env == "vertical":
        veh = load_vehicle(vehicle)
        _require(veh, what, vehicle)
        elem = veh.kernel_params()._asdict()
        return _ReferenceModel(
            {"E": elem},
            "vertical_model.h",
            DEFAULT_DT["dynamic"],
            (VERTICAL_INPUTS, VERTICAL_OUTPUTS, VERTICAL_STATES),
            "railgym one-bogie vertical reference model (air spring with reservoir, Maxwell "
            "damper, bump stops), VerticalSuspension-v1 backend='reference'",
        )
    whole = load_whole_vehicle(_whole_name(vehicle))
    _require(whole.suspension, what, vehicle)
    return _ReferenceModel(
        {
            "E": whole.suspension.kernel_params()._asdict(),
            "V": vehicle_params(whole, flexible)._asdict(),
        },
        "vehicle_model.h",
        VEHICLE_DT,
        (VEHICLE_INPUTS, VEHICLE_OUTPUTS, VEHICLE_STATES),
        "railgym whole-vehicle vertical reference model (carbody bounce, pitch, bending; "
        "two bogies, four wheelsets; dynamic secondary suspension), VerticalVehicle-v1 "
        f"backend='reference', flexible={flexible}",
    )


def _data_header(
    env: str, guid: str, step: float, structs: dict[str, dict[str, float]], model_h: str
) -> str:
    """Text of the generated ``model_data.h``: GUID, RK4 step and the model's constants."""
    return "\n".join(
        [
            f"/* generated by railgym.fmu.reference: the {env} reference model's constants */",
            f'#define MD_GUID "{guid}"',
            f"#define MD_DT {step!r}",
            *(c_struct(name, values) for name, values in structs.items()),
            f'#include "{model_h}"',
            "",
        ]
    )


def _mapped(vehicle: str, map_path: Path) -> str:
    """``vehicle`` as the mapping file beside ``map_path`` names it: a YAML file by its
    absolute path, a packaged name as it is."""
    local = Path(vehicle)
    return (
        str(local.resolve()) if local.suffix in (".yaml", ".yml") and local.is_file() else vehicle
    )


def export_reference_fmu(
    path: str | Path,
    env: str = "vertical",
    kind: str = "both",
    *,
    vehicle: str = "manchester",
    flexible: bool = True,
    dt: float | None = None,
    compiler: str | None = None,
    overwrite: bool = False,
) -> tuple[Path, Path]:
    """Write the reference model of ``env`` as an FMU at ``path`` and its mapping file beside
    it (same stem, ``.yaml``); return both paths. The FMU's default experiment is one episode
    of the env (:data:`EPISODE_S`) at its RK4 step; every unit it declares has its SI base
    units.

    Parameters
    ----------
    path : the ``.fmu`` file.
    env : ``"vertical"`` (``VerticalSuspension-v1``) or ``"vehicle"`` (``VerticalVehicle-v1``).
    kind : ``"me"``, ``"cs"`` or ``"both"``.
    vehicle : packaged vehicle name or YAML path (as the env's ``vehicle=``; for
        ``"vehicle"`` the default is ``manchester_whole``).
    flexible : ``"vehicle"``: with the carbody's bending mode (as the env's ``flexible=``).
    dt : RK4 step of the co-simulation, s (default: the reference backend's).
    compiler : the C compiler (default ``$CC``, ``cc`` or ``gcc``).
    overwrite : replace existing files.
    """
    if env not in ENVS:
        raise ValueError(f"env must be one of {ENVS}, got {env!r}")
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    path = Path(path)
    map_path = path.with_suffix(".yaml")
    for p in (path, map_path):
        if p.exists() and not overwrite:
            raise FileExistsError(f"{p} exists; pass overwrite=True (--overwrite) to replace it")
    structs, model_h, default_dt, variables, what = _reference_model(env, vehicle, flexible)
    step = default_dt if dt is None else float(dt)
    if not step > 0.0:
        raise ValueError(f"dt must be positive, got {dt!r}")
    doc = {"env": env, "vehicle": str(vehicle), "dt": step, "params": structs}
    doc_text = json.dumps(doc, indent=1, sort_keys=True)
    guid = guid_of(doc_text + kind)
    ident = identifier(path, None)
    header = _data_header(env, guid, step, structs, model_h)
    kinds = ("me", "cs") if kind == "both" else (kind,)
    xml = describe(
        model_identifier=ident,
        guid=guid,
        description=what,
        inputs=[Variable(*v) for v in variables[0]],
        outputs=[Variable(*v) for v in variables[1]],
        states=[Variable(*v) for v in variables[2]],
        kinds=kinds,
        source_files=("model.c",),
        interpolate_inputs=True,
        stop_time=EPISODE_S,
        step_size=step,
    )
    files = (*C_FILES, model_h)
    sources = {"model_data.h": header, **{name: _template(name) for name in files}}
    write_fmu(
        path,
        ident,
        xml,
        sources,
        {"reference.json": doc_text + "\n"},
        ("model.c",),
        binary=True,
        compiler=compiler,
    )
    map_path.write_text(
        "# railgym FMU mapping (docs/fmi.md): which FMU variables the env reads and writes\n"
        + yaml.safe_dump(
            reference_mapping(path.name, env, _mapped(vehicle, map_path)), sort_keys=False
        )
    )
    return path, map_path
