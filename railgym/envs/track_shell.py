"""The shell the envs of a vehicle on a track share (``VerticalSuspension``,
``VerticalVehicle``): the track reset options and case (:class:`TrackEnvShell`,
:class:`TrackVectorShell`), the speed limit, the surrogate element's kernel arrays and checks
(:func:`element_arrays`), and the batch limits and reward weighting of the track batches."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from railgym import _checks as val
from railgym.comfort import WeightingFilter
from railgym.envs.base import BatchEnv, BatchVectorEnv, caller_level
from railgym.envs.params import SPEED_FACTOR, TrackEnvParams
from railgym.track import class_speed
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.element_envelope import OperatingEnvelope, element_envelope
from railgym.vehicles.element_plausibility import implausible_element_warning
from railgym.vehicles.vertical.elements import LprArrays
from railgym.vehicles.vertical.kernels import surrogate_arrays
from surrogates import io

__all__ = [
    "ACC_WEIGHTINGS",
    "ELEMENT_OUTPUT_UNIT",
    "ELEMENT_UNITS",
    "MAX_NUM_ENVS",
    "TRACK_BYTES",
    "TrackEnvShell",
    "TrackVectorShell",
    "check_element_vehicle",
    "check_speed_limit",
    "element_arrays",
    "reward_sections",
    "track_window",
]

#: frequency weightings of the reward's acceleration term (ISO 2631-1), ``"none"``: raw
ACC_WEIGHTINGS = ("none", "Wk")


#: most sub-envs of the vector env
MAX_NUM_ENVS = 65536
#: largest track arrays of all sub-envs together, bytes
TRACK_BYTES = 2**30
#: share of :data:`TRACK_BYTES` that the track windows of a chunked batch take, together with
#: the arrays its caller counts in ``chunk_bytes`` of :func:`track_window` (the rest is left to
#: the batch's other per-env arrays)
WINDOW_SHARE = 0.75


def track_window(
    n: int,
    n_samples: int,
    fixed_bytes: int,
    min_samples: int,
    what: str,
    forced: int | None = None,
    chunk_bytes: int | None = None,
) -> int | None:
    """Track samples each of ``n`` sub-envs holds at once: ``None`` when all ``n_samples``
    of an episode fit (16 bytes each, plus ``fixed_bytes`` per env that grow with the
    episode, within :data:`TRACK_BYTES` together), else the length of a window (chunked
    mode: the windows and ``chunk_bytes`` per env, the arrays a chunked batch holds besides
    its windows (default ``fixed_bytes``), take :data:`WINDOW_SHARE` of the limit).
    ``forced`` (tests): a window of that many samples whenever it is shorter than the
    episode. FieldError naming ``num_envs`` when even a window of ``min_samples`` does not
    fit (``what`` names the arrays in the message)."""
    if forced is not None:
        return max(forced, min_samples) if max(forced, min_samples) < n_samples else None
    if n * (16 * n_samples + fixed_bytes) <= TRACK_BYTES:
        return None
    per_env = fixed_bytes if chunk_bytes is None else chunk_bytes
    window = int((WINDOW_SHARE * TRACK_BYTES - n * per_env) // (16 * n))
    if window < min_samples:
        need = n * (16 * min_samples + per_env)
        raise val.FieldError(
            "num_envs",
            f"of {n} needs {need / 2**30:.2f} GiB of {what} even with the tracks held in "
            f"windows of {min_samples} samples ({n_samples} samples per episode); chunked, they "
            f"may take {WINDOW_SHARE * TRACK_BYTES / 2**30:.2f} GiB ({WINDOW_SHARE:.0%} of the "
            f"{TRACK_BYTES / 2**30:g} GiB limit): use fewer sub-envs or a shorter duration",
        )
    return window


def reward_sections(acc_weighting: str, control_dt: float) -> np.ndarray:
    """Second-order sections (n_sec, 6) of the reward's acceleration weighting at the control
    rate ``1/control_dt`` (Hz): ISO 2631-1 Wk for ``"Wk"``; none, shape (0, 6), for ``"none"``
    (:func:`~railgym.envs.compiled.weigh` then returns its input unchanged)."""
    if acc_weighting == "none":
        return np.zeros((0, 6))
    return WeightingFilter(1.0 / control_dt, acc_weighting, lowpass=False).sos


def check_speed_limit(v: float, track_class: int, speed: Any, speed_limit: float | None) -> None:
    """FieldError naming ``speed`` when the speed ``v`` (m/s, of the argument ``speed``) is above
    ``speed_limit`` (m/s, default :data:`~railgym.envs.params.SPEED_FACTOR` × the class's
    maximum speed)."""
    limit = SPEED_FACTOR * class_speed(track_class) if speed_limit is None else speed_limit
    if v > limit:
        raise val.FieldError(
            "speed",
            f"must be at most {limit:.4g} m/s (2 × the class-{int(track_class)} maximum unless "
            f"speed_limit= is given), got {speed!r} m/s (speed= is in m/s: "
            f"{v * 3.6:.4g} km/h)",
        )


def element_arrays(
    backend: str,
    surrogate: Any,
    dt: float,
    kriging: bool = False,
    relaxation: bool = False,
    vehicle: Any = None,
    grid: bool = False,
) -> tuple[LprArrays, OperatingEnvelope | None]:
    """Kernel arrays of the surrogate element (packaged default, a JSON path or a model) and
    its operating envelope (``metadata.envelope``,
    :mod:`railgym.vehicles.element_envelope`; ``None`` without one or for another backend).

    ``surrogate=`` for a backend that does not use it gives a ``UserWarning`` (it is ignored);
    a model whose inputs do not match its feature form (static: δ, δ̇; maxwell: δ, δ̇, δ − s)
    or whose ``τ`` is below ``dt/2`` (s) is rejected, and so is a Kriging unless ``kriging``
    is set (the one-bogie kernels evaluate it), and so is a relaxation law unless
    ``relaxation`` is set (the whole vehicle's kernels integrate it), and so is a malformed
    envelope. With ``vehicle`` (the user gave the element), one ``UserWarning`` when the
    element does not look like that vehicle's secondary suspension
    (:mod:`railgym.vehicles.element_plausibility`). The warnings name the user's line
    (:func:`~railgym.envs.base.caller_level`). ``grid``: an additive LPR element is
    evaluated by its Hermite tables inside the box
    (:func:`~railgym.vehicles.vertical.kernels.surrogate_arrays`).
    """
    given = surrogate
    if backend != "surrogate":
        if surrogate is not None:
            warnings.warn(
                f"surrogate is ignored by backend={backend!r} (only backend='surrogate' uses it)",
                UserWarning,
                stacklevel=caller_level(),
            )
        return surrogate_arrays(None), None
    if surrogate is None:
        surrogate = default_vertical_surrogate()
    elif isinstance(surrogate, str | Path):
        try:
            surrogate = io.load(surrogate)
        except (OSError, ValueError) as exc:
            raise val.FieldError(
                "surrogate", f"cannot be loaded from {str(surrogate)!r}: {exc}"
            ) from None
    if not hasattr(surrogate, "kernel_arrays"):
        raise val.FieldTypeError(
            "surrogate",
            "must be a Legendre regression or a Kriging (it runs inside the compiled kernel); "
            f"got {type(surrogate).__name__}",
        )
    try:
        lpr = surrogate_arrays(surrogate, dt, kriging, relaxation, grid)
    except ValueError as exc:
        raise val.FieldError("surrogate", str(exc), full=True) from None
    try:
        envelope = element_envelope(surrogate)
    except ValueError as exc:
        raise val.FieldError("surrogate", str(exc)) from None
    _check_element_units(surrogate, lpr.lo.shape[0])
    if vehicle is not None:
        _check_element_plausibility(surrogate, vehicle, given)
    return lpr, envelope


def _check_element_plausibility(model: Any, vehicle: Any, given: Any) -> None:
    """One ``UserWarning`` when the element ``model`` (the argument ``given``: a path or the
    model) does not look like the secondary suspension of ``vehicle``
    (:func:`~railgym.vehicles.element_plausibility.implausible_element_warning`); an object
    without ``predict`` and ``domain_`` (kernel arrays only) is not measured."""
    if not (hasattr(model, "predict") and hasattr(model, "domain_")):
        return
    if isinstance(given, str | Path):
        name = repr(str(given))
    else:
        source = (getattr(model, "metadata_", None) or {}).get("source")
        name = f"({type(model).__name__}{f', {source}' if source else ''})"
    text = implausible_element_warning(model, vehicle, name)
    if text is not None:
        warnings.warn(text, UserWarning, stacklevel=caller_level())


#: units of the suspension element's inputs (deflection, its rate, Maxwell state) and output
ELEMENT_UNITS = ("m", "m/s", "m", "m^2")
ELEMENT_OUTPUT_UNIT = "N"


def unnamed(inputs: list[str], output: Any, units: dict[str, Any]) -> bool:
    """Whether the features are those ``surrogates.io.save`` writes for a model without
    names: inputs ``u1 … ud``, output ``v``, no units."""
    return inputs == [f"u{i + 1}" for i in range(len(inputs))] and output == "v" and not units


def _check_element_units(surrogate: Any, d: int) -> None:
    """A model with named inputs (``features_``: read from a file, or from
    ``surrogates.build(..., inputs=, units=)``) must give the units the kernel assumes:
    deflection m, velocity m/s (and the Maxwell state m, the product input δ·ζ m^2) in,
    force N out; an element fitted on
    another problem, or in mm or kN, is refused (the error names the fix). A model without
    names (fitted by ``surrogates.build(U, V)``) carries no units and is taken as SI, in
    memory and after ``surrogates.io.save`` → ``load`` alike (the file holds the placeholder
    names ``u1 … ud``, ``v`` and no units: :func:`unnamed`)."""
    features = getattr(surrogate, "features_", None) or {}
    units, names = features.get("units") or {}, list(features.get("inputs") or [])
    output = features.get("output")
    if len(names) != d or unnamed(names, output, units):
        return
    wanted = [*zip(names[:d], ELEMENT_UNITS[:d], strict=True), (output, ELEMENT_OUTPUT_UNIT)]
    for name, unit in wanted:
        got = units.get(name)
        if got == unit:
            continue
        found = "no unit" if got is None else f"unit {got!r}"
        takes = (
            f"the suspension element takes {', '.join(f'{n!r} in {u}' for n, u in wanted[:-1])}"
            f" and gives {output!r} in {ELEMENT_OUTPUT_UNIT}"
        )
        if got is None:
            si = dict(wanted)
            fix = (
                f"build it with units (`surrogates build DATA.csv --inputs {' '.join(names)} "
                f"--target {output} --units {' '.join(f'{n}={u}' for n, u in wanted)} ...` or "
                f"`surrogates.build(U, V, ..., inputs={names!r}, output={output!r}, "
                f"units={si!r})`), save it with them (`surrogates.io.save(model, path, "
                f"units={si!r})`) or set model.features_['units'] = {si!r}"
            )
        else:
            fix = (
                "convert the data to those units and build the element again (a unit is a "
                "label: changing it does not rescale the fit)"
            )
        raise val.FieldError(
            "surrogate",
            f"{'output' if name == output else 'input'} {name!r} has {found} in "
            f"features.units; {takes}: {fix}",
        )


def check_element_vehicle(backend: str, lpr: LprArrays, vehicle: Any) -> None:
    """A surrogate element that adds the vehicle's bump-stop law (known physics) needs a
    vehicle with bump stops: refused otherwise, naming ``surrogate``."""
    suspension = getattr(vehicle, "suspension", vehicle)
    if backend == "surrogate" and lpr.bump and suspension.bump_stop is None:
        raise val.FieldError(
            "surrogate",
            f"the element adds the vehicle's bump-stop law (features.known_physics), but "
            f"vehicle {suspension.name!r} has no bump_stop section: use an element built "
            "for this vehicle (railgym collect --vehicle ...)",
        )


class TrackEnvShell(BatchEnv):
    """What the single envs of a vehicle on a track share (``VerticalSuspension``,
    ``VerticalVehicle``): the declared arguments (:attr:`params_class`, checked into
    :attr:`cfg`), the packaged element by default, the spaces, the track reset options and
    the case they set (``info["case"]``: ``track_class``, ``speed`` in m/s, ``profile``: a
    measured or user profile, not FRA track)."""

    #: the declared arguments of the env
    params_class: type[TrackEnvParams]
    #: actuators, the length of the action
    n_actuators: int
    #: packaged element used without ``surrogate=``, ``(form, release)`` of
    #: :func:`~railgym.vehicles.collect.default_vertical_surrogate`; ``None``: the current
    #: memory element (the versions: docs, *Version history*)
    default_element: tuple[str, str] | None = None
    #: an additive LPR element evaluated by its Hermite tables inside the box
    #: (:mod:`surrogates.models.lpr_grid`; the versions: docs, *Version history*)
    element_grid: bool = False
    cfg: TrackEnvParams

    def _declare(self, kwargs: dict[str, Any]) -> Any:
        """Check ``kwargs`` into :attr:`cfg`; the element the env uses (``None``: the
        packaged one of the kernel)."""
        cfg = self.cfg = self.params_class.from_kwargs(kwargs)
        self.backend, self.speed_limit = cfg.backend, cfg.speed_limit
        self.track_class, self._speed_arg, self.profile = cfg.track_class, cfg.speed, cfg.profile
        self.obs_names, self.obs_scale = cfg.obs_names, cfg.obs_scale
        if cfg.surrogate is None and cfg.backend == "surrogate":
            return self._default_surrogate()
        return cfg.surrogate

    def _default_surrogate(self) -> Any:
        """The element used without ``surrogate=`` (``None``: the kernel's packaged one)."""
        return default_vertical_surrogate(*self.default_element) if self.default_element else None

    def _start(self, sim: Any, render_mode: str | None, low: float = -1.0) -> None:
        """The shell around ``sim``: observation (n_obs,) and action (n_actuators,) boxes, the
        action in [``low``, 1]."""
        self._init_shell(
            sim,
            render_mode,
            spaces.Box(-np.inf, np.inf, (len(self.obs_names),), np.float32),
            spaces.Box(low, 1.0, (self.n_actuators,), np.float32),
        )

    def _track_options(self, options: dict[str, Any]) -> tuple[Any, Any]:
        """The ``(track_class, speed)`` of reset ``options`` (unchecked): a new class without
        a speed means that class's speed; other options than ``track_class``, ``speed``,
        ``profile`` raise."""
        unknown = set(options) - {"track_class", "speed", "profile"}
        if unknown:
            raise ValueError(f"options: unknown reset option(s) {sorted(unknown)}")
        tc = options.get("track_class", self.track_class)
        sp = options.get("speed", self._speed_arg if "track_class" not in options else None)
        return tc, sp

    def _case(self, sim: Any, idx: np.ndarray) -> dict[str, np.ndarray]:
        """The track class, the speed (m/s) and whether a measured or user profile is ridden
        of the episodes of ``sim``'s vehicles ``idx``."""
        return {
            "track_class": sim.track_class[idx],
            "speed": sim.speed[idx],
            "profile": sim.measured[idx],
        }

    def _case_text(self, episode: tuple) -> str:
        """``episode`` = ``(track_class, speed, profile)``; the speed (m/s) or a range."""
        track_class, speed, profile = episode
        if isinstance(speed, tuple) and speed[0] != speed[1]:
            at = f"{speed[0]:.4g}–{speed[1]:.4g} m/s"
        else:
            at = f"{speed[0] if isinstance(speed, tuple) else speed:.4g} m/s"
        where = "FRA track" if profile is None else "a measured or user profile"
        return f"class {int(track_class)} at {at} on {where}"


class TrackVectorShell(BatchVectorEnv):
    """What the native vector envs of a vehicle on a track share: the single env whose
    arguments and element the sub-envs share (:attr:`single_class`)."""

    single_class: type[TrackEnvShell]

    def _single(self, num_envs: Any, render_mode: str | None, kwargs: dict[str, Any]) -> Any:
        """``(num_envs, single env)`` checked and made; :attr:`cfg` is the single env's."""
        num_envs = val.integer(num_envs, "num_envs", min=1, max=MAX_NUM_ENVS)
        single = self.single_class(render_mode=render_mode, **kwargs)
        self.cfg = single.cfg
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        return num_envs, single
