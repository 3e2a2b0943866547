"""``modelDescription.xml`` of the FMUs railgym writes for whole models and controllers.

The element FMUs of :mod:`surrogates.fmi` have inputs and outputs only; the reference model
FMUs also have continuous states and their derivatives (model exchange), and may interpolate
their inputs in co-simulation (``canInterpolateInputs``). Value references: the inputs
``0 … n_in−1``, then the outputs, the states and the derivatives, in that order (the layout of
``railgym/fmu/c/model.c``).
"""

from __future__ import annotations

from collections.abc import Sequence
from xml.sax.saxutils import quoteattr

from surrogates.fmi.model_description import Variable, interface_lines

__all__ = ["Variable", "describe"]


def _real(var: Variable, vr: int, causality: str, extra: str, real_extra: str = "") -> str:
    unit = f" unit={quoteattr(var.unit)}" if var.unit else ""
    return (
        f'    <ScalarVariable name={quoteattr(var.name)} valueReference="{vr}" '
        f'causality="{causality}" variability="continuous"{extra} '
        f"description={quoteattr(var.description)}><Real{unit}{real_extra}/></ScalarVariable>"
    )


def describe(
    *,
    model_identifier: str,
    guid: str,
    description: str,
    inputs: Sequence[Variable],
    outputs: Sequence[Variable],
    states: Sequence[Variable] = (),
    kinds: Sequence[str] = ("cs",),
    source_files: Sequence[str] = ("model.c",),
    interpolate_inputs: bool = False,
) -> str:
    """The ``modelDescription.xml`` text (FMI 2.0); ``kinds`` ⊆ ``("me", "cs")``.

    Inputs start at 0; states start at 0 (``initial="exact"``); outputs and derivatives are
    calculated and depend on every input and state.
    """
    derivs = [
        Variable(f"der({s.name})", _der_unit(s.unit), f"time derivative of {s.name}")
        for s in states
    ]
    units = sorted({v.unit for v in (*inputs, *outputs, *states, *derivs) if v.unit})
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="2.0" modelName={quoteattr(model_identifier)} '
        f"guid={quoteattr(guid)} description={quoteattr(description)} "
        'generationTool="railgym railgym.fmu" variableNamingConvention="structured" '
        'numberOfEventIndicators="0">',
    ]
    lines += interface_lines(model_identifier, kinds, source_files, units, interpolate_inputs)
    vr = 0
    for var in inputs:
        lines.append(_real(var, vr, "input", "", ' start="0.0"'))
        vr += 1
    first_out = vr
    for var in outputs:
        lines.append(_real(var, vr, "output", ' initial="calculated"'))
        vr += 1
    first_state = vr
    for var in states:
        lines.append(_real(var, vr, "local", ' initial="exact"', ' start="0.0"'))
        vr += 1
    first_der = vr
    for k, var in enumerate(derivs):
        lines.append(
            _real(var, vr, "local", ' initial="calculated"', f' derivative="{first_state + k + 1}"')
        )
        vr += 1
    lines.append("  </ModelVariables>")
    outs = "".join(f'<Unknown index="{first_out + k + 1}"/>' for k in range(len(outputs)))
    ders = "".join(f'<Unknown index="{first_der + k + 1}"/>' for k in range(len(derivs)))
    deriv_block = f"<Derivatives>{ders}</Derivatives>" if derivs else ""
    lines.append(
        f"  <ModelStructure><Outputs>{outs}</Outputs>{deriv_block}"
        f"<InitialUnknowns>{outs}{ders}</InitialUnknowns></ModelStructure>"
    )
    lines.append("</fmiModelDescription>")
    return "\n".join(lines) + "\n"


def _der_unit(unit: str) -> str:
    """Unit of the time derivative of a quantity in ``unit`` (``""`` when not known)."""
    return {"m": "m/s", "m/s": "m/s2", "Pa": "Pa/s"}.get(unit, "")
