"""Env arguments declared once: a frozen dataclass per env, each field with its default, unit,
limits and description.

An env's arguments are the fields of a :class:`Params` subclass, each made by :func:`param`
(in the spirit of SMT's ``options.declare(name, default, values=, types=, desc=)``)::

    @declared
    class MyParams(Params):
        duration: float = param(20.0, "s", "episode length (truncation)", lo=0.0, lo_open=True,
                                hi=600.0)
        observation: str = param("sensors", "", "observation channels", kind="choice",
                                 values=("sensors", "full"))
        n_steps: int = derived("", "control steps per episode")

        def _derive(self) -> None:              # cross-field checks, derived fields
            self._set("n_steps", round(self.duration / 0.01))

``MyParams(**kwargs)`` checks every field by its declaration (:func:`check_field`; errors name
the field, :mod:`railgym._checks`), stores the checked value (canonical Python types), then
runs :meth:`Params._derive`. The env's keyword arguments are the declared fields
(:meth:`Params.from_kwargs`, :func:`keyword_signature`), kernel constants are filled by field
name (:func:`consts`), the docs table of arguments is generated (:func:`arguments_table`,
``railgym env-tables`` rewrites the marked tables of ``docs/envs/*.md``).
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from importlib import import_module
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import numpy as np

from railgym import _checks as val
from railgym.envs.base import step_grid
from railgym.profile import load_profile
from railgym.track import EPISODE_DURATION, class_parameters

__all__ = [
    "BACKENDS",
    "ENV_BACKENDS",
    "KINDS",
    "REWARD_WEIGHTS",
    "Params",
    "Spec",
    "TrackEnvParams",
    "arguments_table",
    "check_field",
    "check_speed",
    "checked_keywords",
    "consts",
    "declared",
    "derived",
    "keyword_signature",
    "keyword_source",
    "limits",
    "param",
    "specs",
    "update_docs",
]

#: kinds of declared fields and what :func:`check_field` accepts for each
KINDS = {
    "real": "a finite number within [lo, hi] (open ends when lo_open / hi_open)",
    "int": "an integer within [lo, hi]",
    "bool": "True or False",
    "choice": "one of values",
    "interval": "(min, max), each within [lo, hi], min < max",
    "weights": "a mapping of some of the default's keys to numbers in [0, hi]; None = default",
    "object": "anything; check(value, name) when given, else checked where it is used",
}
_SPEC = "railgym.spec"
T = TypeVar("T")
F = TypeVar("F", bound=Callable[..., None])


@dataclass(frozen=True)
class Spec:
    """What one declared field is: unit, description, kind and limits (see :data:`KINDS`)."""

    unit: str = ""
    desc: str = ""
    kind: str = "real"
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    values: tuple[Any, ...] = ()
    optional: bool = False  #: None accepted (the env or ``_derive`` resolves it)
    check: Callable[[Any, str], Any] | None = None  #: custom check of kind "object"
    derived: bool = False  #: computed by ``_derive``, not an argument


def param(
    default: Any,
    unit: str = "",
    desc: str = "",
    *,
    kind: str = "real",
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
    values: tuple[Any, ...] = (),
    optional: bool = False,
    check: Callable[[Any, str], Any] | None = None,
) -> Any:
    """Declare an argument (a dataclass field): ``default``, SI ``unit``, one-line ``desc``
    and how :func:`check_field` checks it (``kind``, limits, ``values``); a mutable default
    (dict, list) is copied for each instance."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {list(KINDS)}, got {kind!r}")
    if kind == "weights":
        values = tuple(default)
    spec = Spec(unit, desc, kind, lo, hi, lo_open, hi_open, values, optional, check)
    if isinstance(default, dict | list):
        return field(default_factory=lambda: type(default)(default), metadata={_SPEC: spec})
    return field(default=default, metadata={_SPEC: spec})


def derived(unit: str = "", desc: str = "") -> Any:
    """Declare a derived field: not an argument, set by :meth:`Params._derive`."""
    spec = Spec(unit, desc, kind="object", derived=True)
    return field(init=False, repr=False, metadata={_SPEC: spec})


def declared(cls: type[T]) -> type[T]:
    """The dataclass decorator of a :class:`Params` subclass (frozen, keyword-only, compared
    by identity: fields may hold arrays)."""
    return dataclass(frozen=True, kw_only=True, eq=False)(cls)


def _fields(cls_or_obj: Any, arguments: bool = True) -> list[dataclasses.Field]:
    out = []
    for f in fields(cls_or_obj):
        spec = f.metadata.get(_SPEC)
        if spec is not None and spec.derived != arguments:
            out.append(f)
    return out


def specs(cls_or_obj: Any, arguments: bool = True) -> dict[str, Spec]:
    """The :class:`Spec` of each argument (``arguments=False``: of each derived field), in
    declaration order."""
    return {f.name: f.metadata[_SPEC] for f in _fields(cls_or_obj, arguments)}


def default(f: dataclasses.Field) -> Any:
    """The declared default of field ``f``."""
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return f.default


def _real(value: Any, name: str, s: Spec) -> float:
    if s.lo == 0.0 and not s.hi_open:  # the messages of val.positive / val.non_negative
        return (val.positive if s.lo_open else val.non_negative)(value, name, s.hi)
    return val.in_range(value, name, s.lo, s.hi, lo_open=s.lo_open, hi_open=s.hi_open)


def _interval(value: Any, name: str, s: Spec) -> tuple[float, float]:
    lo, hi = (_real(b, name, s) for b in val.sequence(value, name, 2))
    if not lo < hi:
        raise val.FieldError(name, f"must be (min, max) with min < max, got {value!r}")
    return lo, hi


def _weights(value: Any, name: str, s: Spec, base: Mapping[str, float]) -> dict[str, float]:
    out = dict(base)
    if value is None:
        return out
    for key, w in val.mapping(value, name).items():
        if key not in base:
            raise val.FieldError(name, f"has unknown key {key!r}; keys: {list(base)}")
        out[key] = val.non_negative(w, f"{name}[{key!r}]", s.hi)
    return out


def check_field(f: dataclasses.Field, value: Any) -> Any:
    """``value`` of the declared field ``f`` checked by its :class:`Spec` and returned in its
    canonical type; :class:`~railgym._checks.FieldError` (or ``FieldTypeError``) naming
    the field otherwise."""
    s: Spec = f.metadata[_SPEC]
    name = f.name
    if value is None and (s.optional or s.kind == "weights"):
        return default(f) if s.kind == "weights" else None
    if s.kind == "real":
        return _real(value, name, s)
    if s.kind == "int":
        lo, hi = (None if b is None else int(b) for b in (s.lo, s.hi))
        return val.integer(value, name, lo, hi)
    if s.kind == "bool":
        return val.boolean(value, name)
    if s.kind == "choice":
        return val.choice(value, name, s.values)
    if s.kind == "interval":
        return _interval(value, name, s)
    if s.kind == "weights":
        return _weights(value, name, s, default(f))
    return value if s.check is None else s.check(value, name)


@dataclass(frozen=True, kw_only=True, eq=False)
class Params:
    """Base of the declared env arguments: ``cls(**kwargs)`` checks and stores every field."""

    def __post_init__(self) -> None:
        for f in _fields(self):
            self._set(f.name, check_field(f, getattr(self, f.name)))
        self._derive()

    def _set(self, name: str, value: Any) -> None:
        """Store a checked or derived value (the instance is frozen to everyone else)."""
        object.__setattr__(self, name, value)

    def _derive(self) -> None:
        """Cross-field checks and the derived fields (:func:`derived`); nothing by default."""

    @classmethod
    def from_kwargs(cls: type[T], kwargs: Mapping[str, Any]) -> T:
        """The params of an env's keyword arguments; an unknown name is a ``TypeError``
        listing the arguments."""
        _refuse_unknown(cls, kwargs, set(specs(cls)))
        return cls(**kwargs)

    @classmethod
    def arguments_from(cls, values: Mapping[str, Any]) -> dict[str, Any]:
        """The declared arguments among ``values`` by name (an env constructor's
        ``locals()``, whose keyword-only parameters are the declared fields)."""
        return {name: values[name] for name in specs(cls)}

    @classmethod
    def check(cls, name: str, value: Any) -> Any:
        """``value`` checked as the declared argument ``name`` (e.g. a reset option)."""
        by_name = {f.name: f for f in _fields(cls)}
        return check_field(by_name[name], value)

    def arguments(self) -> dict[str, Any]:
        """The checked arguments by name (derived fields left out)."""
        return {name: getattr(self, name) for name in specs(self)}


def consts(cls: Callable[..., T], source: Any, **extra: Any) -> T:
    """Kernel constants ``cls`` (a NamedTuple) filled by field name: each from ``extra``, else
    the attribute of that name of ``source`` (a :class:`Params`); a field found in neither is
    a ``TypeError`` naming it."""
    values = {}
    for name in cls._fields:  # type: ignore[attr-defined]
        if name in extra:
            values[name] = extra.pop(name)
        elif hasattr(source, name):
            values[name] = getattr(source, name)
        else:
            raise TypeError(f"{cls.__name__}.{name} is neither given nor a field of the params")
    if extra:
        raise TypeError(f"{cls.__name__} has no field(s) {sorted(extra)}")
    return cls(**values)


def _refuse_unknown(cls: type, kwargs: Mapping[str, Any], names: set[str]) -> None:
    unknown = sorted(set(kwargs) - names)
    if unknown:
        raise TypeError(f"unknown argument(s) {unknown}; arguments: {list(specs(cls))}")


def _annotation(f: dataclasses.Field) -> str:
    """The declared type of ``f``, ``| None`` added where ``None`` is accepted."""
    s: Spec = f.metadata[_SPEC]
    none = (s.optional or s.kind == "weights") and str(f.type) != "Any"
    none = none and "None" not in str(f.type)
    return f"{f.type} | None" if none else str(f.type)


def keyword_signature(cls: type, *first: inspect.Parameter) -> inspect.Signature:
    """Signature of an env constructor taking ``first`` and then the fields of ``cls`` as
    keyword-only arguments with their declared types and defaults: what the written-out
    constructors must be (``tests/envs/test_params.py`` compares them)."""
    kw = inspect.Parameter.KEYWORD_ONLY
    rest = [
        inspect.Parameter(f.name, kw, default=default(f), annotation=_annotation(f))
        for f in _fields(cls)
    ]
    return inspect.Signature([*first, *rest])


def keyword_source(cls: type, names: Mapping[str, str] | None = None) -> str:
    """The keyword-only parameters of :func:`keyword_signature` as source lines, to paste
    into a constructor after ``*,``; ``names`` maps a field to the constant written as its
    default (a mutable default, e.g. ``{"reward_weights": "REWARD_WEIGHTS"}``)."""
    names = names or {}
    lines = []
    for f in _fields(cls):
        value = names.get(f.name, repr(default(f)).replace("'", '"'))
        lines.append(f"        {f.name}: {_annotation(f)} = {value},")
    return "\n".join(lines)


def checked_keywords(cls: type) -> Callable[[F], F]:
    """Decorator of an env constructor whose keyword-only parameters are the fields of
    ``cls``: an unknown keyword is the ``TypeError`` of :meth:`Params.from_kwargs` (it lists
    the arguments), not Python's; the constructor's own signature is kept
    (``inspect.signature``, type checkers)."""

    def decorate(init: F) -> F:
        names = set(inspect.signature(init).parameters)

        @functools.wraps(init)
        def checked(*args: Any, **kwargs: Any) -> None:
            _refuse_unknown(cls, kwargs, names)
            init(*args, **kwargs)

        return checked  # type: ignore[return-value]

    return decorate


def limits(cls: type) -> dict[str, Any]:
    """The declared bounds by field name: the upper bound ``hi`` of a real, integer or
    weights field, ``(lo, hi)`` of an interval field; fields without an upper bound are left
    out."""
    out: dict[str, Any] = {}
    for name, s in specs(cls).items():
        if s.kind == "interval":
            out[name] = (s.lo, s.hi)
        elif s.hi is not None:
            out[name] = s.hi
    return out


# --- docs -------------------------------------------------------------------------------------


def _num(x: float) -> str:
    if float(x).is_integer() and abs(x) < 1e5:
        return str(int(x))
    return re.sub(r"e\+?(-?)0*(\d)", r"e\1\2", f"{x:.4g}")


def _literal(value: Any) -> str:
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_literal(k)}: {_literal(v)}" for k, v in value.items()) + "}"
    if isinstance(value, tuple):
        return "(" + ", ".join(_literal(v) for v in value) + ")"
    return repr(value)


def _bounds(s: Spec) -> str:
    left = "(" if s.lo_open or s.lo is None else "["
    right = ")" if s.hi_open or s.hi is None else "]"
    lo = "-inf" if s.lo is None else _num(s.lo)
    hi = "inf" if s.hi is None else _num(s.hi)
    return f"{left}{lo}, {hi}{right}"


def limit_text(s: Spec) -> str:
    """The limits of a declaration in words (the docs table's)."""
    if s.kind in ("real", "int") and s.lo is not None and s.lo == s.hi:
        return f"exactly {_num(s.lo)}"
    if s.kind in ("real", "int") and s.hi is None and s.lo is not None:
        return f"{'>' if s.lo_open else '≥'} {_num(s.lo)}"
    if s.kind in ("real", "int") and (s.lo is not None or s.hi is not None):
        return f"in {_bounds(s)}"
    if s.kind == "choice":
        return "one of " + ", ".join(f"`{_literal(v)}`" for v in s.values)
    if s.kind == "interval":
        return f"each in {_bounds(s)}, min < max"
    if s.kind == "weights":
        keys = ", ".join(f"`{k}`" for k in s.values)
        return f"keys {keys}, each in [0, {_num(s.hi)}]" if s.hi is not None else f"keys {keys}"
    return ""


def arguments_table(cls: type) -> str:
    """The markdown table of the arguments of ``cls``: name, default, unit, meaning (the
    description, ``None`` accepted, the limits)."""
    rows = ["| argument | default | unit | meaning |", "|---|---|---|---|"]
    for f in _fields(cls):
        s: Spec = f.metadata[_SPEC]
        meaning = s.desc
        extra = limit_text(s)
        if extra:
            meaning = f"{meaning}; {extra}" if meaning else extra
        unit = s.unit or "–"
        rows.append(f"| `{f.name}` | `{_literal(default(f))}` | {unit} | {meaning} |")
    return "\n".join(rows)


#: ``<!-- arguments: module:Class -->`` … ``<!-- end arguments -->`` around a generated table
MARKER = re.compile(r"(<!-- arguments: ([\w.]+):(\w+) -->\n)(.*?)(<!-- end arguments -->)", re.S)


def update_docs(path: Path, write: bool = False) -> list[str]:
    """The classes whose marked table in ``path`` differs from :func:`arguments_table`;
    ``write``: rewrite those tables."""
    text = path.read_text(encoding="utf-8")
    stale = []

    def table(m: re.Match) -> str:
        cls = getattr(import_module(m.group(2)), m.group(3))
        new = arguments_table(cls) + "\n"
        if m.group(4) != new:
            stale.append(f"{m.group(2)}:{m.group(3)}")
        return m.group(1) + new + m.group(5)

    new_text = MARKER.sub(table, text)
    if write and stale:
        path.write_text(new_text, encoding="utf-8")
    return stale


# --- the shared base of the track envs --------------------------------------------------------

#: backend → kernel variant of the secondary suspension (the one-bogie and whole-vehicle kernels)
BACKENDS = {"surrogate": "surrogate", "reference": "dynamic", "linear": "linear"}
#: backends of the track envs: also "fmu", an FMU as the whole vehicle (railgym.fmu; its state
#: layout is the dynamic variant's)
ENV_BACKENDS = {**BACKENDS, "fmu": "dynamic"}
#: slowest speed of an episode, m/s: slower, the FRA track of long wavelengths needs too many
#: samples
SPEED_MIN = 1.0
#: ``speed`` at most this × the class's maximum speed unless ``speed_limit`` is given
SPEED_FACTOR = 2.0
#: default weights of the reward terms of the track envs
REWARD_WEIGHTS = {"acceleration": 1.0, "deflection": 1.0, "force": 0.1}


def check_speed(speed: Any, field: str = "speed") -> float:
    """A speed in m/s, at least :data:`SPEED_MIN`."""
    v = val.positive(speed, field)
    if v < SPEED_MIN:
        raise val.FieldError(
            field, f"must be at least {SPEED_MIN:g} m/s (the env's lowest speed), got {speed!r}"
        )
    return v


def _track_class(value: Any, name: str) -> int:
    class_parameters(value)  # raises ValueError naming track_class
    return int(value)


def _profile(value: Any, name: str) -> tuple[np.ndarray, np.ndarray] | None:
    return load_profile(value)


@dataclass(frozen=True, kw_only=True, eq=False)
class TrackEnvParams(Params):
    """Arguments shared by the envs of a vehicle on a track (``VerticalSuspension``,
    ``VerticalVehicle``). A subclass declares its own fields and defines :attr:`OBSERVATIONS`,
    :meth:`_default_dt` and :meth:`_load_vehicle`; ``dt=None`` becomes :meth:`_default_dt`,
    ``profile`` holds the checked ``(x, z)`` arrays (m)."""

    #: observation name → (channels, scale of each in SI units; None = the free travel)
    OBSERVATIONS: ClassVar[dict[str, tuple[tuple[str, ...], tuple[float | None, ...]]]] = {}

    backend: str = param(
        "surrogate",
        "",
        "secondary suspension: surrogate element, reference model, linear, or an FMU as the "
        "vehicle (`fmu`, `fmu_map`)",
        kind="choice",
        values=tuple(ENV_BACKENDS),
    )
    surrogate: Any = param(
        None,
        "",
        'LPR or Kriging model, JSON path, or `None` (packaged element); backend `"surrogate"` only',
        kind="object",
    )
    track_class: int = param(5, "", "FRA track class 1–6", kind="object", check=_track_class)
    speed: Any = param(
        None,
        "m/s",
        "`None` = the class's maximum passenger speed (class 5: 144 km/h); at least "
        f"{SPEED_MIN:g} m/s, at most `speed_limit`",
        kind="object",
        optional=True,
        check=check_speed,
    )
    speed_limit: float | None = param(
        None,
        "m/s",
        f"`None` = {SPEED_FACTOR:g} × the class's maximum speed",
        lo=0.0,
        lo_open=True,
        optional=True,
    )
    profile: Any = param(
        None,
        "m",
        "`None` (seeded FRA track), a CSV path (columns x, z) or `(x, z)`; must cover "
        "speed × duration",
        kind="object",
        check=_profile,
    )
    duration: float = param(
        EPISODE_DURATION,
        "s",
        "episode length (truncation), a whole multiple of `control_dt`",
        lo=0.0,
        lo_open=True,
        hi=600.0,
    )
    control_dt: float = param(
        0.01, "s", "agent step, a whole multiple of `dt`", lo=0.0, lo_open=True
    )
    dt: float | None = param(
        None,
        "s",
        "integration step, at most `control_dt`; `None` = the kernel's `DEFAULT_DT` (1 ms; "
        "whole vehicle 2 ms)",
        lo=0.0,
        lo_open=True,
        optional=True,
    )
    f_max: float = param(8000.0, "N", "actuator force at action ±1", lo=0.0, lo_open=True, hi=1e6)
    observation: str = param(
        "sensors", "", "observation channels", kind="choice", values=("sensors", "full")
    )
    sensor_noise: float = param(
        0.0, "1", "std of the additive noise on the normalised observation", lo=0.0, hi=10.0
    )
    reward_weights: dict[str, float] = param(
        REWARD_WEIGHTS,
        "1",
        "weights of the reward terms; `None` or missing keys: the default",
        kind="weights",
        hi=1e6,
    )
    band: tuple[float, float] = param(
        (1.0, 100.0),
        "m",
        "wavelength band of the track irregularity",
        kind="interval",
        lo=0.1,
        hi=1000.0,
    )
    vehicle: Any = param(
        None,
        "",
        "vehicle YAML: name in `configs/vehicles/` or path; `None`: the packaged vehicle, and "
        'with backend `"fmu"` the mapping\'s `vehicle:` (one of the two is required there)',
        kind="object",
        optional=True,
    )
    fmu: Any = param(
        None, "", 'FMU file (default the mapping\'s `fmu:`); backend `"fmu"` only', kind="object"
    )
    fmu_map: Any = param(
        None, "", 'mapping file of the FMU (docs/fmi.md); backend `"fmu"` only', kind="object"
    )

    variant: str = derived("", "kernel variant of the backend (:data:`ENV_BACKENDS`)")
    n_sub: int = derived("1", "integration steps per control step")
    n_steps: int = derived("1", "control steps per episode")
    model: Any = derived("", "the loaded vehicle of `vehicle`")
    free_travel: float = derived(
        "m", "deflection scale: the free travel in compression (vehicle.deflection_scale)"
    )
    obs_names: tuple[str, ...] = derived("", "observation channels")
    obs_scale: np.ndarray = derived("SI", "scale of each observation channel")

    def _default_dt(self) -> float:
        """Integration step of ``dt=None``, s."""
        raise NotImplementedError

    def _load_vehicle(self) -> tuple[Any, float]:
        """The vehicle of ``self.vehicle`` and its deflection scale, m."""
        raise NotImplementedError

    #: the packaged vehicle of ``vehicle=None`` (built-in backends)
    DEFAULT_VEHICLE: ClassVar[str] = "manchester"
    #: the ``env:`` of this env's FMU mapping files (:mod:`railgym.fmu.mapping`)
    FMU_ENV: ClassVar[str] = "vertical"

    def _vehicle_of_backend(self) -> Any:
        """``vehicle``, else the packaged one; with backend ``"fmu"`` the user's model must be
        described (``vehicle=`` or the mapping's ``vehicle:``): no default is taken for it."""
        if self.backend != "fmu":
            return self.DEFAULT_VEHICLE if self.vehicle is None else self.vehicle
        from railgym.fmu.mapping import fmu_vehicle

        return fmu_vehicle(self.fmu_map, self.vehicle, "vehicle=", self.FMU_ENV)

    def _derive(self) -> None:
        if self.backend != "fmu":
            for name in ("fmu", "fmu_map"):
                if getattr(self, name) is not None:
                    raise val.FieldError(
                        name, f"is only used with backend='fmu', not {self.backend!r}"
                    )
        elif self.fmu_map is None:
            raise val.FieldError("fmu_map", "is required with backend='fmu' (docs/fmi.md)")
        given = self.vehicle
        self._set("vehicle", self._vehicle_of_backend())
        self._set("variant", ENV_BACKENDS[self.backend])
        if self.dt is None:
            self._set("dt", self._default_dt())
        n_sub, n_steps = step_grid(self.dt, self.control_dt, self.duration)
        self._set("n_sub", n_sub)
        self._set("n_steps", n_steps)
        model, free_travel = self._load_vehicle()
        if self.backend != "fmu":
            try:
                getattr(model, "suspension", model).require_variant(self.variant)
            except val.FieldError as exc:
                raise val.FieldError(
                    "vehicle", f"{self.vehicle!r}: {exc} (backend={self.backend!r})"
                ) from None
        if self.backend == "surrogate" and self.surrogate is not None:
            from railgym.vehicles.element_vehicle import check_element_vehicle

            check_element_vehicle(self.surrogate, given, model, self.DEFAULT_VEHICLE, self.FMU_ENV)
        self._set("model", model)
        self._set("free_travel", free_travel)
        names, scales = self.OBSERVATIONS[self.observation]
        self._set("obs_names", names)
        self._set("obs_scale", np.array([free_travel if s is None else s for s in scales]))

    @property
    def weights(self) -> tuple[float, ...]:
        """The reward weights in declared key order."""
        return tuple(self.reward_weights.values())


if __name__ == "__main__":
    from surrogates.cli_flags import moved_command

    raise SystemExit(moved_command("railgym.envs.params", "railgym env-tables"))
