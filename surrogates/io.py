"""Persistence of fitted surrogates (JSON, no pickle) and reading training data from CSV.

File layout (``schema_version`` 2)::

    {"schema_version": 2, "format": "surrogates-model",
     "model": {"kind", "params", "domain", "state"},
     "features": {"inputs": [...], "output": "...", "units": {...},
                  "form": "static" | "maxwell" | "maxwell_product", "tau": null | s,
                  "known_physics": [...]},
     "metadata": {...}}

``form``, ``tau`` and ``known_physics`` are the element's feature form
(:mod:`surrogates.memory`); version 1 files (without them) load as the static form. An
element with a nonlinear relaxation law adds ``"relaxation": {"zeta": [m], "rate": [m/s]}``
to ``features`` and is written as ``schema_version`` 3 (so that a reader of version 2, which
would ignore the law, refuses it); the others are still written as version 2.
"""

from __future__ import annotations

import csv
import io as _io
import json
import math
import os
import re
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from surrogates.memory import element_form, law_document
from surrogates.models import SurrogateModel, model_class
from surrogates.models.checks import ModelFieldError

SCHEMA_VERSION = 2
#: schema version of a file whose element has a relaxation law (``features.relaxation``)
RELAXATION_VERSION = 3
#: schema versions this module reads
READABLE_VERSIONS = (1, 2, 3)
FORMAT = "surrogates-model"


def model_to_document(
    model: SurrogateModel,
    inputs: Sequence[str] | None = None,
    output: str | None = None,
    units: dict[str, str] | None = None,
    metadata: dict[str, Any] | None = None,
    form: str | None = None,
    tau: float | None = None,
    known_physics: Sequence[str] | None = None,
    relaxation: Any = None,
) -> dict[str, Any]:
    """The JSON document :func:`save` writes; ``form``, ``tau`` (s), ``known_physics`` and
    ``relaxation`` (a law ``(zeta, rate)`` or its mapping) as in
    :func:`surrogates.memory.element_form`.

    An argument left ``None`` keeps what the model read from its file (``features_`` and
    ``metadata_`` of :func:`load`), so ``save(load(f))`` writes the element of ``f``; a model
    without them gets ``u1 … ud``, ``"v"``, no units and the static form. ``metadata`` is
    converted to plain JSON (:func:`json_metadata`: numpy arrays to lists, numpy scalars to
    numbers); a value JSON cannot hold is a ``ValueError`` naming its key.
    """
    d = model.to_dict()
    n_in = len(d["domain"]["lower"])
    read = getattr(model, "features_", None) or {}
    if form is None:
        form = read.get("form", "static")
        tau = read.get("tau") if tau is None else tau
        known_physics = read.get("known_physics", []) if known_physics is None else known_physics
        relaxation = read.get("relaxation") if relaxation is None else relaxation
    if inputs is None:
        inputs = read.get("inputs") or [f"u{i + 1}" for i in range(n_in)]
    inputs = list(inputs)
    if len(inputs) != n_in:
        raise ValueError(f"inputs names {len(inputs)} features, the model has {n_in}")
    extra = {k: v for k, v in read.items() if k == "descriptions"}
    shape = {"form": form, "tau": tau, "known_physics": list(known_physics or ())}
    if relaxation is not None:
        shape["relaxation"] = relaxation
    law = element_form(shape, n_in, "features").relaxation
    if law is not None:
        shape["relaxation"] = law_document(law)
    if metadata is None:
        metadata = getattr(model, "metadata_", None)
    return {
        "schema_version": SCHEMA_VERSION if law is None else RELAXATION_VERSION,
        "format": FORMAT,
        "model": d,
        "features": {
            "inputs": inputs,
            "output": output or read.get("output") or "v",
            "units": dict(units if units is not None else read.get("units") or {}),
            **shape,
            **extra,
        },
        "metadata": json_metadata(dict(metadata or {})),
    }


def json_metadata(value: Any, field: str = "metadata") -> Any:
    """``value`` as plain JSON data: mappings with string keys, lists (from lists, tuples and
    numpy arrays), finite numbers (numpy scalars as Python numbers), strings, booleans and
    ``None``. Anything else is a ``ValueError`` naming its key path (``metadata['x'][2]``)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    elif isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, Mapping):
        out = {}
        for key, item in value.items():
            if not isinstance(key, str):
                raise ValueError(
                    f"{field}: key {key!r} must be a string (JSON object keys are strings)"
                )
            out[key] = json_metadata(item, f"{field}[{key!r}]")
        return out
    if isinstance(value, list | tuple):
        return [json_metadata(item, f"{field}[{i}]") for i, item in enumerate(value)]
    if value is None or isinstance(value, str | bool | int):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{field} must be a finite number (JSON has no {value}), got {value}")
        return value
    raise ValueError(
        f"{field}: a value of type {type(value).__name__} cannot be saved in the JSON "
        "metadata; give numbers, strings, booleans, None, or lists and mappings of them"
    )


def model_from_document(doc: Any, source: str = "document") -> SurrogateModel:
    """Rebuild a model from a document; ``metadata_`` and ``features_`` are attached to it.

    Raises :class:`~surrogates.models.checks.ModelFieldError` (a ``ValueError``) naming
    ``source`` and the first invalid field.
    """
    if not isinstance(doc, dict):
        raise ModelFieldError(f"{source}: expected a JSON object at the top level")
    if doc.get("format") != FORMAT:
        raise ModelFieldError(
            f"{source}: field 'format' must be {FORMAT!r}, got {doc.get('format')!r}"
        )
    if "schema_version" not in doc:
        raise ModelFieldError(f"{source}: missing field 'schema_version'")
    version = doc["schema_version"]
    if isinstance(version, bool) or version not in READABLE_VERSIONS:
        raise ModelFieldError(
            f"{source}: schema_version {version!r} is not supported "
            f"(this version reads {list(READABLE_VERSIONS)}; a newer file needs a newer "
            "surrogates)"
        )
    for key in ("model", "features"):
        if key not in doc:
            raise ModelFieldError(f"{source}: missing field {key!r}")
    md = doc["model"]
    if not isinstance(md, dict) or "kind" not in md:
        raise ModelFieldError(f"{source}: missing field 'model.kind'")
    try:
        if not isinstance(md["kind"], str):
            raise ModelFieldError(f"model.kind must be a string, got {md['kind']!r}")
        model = model_class(md["kind"]).from_dict(md)
    except ValueError as exc:
        raise ModelFieldError(f"{source}: invalid 'model' field: {exc}") from None
    model.features_ = _check_features(doc["features"], model.n_features_in_, source)
    if model.features_.get("relaxation") is not None and version < RELAXATION_VERSION:
        raise ModelFieldError(
            f"{source}: field 'features.relaxation' needs schema_version {RELAXATION_VERSION}, "
            f"the file has {version}"
        )
    metadata = doc.get("metadata", {})
    if not isinstance(metadata, dict):
        raise ModelFieldError(f"{source}: field 'metadata' must be a JSON object")
    model.metadata_ = metadata
    return model


def _check_features(feat: Any, n_in: int, source: str) -> dict[str, Any]:
    """The ``features`` block: ``inputs`` (n_in names), ``output`` (a name), ``units``."""
    if not isinstance(feat, dict):
        raise ModelFieldError(f"{source}: field 'features' must be a JSON object")
    inputs = feat.get("inputs")
    if (
        not isinstance(inputs, list)
        or len(inputs) != n_in
        or not all(isinstance(x, str) for x in inputs)
    ):
        raise ModelFieldError(
            f"{source}: field 'features.inputs' must list {n_in} input names, got {inputs!r}"
        )
    if not isinstance(feat.get("output"), str):
        raise ModelFieldError(f"{source}: field 'features.output' must be a name (string)")
    units = feat.get("units", {})
    if not isinstance(units, dict) or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in units.items()
    ):
        raise ModelFieldError(f"{source}: field 'features.units' must map names to unit strings")
    shape = element_form(feat, n_in, source)
    return {
        **feat,
        "form": shape.form,
        "tau": shape.tau,
        "known_physics": list(shape.known_physics),
    }


def save(
    model: SurrogateModel, path: str | Path, *, overwrite: bool = True, **document: Any
) -> Path:
    """Write ``model`` as JSON to ``path``; keyword arguments as in :func:`model_to_document`.

    The file is written to a temporary file in the same folder and renamed over ``path``
    (atomic: a reader never sees a half-written model). ``overwrite=False`` raises
    :class:`FileExistsError` when ``path`` exists; the default ``True`` replaces it (the
    command line's ``surrogates build -o`` asks for ``--overwrite`` instead).
    """
    path = Path(path)
    text = json.dumps(model_to_document(model, **document), indent=1, allow_nan=False) + "\n"
    if not overwrite and path.exists():
        raise FileExistsError(f"{path}: exists; pass overwrite=True to replace it")
    write_atomic(path, text)
    return path


def new_file_mode() -> int:
    """Permission bits of a newly created file under the process umask, ``0o666 & ~umask``
    (what ``open(path, "w")`` gives; ``tempfile.mkstemp`` makes 0o600 instead)."""
    try:  # Linux: read it without changing it
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


def write_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename;
    the file gets the permission bits of the umask, as a plain write would."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.chmod(tmp, new_file_mode())
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


#: largest model file :func:`load` reads, bytes
MAX_FILE_BYTES = 256 * 2**20


def load(path: str | Path) -> SurrogateModel:
    """Read a model written by :func:`save`.

    A bad or foreign file (not UTF-8 JSON, too deeply nested, larger than
    ``MAX_FILE_BYTES``, or any invalid field) raises one
    :class:`~surrogates.models.checks.ModelFieldError` (a ``ValueError``) naming the file.
    """
    path = Path(path)
    if path.stat().st_size > MAX_FILE_BYTES:
        raise ModelFieldError(f"{path}: larger than {MAX_FILE_BYTES} bytes, not a model file")
    try:
        doc = json.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise ModelFieldError(
            f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start})"
        ) from None
    except ValueError as exc:  # JSONDecodeError, or an integer too long to convert
        raise ModelFieldError(f"{path}: not valid JSON ({exc})") from None
    except RecursionError:
        raise ModelFieldError(f"{path}: JSON nested too deeply to be a model file") from None
    return model_from_document(doc, source=str(path))


def read_csv(path: str | Path, columns: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """Read named numeric columns of a CSV file with a header row.

    Returns ``{name: float array}`` for ``columns`` (all columns if ``None``). A header
    field ``du [m]`` names the column ``du`` (its unit: :func:`read_csv_units`). Raises
    ``ValueError`` naming the column for a missing column, a non-numeric or non-finite
    value (with its line number), or a row with a different number of fields.
    """
    return read_csv_units(path, columns)[0]


#: a header field ``name [unit]``
_NAME_UNIT = re.compile(r"^(.*?\S)\s*\[([^\[\]]*)\]$")


def read_csv_units(
    path: str | Path, columns: Sequence[str] | None = None
) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """:func:`read_csv` and the units written in the header (``du [m]``: column ``du``, unit
    ``"m"``), ``{name: unit}`` of the columns read that have one."""
    path = Path(path)
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ValueError(f"{path}: line {line}: not UTF-8 text ({exc.reason})") from None
    reader = csv.reader(_io.StringIO(text, newline=""))
    try:
        return _read_rows(reader, path, columns)
    except csv.Error as exc:
        raise ValueError(f"{path}: line {reader.line_num}: {exc}") from None


def _read_rows(
    reader: Any, path: Path, columns: Sequence[str] | None
) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    try:
        fields = [h.strip() for h in next(reader)]
    except StopIteration:
        raise ValueError(f"{path}: empty file, expected a header row") from None
    header: list[str] = []
    units: dict[str, str] = {}
    for field in fields:
        match = _NAME_UNIT.match(field)
        header.append(match.group(1) if match else field)
        if match:
            units[match.group(1)] = match.group(2).strip()
    dups = sorted({h for h in header if header.count(h) > 1})
    if dups:
        raise ValueError(f"{path}: line 1: duplicate column name(s) {dups}")
    wanted = list(columns) if columns is not None else header
    missing = [c for c in wanted if c not in header]
    if missing:
        raise ValueError(f"{path}: missing column(s) {missing}; the header has {header}")
    pos = [header.index(c) for c in wanted]
    data: list[list[float]] = [[] for _ in wanted]
    for row in reader:
        lineno = reader.line_num
        if not row or all(not f.strip() for f in row):
            continue
        if len(row) != len(header):
            raise ValueError(
                f"{path}: line {lineno} has {len(row)} fields, the header has {len(header)}"
            )
        for j, (name, p) in enumerate(zip(wanted, pos, strict=True)):
            cell = row[p]
            try:
                val = float(cell) if len(cell) <= 64 else float("x")
            except ValueError:
                shown = cell if len(cell) <= 64 else cell[:20] + f"... ({len(cell)} characters)"
                raise ValueError(
                    f"{path}: column {name!r} line {lineno}: {shown!r} is not a number"
                ) from None
            if not np.isfinite(val):
                raise ValueError(f"{path}: column {name!r} line {lineno}: value is {val}")
            data[j].append(val)
    if not data or not data[0]:
        raise ValueError(f"{path}: no data rows")
    out = {name: np.asarray(col) for name, col in zip(wanted, data, strict=True)}
    return out, {name: units[name] for name in wanted if name in units}


# readers of LS-DYNA output and multibody tables, re-exported as part of this module's API
from surrogates.lsdyna import read_glstat, read_legend, read_nodout, read_rcforc  # noqa: E402, F401
from surrogates.tables import read_table  # noqa: E402, F401
