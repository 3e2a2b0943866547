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

from surrogates.fmi.model_description import BASE_UNITS, Variable, interface_lines

__all__ = ["MODEL_BASE_UNITS", "Variable", "describe"]

#: SI base-unit exponents of every unit the model FMUs declare: the element units, angles and
#: the units of the states' time derivatives (``UnitDefinitions`` gives each its base units)
MODEL_BASE_UNITS: dict[str, dict[str, int]] = {
    **BASE_UNITS,
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "Pa/s": {"kg": 1, "m": -1, "s": -3},
}
#: unit of the time derivative of a state in each unit
DERIVATIVE_UNITS = {"m": "m/s", "m/s": "m/s2", "Pa": "Pa/s", "rad": "rad/s", "rad/s": "rad/s2"}


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
    stop_time: float = 1.0,
    step_size: float | None = None,
) -> str:
    """The ``modelDescription.xml`` text (FMI 2.0); ``kinds`` ⊆ ``("me", "cs")``.

    Inputs start at 0; states start at 0 (``initial="exact"``); outputs and derivatives are
    calculated and depend on every input and state. Every unit is declared with its SI base
    units (:data:`MODEL_BASE_UNITS`); the default experiment runs from 0 to ``stop_time`` s
    in steps of ``step_size`` s (when given).

    Raises
    ------
    ValueError
        A variable's unit is not in :data:`MODEL_BASE_UNITS` (or a state's has no
        derivative unit in :data:`DERIVATIVE_UNITS`).
    """
    derivs = [
        Variable(f"der({s.name})", _der_unit(s.unit), f"time derivative of {s.name}")
        for s in states
    ]
    units = _units(inputs, outputs, states, derivs)
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="2.0" modelName={quoteattr(model_identifier)} '
        f"guid={quoteattr(guid)} description={quoteattr(description)} "
        'generationTool="railgym railgym.fmu" variableNamingConvention="structured" '
        'numberOfEventIndicators="0">',
    ]
    lines += interface_lines(
        model_identifier,
        kinds,
        source_files,
        units,
        interpolate_inputs,
        base_units=MODEL_BASE_UNITS,
        stop_time=stop_time,
        step_size=step_size,
    )
    lines += _variable_lines(inputs, outputs, states, derivs)
    lines.append("</fmiModelDescription>")
    return "\n".join(lines) + "\n"


def _units(*groups: Sequence[Variable]) -> list[str]:
    """The units of the variables in ``groups``, sorted; ``ValueError`` naming the variables
    (of every group but the last, the derivatives) of a unit not in :data:`MODEL_BASE_UNITS`."""
    units = sorted({v.unit for group in groups for v in group if v.unit})
    for u in units:
        if u not in MODEL_BASE_UNITS:
            names = [v.name for group in groups[:-1] for v in group if v.unit == u]
            raise ValueError(
                f"unit {u!r} of {names} has no SI base units: add it to MODEL_BASE_UNITS"
            )
    return units


def _variable_lines(
    inputs: Sequence[Variable],
    outputs: Sequence[Variable],
    states: Sequence[Variable],
    derivs: Sequence[Variable],
) -> list[str]:
    """The ``ScalarVariable`` lines (value references in the order of the arguments), the end
    of ``ModelVariables`` and the ``ModelStructure`` line."""
    lines: list[str] = []
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
    return lines


def _der_unit(unit: str) -> str:
    """Unit of the time derivative of a quantity in ``unit`` (:data:`DERIVATIVE_UNITS`; none
    for none); ``ValueError`` for a unit not there."""
    if not unit:
        return ""
    if unit not in DERIVATIVE_UNITS:
        raise ValueError(f"state unit {unit!r} has no derivative unit: add it to DERIVATIVE_UNITS")
    return DERIVATIVE_UNITS[unit]
