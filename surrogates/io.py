"""Persistence of fitted surrogates (JSON, no pickle) and reading training data from CSV.

File layout (``schema_version`` 1)::

    {"schema_version": 1, "format": "surrogates-model",
     "model": {"kind", "params", "domain", "state"},
     "features": {"inputs": [...], "output": "...", "units": {...}},
     "metadata": {...}}
"""

from __future__ import annotations

import csv
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from surrogates.models import SurrogateModel, model_class

SCHEMA_VERSION = 1
FORMAT = "surrogates-model"


def model_to_document(
    model: SurrogateModel,
    inputs: Sequence[str] | None = None,
    output: str | None = None,
    units: dict[str, str] | None = None,
    metadata: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The JSON document :func:`save` writes."""
    d = model.to_dict()
    n_in = len(d["domain"]["lower"])
    inputs = list(inputs) if inputs is not None else [f"u{i + 1}" for i in range(n_in)]
    if len(inputs) != n_in:
        raise ValueError(f"inputs names {len(inputs)} features, the model has {n_in}")
    return {
        "schema_version": SCHEMA_VERSION,
        "format": FORMAT,
        "model": d,
        "features": {"inputs": inputs, "output": output or "v", "units": dict(units or {})},
        "metadata": dict(metadata or {}),
    }


def model_from_document(doc: Any, source: str = "document") -> SurrogateModel:
    """Rebuild a model from a document; ``metadata_`` and ``features_`` are attached to it."""
    if not isinstance(doc, dict):
        raise ValueError(f"{source}: expected a JSON object at the top level")
    if doc.get("format") != FORMAT:
        raise ValueError(f"{source}: field 'format' must be {FORMAT!r}, got {doc.get('format')!r}")
    if "schema_version" not in doc:
        raise ValueError(f"{source}: missing field 'schema_version'")
    if doc["schema_version"] != SCHEMA_VERSION:
        raise ValueError(
            f"{source}: schema_version {doc['schema_version']!r} is not supported "
            f"(this version reads {SCHEMA_VERSION})"
        )
    for key in ("model", "features"):
        if key not in doc:
            raise ValueError(f"{source}: missing field {key!r}")
    md = doc["model"]
    if not isinstance(md, dict) or "kind" not in md:
        raise ValueError(f"{source}: missing field 'model.kind'")
    try:
        model = model_class(md["kind"]).from_dict(md)
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{source}: invalid 'model' field: {exc}") from exc
    model.features_ = doc["features"]
    model.metadata_ = doc.get("metadata", {})
    return model


def save(model: SurrogateModel, path: str | Path, **document: Any) -> Path:
    """Write ``model`` as JSON to ``path``; keyword arguments as in :func:`model_to_document`."""
    path = Path(path)
    path.write_text(json.dumps(model_to_document(model, **document), indent=1) + "\n")
    return path


def load(path: str | Path) -> SurrogateModel:
    """Read a model written by :func:`save`; clear ``ValueError`` for bad or foreign files."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not valid JSON ({exc})") from exc
    return model_from_document(doc, source=str(path))


def read_csv(path: str | Path, columns: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """Read named numeric columns of a CSV file with a header row.

    Returns ``{name: float array}`` for ``columns`` (all columns if ``None``). Raises
    ``ValueError`` naming the column for a missing column, a non-numeric or non-finite
    value (with its line number), or a row with a different number of fields.
    """
    path = Path(path)
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        try:
            header = [h.strip() for h in next(reader)]
        except StopIteration:
            raise ValueError(f"{path}: empty file, expected a header row") from None
        wanted = list(columns) if columns is not None else header
        missing = [c for c in wanted if c not in header]
        if missing:
            raise ValueError(f"{path}: missing column(s) {missing}; the header has {header}")
        pos = [header.index(c) for c in wanted]
        data: list[list[float]] = [[] for _ in wanted]
        for lineno, row in enumerate(reader, start=2):
            if not row or all(not f.strip() for f in row):
                continue
            if len(row) != len(header):
                raise ValueError(
                    f"{path}: line {lineno} has {len(row)} fields, the header has {len(header)}"
                )
            for j, (name, p) in enumerate(zip(wanted, pos, strict=True)):
                try:
                    val = float(row[p])
                except ValueError:
                    raise ValueError(
                        f"{path}: column {name!r} line {lineno}: {row[p]!r} is not a number"
                    ) from None
                if not np.isfinite(val):
                    raise ValueError(f"{path}: column {name!r} line {lineno}: value is {val}")
                data[j].append(val)
    if not data or not data[0]:
        raise ValueError(f"{path}: no data rows")
    return {name: np.asarray(col) for name, col in zip(wanted, data, strict=True)}


# readers of LS-DYNA output and multibody tables, re-exported as part of this module's API
from surrogates.lsdyna import read_glstat, read_legend, read_nodout, read_rcforc  # noqa: E402, F401
from surrogates.tables import read_table  # noqa: E402, F401
