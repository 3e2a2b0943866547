"""Names and units of a surrogate element's inputs and output.

The checks :func:`surrogates.build` and ``surrogates build`` share: input names and an
output name (:func:`element_names`), and units (:func:`check_units`): a known unit string
(:data:`KNOWN_UNITS`) for every input and the output, or none. In :func:`surrogates.build`
the units are labels: an element keeps the units of its data (an env that needs SI refuses
an element in mm); ``surrogates build`` converts its table to SI first
(:func:`surrogates.tables.to_si`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from surrogates.tables import UNITS as _TABLE_UNITS

#: unit strings an element's inputs and output may carry: the units the data readers know
#: (:data:`surrogates.tables.UNITS`), the element units the FMU export declares and ``m^2``
#: (the product input ``δ·ζ`` of a ``"maxwell_product"`` element)
KNOWN_UNITS: frozenset[str] = frozenset(
    {u for u in _TABLE_UNITS if u} | {"N/m", "N.s/m", "J", "m^2"}
)


def default_names(n_inputs: int) -> tuple[list[str], str]:
    """The names of an element saved without any: ``u1 … ud`` and ``"v"``."""
    return [f"u{i + 1}" for i in range(n_inputs)], "v"


def element_names(
    n_inputs: int, inputs: Sequence[str] | None, output: str | None
) -> tuple[list[str], str]:
    """Checked input names (``n_inputs`` distinct non-empty strings) and output name (a
    non-empty string that is no input name); ``None`` gives :func:`default_names`.

    Raises ``ValueError`` naming ``inputs`` or ``output``.
    """
    names, out = default_names(n_inputs)
    if inputs is not None:
        if isinstance(inputs, str) or not all(isinstance(x, str) and x for x in inputs):
            raise ValueError(f"inputs must be a list of non-empty names, got {inputs!r}")
        names = list(inputs)
        if len(names) != n_inputs:
            raise ValueError(f"inputs names {len(names)} inputs, the data has {n_inputs}")
        dups = sorted({x for x in names if names.count(x) > 1})
        if dups:
            raise ValueError(f"inputs names {dups} more than once")
    if output is not None:
        if not (isinstance(output, str) and output):
            raise ValueError(f"output must be a non-empty name, got {output!r}")
        out = output
    if out in names:
        raise ValueError(f"output {out!r} is also an input name")
    return names, out


def example(names: Sequence[str], units: Mapping[str, str], cli: bool) -> str:
    """``--units a=m b=UNIT`` (``cli``) or ``units={'a': 'm', 'b': 'UNIT'}`` for ``names``,
    with ``UNIT`` where ``units`` has none."""
    full = {n: units.get(n, "UNIT") for n in names}
    if cli:
        return "--units " + " ".join(f"{n}={u}" for n, u in full.items())
    return f"units={full!r}"


def check_units(
    units: Mapping[str, Any] | None,
    inputs: Sequence[str],
    output: str,
    flag: str = "units",
    cli: bool = False,
) -> dict[str, str]:
    """The units of an element: a known unit (:data:`KNOWN_UNITS`) for every input and the
    output, or none (``{}``).

    Raises ``ValueError`` naming ``flag`` and the names: a name that is no input or output,
    a unit that is not a known unit string, or units for some names only (the message names
    the missing ones and shows the full ``flag``, ``--units …`` when ``cli``).
    """
    if units is None:
        return {}
    if not isinstance(units, Mapping):
        raise ValueError(f"{flag} must map names to unit strings, got {units!r}")
    names = [*inputs, output]
    unknown = [n for n in units if n not in names]
    if unknown:
        raise ValueError(
            f"{flag} names {unknown}, not among the inputs {list(inputs)} and the output {output!r}"
        )
    for name, unit in units.items():
        if not isinstance(unit, str) or unit not in KNOWN_UNITS:
            raise ValueError(
                f"{flag}: unit {unit!r} of {name!r} is not a known unit; known units: "
                f"{sorted(KNOWN_UNITS)}"
            )
    missing = [n for n in names if n not in units]
    if units and missing:
        raise ValueError(
            f"{flag}: no unit for {missing} (given for {[n for n in names if n in units]}); "
            f"give a unit for every input and the output, e.g. "
            f"{example(names, units, cli)}, or none"
        )
    return {n: units[n] for n in names if n in units}
