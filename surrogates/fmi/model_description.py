"""``modelDescription.xml`` of an exported surrogate element (FMI 2.0).

One ``Real`` input per feature (value references ``0 … d−1``, continuous, start value the
centre of the training box) and ``Real`` outputs from value reference ``d`` on (the element
force first; continuous, ``initial="calculated"``, each depending on every input). Names follow the
``flat`` naming convention restricted to C identifiers (:func:`fmi_names`); the original
feature name, its training range and unit go into the description. Units are declared in
``UnitDefinitions``, with SI base-unit exponents for the common mechanical units.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

#: SI base-unit exponents (kg, m, s) of the units the elements commonly use
BASE_UNITS: dict[str, dict[str, int]] = {
    "m": {"m": 1},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "m/s^2": {"m": 1, "s": -2},
    "s": {"s": 1},
    "kg": {"kg": 1},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N/m": {"kg": 1, "s": -2},
    "N.s/m": {"kg": 1, "s": -1},
    "Pa": {"kg": 1, "m": -1, "s": -2},
    "J": {"kg": 1, "m": 2, "s": -2},
    "rad": {},
    "1": {},
}


@dataclass(frozen=True)
class Variable:
    """One FMI variable: its name, unit (``""`` for none) and description."""

    name: str
    unit: str
    description: str


def fmi_names(names: Sequence[str]) -> list[str]:
    """FMI-valid (C identifier) and unique variable names for the feature names ``names``.

    Characters outside ``[A-Za-z0-9_]`` become ``_``, a leading digit gets a ``_`` prefix, and
    repeated results get a ``_2``, ``_3`` … suffix: ``"x1-x2"`` → ``"x1_x2"``.
    """
    out: list[str] = []
    for name in names:
        base = re.sub(r"[^A-Za-z0-9_]", "_", str(name)) or "_"
        if base[0].isdigit():
            base = "_" + base
        cand, k = base, 2
        while cand in out:
            cand, k = f"{base}_{k}", k + 1
        out.append(cand)
    return out


def interface_lines(
    model_identifier: str,
    kinds: Sequence[str],
    source_files: Sequence[str],
    units: Sequence[str],
    interpolate_inputs: bool = False,
    *,
    base_units: Mapping[str, Mapping[str, int]] = BASE_UNITS,
    stop_time: float = 1.0,
    step_size: float | None = None,
) -> list[str]:
    """Lines of ``modelDescription.xml`` from the ``ModelExchange`` / ``CoSimulation``
    elements (``kinds`` ⊆ ``("me", "cs")``) through ``UnitDefinitions`` (the SI exponents of
    each unit from ``base_units``; a unit not there is declared without them),
    ``LogCategories`` and ``DefaultExperiment`` (from 0 to ``stop_time`` s, in steps of
    ``step_size`` s when given) to the opening ``ModelVariables`` tag."""
    lines: list[str] = []
    files = "".join(f"<File name={quoteattr(f)}/>" for f in source_files)
    common = (
        f'modelIdentifier={quoteattr(model_identifier)} canGetAndSetFMUstate="false" '
        'canSerializeFMUstate="false" providesDirectionalDerivative="false" '
        'canNotUseMemoryManagementFunctions="true"'
    )
    if "me" in kinds:
        lines.append(
            f'  <ModelExchange {common} completedIntegratorStepNotNeeded="true">'
            f"<SourceFiles>{files}</SourceFiles></ModelExchange>"
        )
    if "cs" in kinds:
        interp = ' canInterpolateInputs="true"' if interpolate_inputs else ""
        lines.append(
            f'  <CoSimulation {common} canHandleVariableCommunicationStepSize="true"{interp}>'
            f"<SourceFiles>{files}</SourceFiles></CoSimulation>"
        )
    if units:
        lines.append("  <UnitDefinitions>")
        for u in units:
            base = base_units.get(u)
            if base is None:
                lines.append(f"    <Unit name={quoteattr(u)}/>")
            else:
                exps = "".join(f' {k}="{e}"' for k, e in base.items())
                lines.append(f"    <Unit name={quoteattr(u)}><BaseUnit{exps}/></Unit>")
        lines.append("  </UnitDefinitions>")
    lines.append('  <LogCategories><Category name="logStatusError"/></LogCategories>')
    step = "" if step_size is None else f' stepSize="{float(step_size)!r}"'
    lines.append(f'  <DefaultExperiment startTime="0.0" stopTime="{float(stop_time)!r}"{step}/>')
    lines.append("  <ModelVariables>")
    return lines


def model_description(
    *,
    model_identifier: str,
    guid: str,
    description: str,
    inputs: Sequence[Variable],
    outputs: Sequence[Variable],
    starts: Sequence[float],
    kinds: Sequence[str],
    source_files: Sequence[str],
) -> str:
    """The ``modelDescription.xml`` text; ``kinds`` ⊆ ``("me", "cs")``."""
    units = sorted({v.unit for v in (*inputs, *outputs) if v.unit})
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="2.0" modelName={quoteattr(model_identifier)} '
        f"guid={quoteattr(guid)} description={quoteattr(description)} "
        'generationTool="railgym surrogates.fmi" variableNamingConvention="flat" '
        'numberOfEventIndicators="0">',
    ]
    lines += interface_lines(model_identifier, kinds, source_files, units)
    for vr, (var, start) in enumerate(zip(inputs, starts, strict=True)):
        unit = f" unit={quoteattr(var.unit)}" if var.unit else ""
        lines.append(
            f'    <ScalarVariable name={quoteattr(var.name)} valueReference="{vr}" '
            f'causality="input" variability="continuous" '
            f'description={quoteattr(var.description)}><Real start="{start!r}"{unit}/>'
            "</ScalarVariable>"
        )
    for k, out in enumerate(outputs):
        unit = f" unit={quoteattr(out.unit)}" if out.unit else ""
        lines.append(
            f"    <ScalarVariable name={quoteattr(out.name)} "
            f'valueReference="{len(inputs) + k}" causality="output" variability="continuous" '
            f'initial="calculated" description={quoteattr(out.description)}><Real{unit}/>'
            "</ScalarVariable>"
        )
    lines.append("  </ModelVariables>")
    deps = " ".join(str(i + 1) for i in range(len(inputs)))
    unknowns = "".join(
        f'<Unknown index="{len(inputs) + k + 1}" dependencies="{deps}"/>'
        for k in range(len(outputs))
    )
    lines.append(
        f"  <ModelStructure><Outputs>{unknowns}</Outputs>"
        f"<InitialUnknowns>{unknowns}</InitialUnknowns></ModelStructure>"
    )
    lines.append("</fmiModelDescription>")
    return "\n".join(lines) + "\n"
