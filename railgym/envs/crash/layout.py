"""The per-train arrays and the ``info`` keys of ``railgym/TrainCrash-v1``, declared once.

:data:`EPISODE` declares every per-train array of :class:`~railgym.envs.crash.batch.CrashBatch`
(absorber scales, episode statistics, observation, reward, the flat ``info`` row and the
flags) and :data:`INFO_FIELDS` every ``info`` key. Everything else is derived from them: the
:class:`Episode` and :class:`InfoColumns` named tuples the kernels read, the array shapes
(:func:`episode_shapes`), the columns of the flat ``info`` row (:func:`info_layout`), the
values cleared at first contact (:data:`CLEARED`) and the compiled views of the buffer
(:func:`buffer_views`). Adding an episode statistic is one entry here plus its computation in
:mod:`railgym.envs.crash.step` (``docs/architecture.md``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple, get_type_hints

import numpy as np
from numba import njit

__all__ = [
    "CLEARED",
    "COLUMNS",
    "ENV_FIELDS",
    "EPISODE",
    "INFO_FIELDS",
    "REWARD_TERMS",
    "Array",
    "Episode",
    "InfoColumns",
    "InfoKey",
    "buffer_views",
    "episode_shapes",
    "info_layout",
    "named_rebuild",
    "new_episode_arrays",
    "row_clearer",
]

#: the reward terms (``info["reward_terms"]``), summing to the reward
REWARD_TERMS = ("decel", "intrusion", "peak", "divergence")


class Array(NamedTuple):
    """One per-train array of the crash batch.

    Attributes
    ----------
    name : field of :class:`Episode`.
    size : columns per train: ``"1"`` (a 1-D array, one value per train), ``"cars"``,
        ``"zones"`` (controlled zones), ``"model_zones"`` (every zone of the model),
        ``"ring"`` (the moving-average ring), ``"terms"`` (:data:`REWARD_TERMS`), ``"obs"``,
        ``"info"`` (the flat info row).
    unit : SI unit (``"1"``: none). description : one line.
    start : value of a new batch.
    clear : value set at first contact (each reset), or ``None`` where the bookkeeping sets
        it itself.
    dtype : ``"float64"`` (kept in the batch's float buffer), ``"bool"`` or ``"int64"``
        (1-D flags, arrays of their own).
    """

    name: str
    size: str
    unit: str
    description: str
    start: float = 0.0
    clear: float | None = None
    dtype: str = "float64"


#: every per-train array, floats first (their order in the buffer), then the flags
EPISODE: tuple[Array, ...] = (
    Array("scale", "model_zones", "1", "absorber force scale over the step", 1.0, 1.0),
    Array("speed", "1", "m/s", "initial speed"),
    Array("energy0", "1", "J", "stored energy at first contact"),
    Array("payload", "cars", "kg", "payload of each car"),
    Array("peak", "cars", "g", "peak deceleration", clear=0.0),
    Array("decel_sum", "cars", "g", "sum of the step decelerations", clear=0.0),
    Array("max_crush", "zones", "m", "largest crush", clear=0.0),
    Array("intrusion", "zones", "m", "crush beyond the absorber stroke", clear=0.0),
    Array("w_peak", "model_zones", "J", "largest work done on each zone so far"),
    Array("f_peak", "model_zones", "N", "zone force when that work was reached"),
    Array("pulse_t0", "cars", "s", "pulse start, −1 before the onset", clear=-1.0),
    Array("pulse_v0", "cars", "m/s", "velocity at the pulse start", clear=0.0),
    Array("pulse_t1", "cars", "s", "pulse end so far", clear=0.0),
    Array("pulse_v1", "cars", "m/s", "velocity at the pulse end so far", clear=0.0),
    Array("stopped", "cars", "1", "1 once the car's velocity reached zero in its pulse", clear=0.0),
    Array("prev_v", "cars", "m/s", "velocity at the previous step end"),
    Array("prev_a", "cars", "m/s²", "acceleration at the previous step end"),
    Array("ring", "ring", "m/s", "last window_steps + 1 velocities of each car, slot-major"),
    Array("ma_peak", "cars", "g", "moving-average peak deceleration", clear=0.0),
    Array("terms", "terms", "1", "last reward terms", clear=0.0),
    Array("obs", "obs", "1", "observation"),
    Array("reward", "1", "1", "last reward", clear=0.0),
    Array("info", "info", "1", "flat info row (INFO_FIELDS)"),
    Array("div", "1", "1", "diverged", clear=0.0, dtype="bool"),
    Array("over", "1", "1", "crash over", clear=0.0, dtype="bool"),
    Array("steps", "1", "1", "control steps since the reset", clear=0.0, dtype="int64"),
)

#: per-train arrays of :class:`~railgym.envs.crash.batch.CrashBatch`, in :data:`EPISODE` order
Episode = NamedTuple("Episode", [(a.name, np.ndarray) for a in EPISODE])  # type: ignore[misc]
#: the float arrays of :class:`Episode`, kept in the batch's buffer
ENV_FIELDS = tuple(a.name for a in EPISODE if a.dtype == "float64")
#: the 1-D ones among them (the others are 2-D)
COLUMNS = tuple(a.name for a in EPISODE if a.dtype == "float64" and a.size == "1")
#: (name, value) of the arrays set at first contact
CLEARED = tuple((a.name, a.clear) for a in EPISODE if a.clear is not None)
if ENV_FIELDS != Episode._fields[: len(ENV_FIELDS)]:
    raise ImportError("EPISODE must declare its float arrays before the flags")


class InfoKey(NamedTuple):
    """One key of the crash env's ``info``.

    Attributes
    ----------
    name : the key. size : ``"1"`` (a float or bool), ``"cars"`` or ``"zones"`` (an array).
    dtype : ``"float64"`` or ``"bool"``. unit : SI unit (``"1"``: none; ``"g"``:
        standard gravity). description : one line.
    """

    name: str
    size: str
    dtype: str
    unit: str
    description: str


#: the ``info`` keys, in the column order of the flat info row
INFO_FIELDS: tuple[InfoKey, ...] = (
    InfoKey("time", "1", "float64", "s", "simulated time"),
    InfoKey("initial_speed", "1", "float64", "m/s", "this episode's initial speed"),
    InfoKey("payload_kg", "cars", "float64", "kg", "this episode's payload of each car"),
    InfoKey("decel_g", "cars", "float64", "g", "deceleration of each car at the step end"),
    InfoKey("crush_m", "zones", "float64", "m", "zone crush at the step end"),
    InfoKey("force_N", "zones", "float64", "N", "zone force at the step end"),
    InfoKey("absorber_scale", "zones", "float64", "1", "force scale of each absorber"),
    InfoKey("peak_decel_g", "cars", "float64", "g", "largest deceleration so far"),
    InfoKey("mean_decel_g", "cars", "float64", "g", "mean deceleration over all steps"),
    InfoKey("moving_average_peak_g", "cars", "float64", "g", "largest moving-average mean"),
    InfoKey("pulse_mean_decel_g", "cars", "float64", "g", "mean deceleration of the pulse"),
    InfoKey("absorbed_energy_J", "zones", "float64", "J", "net work done on each zone"),
    InfoKey("max_crush_m", "zones", "float64", "m", "largest crush of each zone"),
    InfoKey("intrusion_m", "zones", "float64", "m", "crush beyond the absorber stroke"),
    InfoKey("stroke_used", "zones", "float64", "1", "max_crush_m / absorber stroke"),
    InfoKey("stroke_exceeded", "1", "bool", "1", "some zone crushed beyond its stroke"),
    InfoKey("mean_decel_passed", "cars", "bool", "1", "pulse mean within its limit"),
    InfoKey("peak_decel_passed", "cars", "bool", "1", "peak within its limit"),
    InfoKey("moving_average_passed", "cars", "bool", "1", "moving average within its limit"),
    InfoKey("intrusion_passed", "zones", "bool", "1", "intrusion within its limit"),
    InfoKey("criteria_passed", "1", "bool", "1", "every car and zone within every limit"),
    InfoKey("friction_work_J", "1", "float64", "J", "wheel–rail friction work"),
    InfoKey("energy_error", "1", "float64", "1", "energy check over the initial energy"),
    InfoKey("diverged", "1", "bool", "1", "the state diverged on this step"),
)
#: first column of each ``info`` key in the flat info row (:func:`info_layout`)
InfoColumns = NamedTuple("InfoColumns", [(key.name, int) for key in INFO_FIELDS])  # type: ignore[misc]


def _sizes(n_cars: int, n_zones: int) -> dict[str, int]:
    return {"1": 1, "cars": n_cars, "zones": n_zones}


def info_layout(n_cars: int, n_zones: int) -> dict[str, tuple[slice, bool]]:
    """Columns of each ``info`` key in the flat info row (key → (columns, is_scalar)), from
    :data:`INFO_FIELDS`."""
    sizes = _sizes(n_cars, n_zones)
    out, j = {}, 0
    for key in INFO_FIELDS:
        out[key.name] = (slice(j, j + sizes[key.size]), key.size == "1")
        j += sizes[key.size]
    return out


def episode_shapes(n: int, counts: dict[str, int]) -> dict[str, tuple[int, ...]]:
    """Shape of each array of :data:`EPISODE` for ``n`` trains; ``counts`` gives the columns
    of each size but ``"1"`` (``cars``, ``zones``, ``model_zones``, ``ring``, ``terms``,
    ``obs``, ``info``)."""
    return {a.name: (n,) if a.size == "1" else (n, counts[a.size]) for a in EPISODE}


def new_episode_arrays(n: int, counts: dict[str, int]) -> dict[str, np.ndarray]:
    """The arrays of :data:`EPISODE` for ``n`` trains, at their ``start`` values."""
    shapes = episode_shapes(n, counts)
    return {a.name: np.full(shapes[a.name], a.start, a.dtype) for a in EPISODE}


@njit(cache=True, inline="always")
def _field(buf, fields, f):
    """2-D array ``f`` (rows, columns) of a batch buffer, as a view."""
    o, r, c = fields[f, 0], fields[f, 1], fields[f, 2]
    return buf[o : o + r * c].reshape((r, c))


@njit(cache=True, inline="always")
def _column(buf, fields, f):
    """1-D array ``f`` (rows,) of a batch buffer, as a view."""
    return buf[fields[f, 0] : fields[f, 0] + fields[f, 1]]


def buffer_views(dims: tuple[int, ...]) -> Callable[..., Any]:
    """Compiled ``views(buf, fields, first)``: the tuple of views of arrays ``first``,
    ``first + 1``, … of a batch buffer (see ``CrashBatch._pack``), ``dims[j]`` (1 or 2) the
    dimensions of the ``j``-th; made once per layout, so that no view list is kept by hand."""
    if not dims:

        @njit(inline="always")
        def none(buf, fields, first):
            return ()

        return none
    rest = buffer_views(dims[1:])
    if dims[0] == 1:

        @njit(inline="always")
        def views(buf, fields, first):
            return (_column(buf, fields, first),) + rest(buf, fields, first + 1)

    else:

        @njit(inline="always")
        def views(buf, fields, first):
            return (_field(buf, fields, first),) + rest(buf, fields, first + 1)

    return views


def _is_named_tuple(cls: Any) -> bool:
    return isinstance(cls, type) and issubclass(cls, tuple) and hasattr(cls, "_fields")


def named_rebuild(cls: type) -> Callable[..., Any]:
    """Compiled ``named(t)``: the ``cls`` instance of the plain tuple ``t`` made by
    :func:`~railgym.envs.crash.step.plain` of one, field by field of ``cls`` (nested named
    tuples, found from the field annotations, rebuilt as well)."""
    hints = get_type_hints(cls)
    fields = cls._fields  # type: ignore[attr-defined]

    def items(k: int) -> Callable[..., Any]:
        if k == len(fields):

            @njit(inline="always")
            def none(t):
                return ()

            return none
        rest = items(k + 1)
        sub = hints[fields[k]]
        if _is_named_tuple(sub):
            inner = named_rebuild(sub)

            @njit(inline="always")
            def nested(t):
                return (inner(t[k]),) + rest(t)

            return nested

        @njit(inline="always")
        def item(t):
            return (t[k],) + rest(t)

        return item

    values = items(0)

    @njit(inline="always")
    def named(t):
        return cls(*values(t))

    return named


def row_clearer(cleared: tuple[tuple[str, Any], ...]) -> Callable[..., Any]:
    """Compiled ``clear(episode, i)``: row ``i`` of each named :class:`Episode` array set to its
    value (``cleared``: (name, value) pairs, e.g. :data:`CLEARED`), one generated assignment
    per array."""
    if not cleared:

        @njit(inline="always")
        def none(episode, i):
            return None

        return none
    rest = row_clearer(cleared[1:])
    ((name, value),) = cleared[:1]
    field = Episode._fields.index(name)
    dtype = next(a.dtype for a in EPISODE if a.name == name)
    value = np.dtype(dtype).type(value)

    @njit(inline="always")
    def clear(episode, i):
        episode[field][i] = value
        rest(episode, i)

    return clear
