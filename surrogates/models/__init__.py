"""Surrogate models: one per file under the common base class ``SurrogateModel``."""

from __future__ import annotations

import importlib
from typing import Any

from surrogates.models.base import EXTRAPOLATION_POLICIES, SurrogateModel

_LAZY = {
    "LegendreRegression": "surrogates.models.lpr",
    "Kriging": "surrogates.models.kriging",
    "PassiveLegendreRegression": "surrogates.passive",
}

__all__ = ["EXTRAPOLATION_POLICIES", "SurrogateModel", *_LAZY]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'surrogates.models' has no attribute {name!r}")


def model_class(kind: str) -> type[SurrogateModel]:
    """Return the model class registered under ``kind`` (``"lpr"``, ``"lpr_passive"`` or
    ``"kriging"``)."""
    names = {
        "lpr": "LegendreRegression",
        "lpr_passive": "PassiveLegendreRegression",
        "kriging": "Kriging",
    }
    if kind not in names:
        raise ValueError(f"unknown model kind {kind!r}; expected one of {sorted(names)}")
    return __getattr__(names[kind])
