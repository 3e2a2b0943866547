"""FMUs of railgym's built-in reference models (FMI 2.0, C), and their mapping files.

:func:`export_reference_fmu` writes the one-bogie vertical reference model
(``VerticalSuspension-v0`` with ``backend="reference"``: the ``"dynamic"`` variant of
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

import yaml

from railgym.fmu.description import Variable, describe
from railgym.vehicles.vertical import DEFAULT_DT, load_vehicle
from surrogates.fmi.export import guid_of, identifier, write_fmu

__all__ = ["ENVS", "KINDS", "export_reference_fmu", "reference_mapping"]

ENVS = ("vertical",)
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
C_FILES = ("model.c", "suspension.h", "vertical_model.h")


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


def reference_mapping(fmu_name: str) -> dict[str, object]:
    """The mapping document (:mod:`railgym.fmu.mapping`) of an exported vertical reference FMU."""
    return {
        "version": 1,
        "fmu": fmu_name,
        "env": "vertical",
        "inputs": {
            "track": [{"displacement": "z", "rate": "zdot"}],
            "actuator_force": ["actuator_force"],
        },
        "outputs": {name: name for name, _, _ in VERTICAL_OUTPUTS},
    }


def export_reference_fmu(
    path: str | Path,
    env: str = "vertical",
    kind: str = "both",
    *,
    vehicle: str = "manchester",
    dt: float | None = None,
    compiler: str | None = None,
    overwrite: bool = False,
) -> tuple[Path, Path]:
    """Write the reference model of ``env`` as an FMU at ``path`` and its mapping file beside
    it (same stem, ``.yaml``); return both paths.

    Parameters
    ----------
    path : the ``.fmu`` file.
    env : ``"vertical"`` (``VerticalSuspension-v0``).
    kind : ``"me"``, ``"cs"`` or ``"both"``.
    vehicle : packaged vehicle name or YAML path (as the env's ``vehicle=``).
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
    params = load_vehicle(vehicle).kernel_params()
    step = DEFAULT_DT["dynamic"] if dt is None else float(dt)
    if not step > 0.0:
        raise ValueError(f"dt must be positive, got {dt!r}")
    doc = {"env": env, "vehicle": str(vehicle), "dt": step, "params": params._asdict()}
    doc_text = json.dumps(doc, indent=1, sort_keys=True)
    guid = guid_of(doc_text + kind)
    ident = identifier(path, None)
    header = "\n".join(
        [
            "/* generated by railgym.fmu.reference: the vertical reference model's constants */",
            f'#define MD_GUID "{guid}"',
            f"#define MD_DT {step!r}",
            c_struct("E", params._asdict()),
            '#include "vertical_model.h"',
            "",
        ]
    )
    kinds = ("me", "cs") if kind == "both" else (kind,)
    xml = describe(
        model_identifier=ident,
        guid=guid,
        description="railgym one-bogie vertical reference model (air spring with reservoir, "
        "Maxwell damper, bump stops), VerticalSuspension-v0 backend='reference'",
        inputs=[Variable(*v) for v in VERTICAL_INPUTS],
        outputs=[Variable(*v) for v in VERTICAL_OUTPUTS],
        states=[Variable(*v) for v in VERTICAL_STATES],
        kinds=kinds,
        source_files=("model.c",),
        interpolate_inputs=True,
    )
    sources = {"model_data.h": header, **{name: _template(name) for name in C_FILES}}
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
    text = (
        "# railgym FMU mapping (docs/fmi.md): which FMU variables the env reads and writes\n"
        + yaml.safe_dump(reference_mapping(path.name), sort_keys=False)
    )
    map_path.write_text(text)
    return path, map_path
