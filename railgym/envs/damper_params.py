"""The controllable-damper arguments of the track envs (``actuator="semi-active"``), declared
once for ``VerticalSuspension-v1`` and ``VerticalVehicle-v1``.

:class:`DamperArgs` declares ``actuator``, ``damper`` and ``damper_element`` and derives the
loaded damper (``damper_params``, :mod:`railgym.vehicles.semi_active`) and, on the surrogate
backend, its data-driven element (``damper_model``,
:mod:`railgym.vehicles.semi_active_element`); :func:`damper_law_of` is the law the kernels
integrate. Each damper adds its filtered command as an observation channel, last
(:func:`damper_channels`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from railgym import _checks as val
from railgym.envs.base import caller_level
from railgym.envs.params import Params, derived, param
from railgym.vehicles.semi_active import DamperParams, load_damper
from railgym.vehicles.semi_active_element import DamperElement, load_damper_element
from railgym.vehicles.vertical.elements import DamperLaw
from railgym.vehicles.vertical.kernels import damper_law

__all__ = [
    "ACTUATORS",
    "DAMPER_CHANNEL",
    "DEFAULT_DAMPER",
    "DamperArgs",
    "damper_channels",
    "check_element_damper",
    "damper_law_of",
]

#: what the action commands: an actuator force, or a controllable damper
ACTUATORS = ("force", "semi-active")
#: the observation channel of one damper's filtered command (last), with its scale
DAMPER_CHANNEL = ("damper_command", 1.0)
#: the packaged damper of ``damper=`` (``configs/dampers/``)
DEFAULT_DAMPER = "mr_secondary"


def damper_channels(n: int) -> tuple[str, ...]:
    """The observation channels of ``n`` dampers' filtered commands: ``damper_command`` for
    one, ``damper_command_0`` … for more (front first)."""
    name = DAMPER_CHANNEL[0]
    return (name,) if n == 1 else tuple(f"{name}_{i}" for i in range(n))


@dataclass(frozen=True, kw_only=True, eq=False)
class DamperArgs(Params):
    """The damper arguments of a track env; the env's ``_derive`` calls
    :meth:`_derive_damper` with its number of dampers (needs ``backend``, ``obs_names`` and
    ``obs_scale`` of :class:`~railgym.envs.params.TrackEnvParams`)."""

    actuator: str = param(
        "force",
        "",
        '`"force"`: the action is the actuator force / `f_max`, in [−1, 1]; `"semi-active"`: '
        "the command in [0, 1] of the controllable damper `damper` at its place (not with "
        'backend `"fmu"`)',
        kind="choice",
        values=ACTUATORS,
    )
    damper: Any = param(
        DEFAULT_DAMPER,
        "",
        'controllable damper of actuator `"semi-active"`: name in `configs/dampers/` or YAML path',
        kind="object",
    )
    damper_element: Any = param(
        None,
        "",
        'data-driven element of `damper` that backend `"surrogate"` runs: packaged name or '
        "`.json` path (`railgym damper-element`); default: the packaged element of a "
        "packaged `damper`",
        kind="object",
        optional=True,
    )

    damper_params: DamperParams | None = derived(
        "", 'the loaded `damper` (`None` with actuator `"force"`)'
    )
    damper_model: DamperElement | None = derived(
        "",
        'the loaded `damper_element` (`None` unless actuator `"semi-active"` on backend '
        '`"surrogate"`)',
    )

    def _derive_damper(self, n: int) -> None:
        """The damper of ``actuator="semi-active"`` (``damper_params``, ``damper_model``) and
        the observation channels of its ``n`` filtered commands (:func:`damper_channels`);
        ``damper=`` other than the default with ``actuator="force"`` is refused."""
        self._set("damper_model", None)
        if self.actuator == "force":
            if not (isinstance(self.damper, str) and self.damper == DEFAULT_DAMPER):
                raise val.FieldError(
                    "damper", "is only used with actuator='semi-active', not 'force'"
                )
            if self.damper_element is not None:
                raise val.FieldError(
                    "damper_element", "is only used with actuator='semi-active', not 'force'"
                )
            self._set("damper_params", None)
            return
        backend = self.backend  # type: ignore[attr-defined]
        if backend == "fmu":
            raise val.FieldError(
                "actuator", "'semi-active' is not available with backend='fmu'", full=False
            )
        params = load_damper(self.damper)
        self._set("damper_params", params)
        if backend == "surrogate":
            element = _damper_element(self.damper, self.damper_element)
            check_element_damper(element, self.damper, params)
            self._set("damper_model", element)
        elif self.damper_element is not None:
            warnings.warn(
                f"damper_element is ignored by backend={backend!r} (only "
                "backend='surrogate' uses it)",
                UserWarning,
                stacklevel=caller_level(),
            )
        names, scale = self.obs_names, self.obs_scale  # type: ignore[attr-defined]
        self._set("obs_names", (*names, *damper_channels(n)))
        self._set("obs_scale", np.append(scale, np.full(n, DAMPER_CHANNEL[1])))


def damper_law_of(cfg: DamperArgs) -> DamperLaw | None:
    """The controllable damper the kernels integrate (``None``: ``actuator="force"``): its
    element ``cfg.damper_model`` on the surrogate backend, the exact law of
    ``cfg.damper_params`` on the others."""
    if cfg.damper_params is None:
        return None
    return damper_law(cfg.damper_params, cfg.damper_model)


def _damper_element(damper: Any, element: Any) -> DamperElement:
    """The element of ``damper`` for the surrogate backend: ``element`` (packaged name or
    ``.json`` path) or, without one, the packaged element of the packaged ``damper``."""
    if element is None:
        if not (isinstance(damper, str) and _is_packaged_element(damper)):
            raise val.FieldError(
                "damper_element",
                f"damper {str(damper)!r} has no packaged element: give damper_element= (built "
                "by railgym damper-element --damper DAMPER -o ELEMENT.json) or use another "
                "backend",
            )
        return _packaged_element(damper)
    if not isinstance(element, str | Path):
        raise val.FieldTypeError(
            "damper_element", f"must be a packaged name or a .json path, got {element!r}"
        )
    if Path(element).is_dir():
        raise val.FieldError("damper_element", f"{str(element)!r} is a folder, expected a file")
    if str(element).endswith(".json"):
        try:
            return load_damper_element(element)
        except (OSError, ValueError) as exc:
            raise val.FieldError("damper_element", str(exc)) from None
    if not _is_packaged_element(str(element)):
        raise val.FieldError("damper_element", f"no packaged element {str(element)!r}")
    return _packaged_element(str(element))


def check_element_damper(element: DamperElement, damper: Any, params: DamperParams) -> None:
    """Refuse an element built for another damper than ``damper`` (its loaded ``params``):
    the damper the element records (its parameters, or a packaged damper's name) must have
    ``params``; an element that records neither is used with a warning naming both."""
    built = element.report.get("damper_params")
    if isinstance(built, dict) and set(built) == set(DamperParams._fields):
        built_for: DamperParams = DamperParams(**{k: float(v) for k, v in built.items()})
    elif (resources.files("railgym") / "configs" / "dampers" / f"{element.damper}.yaml").is_file():
        built_for = load_damper(element.damper)
    else:
        warnings.warn(
            f"damper_element: built for damper {element.damper!r}, whose parameters it does "
            f"not record; it runs for damper={str(damper)!r} unchecked",
            UserWarning,
            stacklevel=caller_level(),
        )
        return
    if not np.allclose(built_for, params, rtol=1e-9, atol=0.0):
        diff = ", ".join(
            f"{k} {a:g} (given {b:g})"
            for k, a, b in zip(DamperParams._fields, built_for, params, strict=True)
            if not np.isclose(a, b, rtol=1e-9, atol=0.0)
        )
        raise val.FieldError(
            "damper_element",
            f"was built for damper {element.damper!r} ({diff}), not for damper="
            f"{str(damper)!r}: build the element of this damper (python -m "
            "railgym.vehicles.semi_active_element --damper DAMPER --out ELEMENT.json) or use "
            "backend='reference'",
        )


def _is_packaged_element(name: str) -> bool:
    return (resources.files("railgym") / "data" / f"damper_{name}.json").is_file()


@lru_cache(maxsize=2)
def _packaged_element(name: str) -> DamperElement:
    """A packaged damper element, loaded once."""
    return load_damper_element(name)
