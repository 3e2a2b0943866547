"""surrogates — build data-driven surrogate elements (Legendre regression, Kriging).

The four stages of the method each have a module: :mod:`surrogates.features`,
:mod:`surrogates.sampling`, :mod:`surrogates.models`, :mod:`surrogates.selection`; plus
:mod:`surrogates.metrics` and :mod:`surrogates.io`. Needs neither gymnasium nor torch.

Names are imported lazily so that ``import surrogates`` stays cheap.
"""

from __future__ import annotations

import importlib
from typing import Any

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
    if name == "__version__":  # of the distribution ``railgym``, which ships this package
        from importlib.metadata import PackageNotFoundError, version

        try:
            return version("railgym")
        except PackageNotFoundError:  # a source tree on ``sys.path``, not installed
            return "0+unknown"
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    if name in _SUBMODULES:
        return importlib.import_module(f"surrogates.{name}")
    raise AttributeError(f"module 'surrogates' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__, "__version__"])
