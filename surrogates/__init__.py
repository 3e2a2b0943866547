"""surrogates — build data-driven surrogate elements (Legendre regression, Kriging).

The four stages of the method each have a module: :mod:`surrogates.features`,
:mod:`surrogates.sampling`, :mod:`surrogates.models`, :mod:`surrogates.selection`; plus
:mod:`surrogates.metrics` and :mod:`surrogates.io`. Needs neither gymnasium nor torch.

Names are imported lazily so that ``import surrogates`` stays cheap.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.3.0"

_LAZY = {
    "LegendreRegression": "surrogates.models.lpr",
    "Kriging": "surrogates.models.kriging",
    "select": "surrogates.sampling",
    "build": "surrogates.builder",
    "BuildReport": "surrogates.builder",
    "TimeHistory": "surrogates.features",
    "ModelFieldError": "surrogates.models.checks",
    "UnderdeterminedFitWarning": "surrogates.models.checks",
}

#: submodules reachable as attributes after a plain ``import surrogates`` (``surrogates.io``)
_SUBMODULES = (
    "builder",
    "checks",
    "features",
    "fmi",
    "io",
    "lsdyna",
    "memory",
    "metrics",
    "models",
    "passive",
    "sampling",
    "selection",
    "tables",
)

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    if name in _SUBMODULES:
        return importlib.import_module(f"surrogates.{name}")
    raise AttributeError(f"module 'surrogates' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(list(globals()) + __all__)
