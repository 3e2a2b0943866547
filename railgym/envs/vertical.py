"""``railgym/VerticalSuspension-v1``: active secondary suspension on FRA or measured track.

A bogie (m1) and its share of the carbody (m2) ride on the primary suspension over a
seeded FRA track profile (paper eq. 1/2) or a measured/user profile
(:mod:`railgym.profile`); the secondary suspension is either a surrogate
element F̂(δ, δ̇) (``backend="surrogate"``, paper eq. 2), the high-fidelity reference
(``"reference"``: air spring with reservoir + Maxwell damper + bump stops) or the linear
suspension (``"linear"``). The agent commands an actuator force between bogie and carbody
(``actuator="force"``) or the command of a controllable damper at its place
(``actuator="semi-active"``, :mod:`railgym.vehicles.semi_active`). See
``docs/envs/vertical.md`` for the tables of observation, action, reward, ``info`` and the
argument limits.

The physics is in :mod:`railgym.vehicles.vertical` (numba RK4 kernels); the single env
and the native vector env are the shells of :mod:`railgym.envs.base` around
:class:`~railgym.envs.vertical_batch.VerticalBatch`, which steps any number of vehicles,
each on its own track, in one compiled call.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from railgym import _checks as val
from railgym.comfort import MIN_FS
from railgym.envs.base import BatchEnv, BatchVectorEnv, caller_level
from railgym.envs.damper_params import (
    ACTUATORS,
    DAMPER_CHANNEL,
    DEFAULT_DAMPER,
    DamperArgs,
    damper_law_of,
)
from railgym.envs.params import (
    BACKENDS,
    ENV_BACKENDS,
    REWARD_WEIGHTS,
    SPEED_FACTOR,
    SPEED_MIN,
    TrackEnvParams,
    check_speed,
    checked_keywords,
    declared,
    limits,
    param,
)
from railgym.envs.vertical_batch import (
    ACC_REF,
    INFO_KEYS,
    MAX_NUM_ENVS,
    TRACK_BYTES,
    VerticalBatch,
)
from railgym.profile import load_profile
from railgym.track import class_speed
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.element_envelope import OperatingEnvelope, element_envelope
from railgym.vehicles.element_plausibility import implausible_element_warning
from railgym.vehicles.vertical import (
    DEFAULT_DT,
    LprArrays,
    SuspensionParams,
    load_vehicle,
    surrogate_arrays,
)
from surrogates import io

__all__ = [
    "ACC_REF",
    "ACC_WEIGHTINGS",
    "ACTUATORS",
    "DAMPER_CHANNEL",
    "BACKENDS",
    "ENV_BACKENDS",
    "DEFAULT_WEIGHTS",
    "INFO_KEYS",
    "LIMITS",
    "OBSERVATIONS",
    "VerticalBatch",
    "VerticalParams",
    "VerticalSuspensionEnv",
    "VerticalSuspensionEnvV0",
    "VerticalSuspensionEnvV2",
    "VerticalSuspensionVectorEnv",
    "VerticalSuspensionVectorEnvV0",
    "VerticalSuspensionVectorEnvV2",
    "check_speed",
    "check_speed_limit",
]

OBSERVATIONS = {
    # name: (channels, scale of each channel in SI units)
    "sensors": (
        ("carbody_acc", "bogie_acc", "deflection", "deflection_rate", "carbody_vel"),
        (1.0, 10.0, None, 0.1, 0.1),
    ),
    "full": (
        ("x1", "v1", "x2", "v2", "bogie_acc", "carbody_acc", "z", "zdot"),
        (0.01, 0.1, 0.01, 0.1, 10.0, 1.0, 0.01, 0.1),
    ),
}
DEFAULT_WEIGHTS = {"acceleration": 1.0, "deflection": 1.0, "force": 0.1}
#: frequency weightings of the reward's acceleration term (ISO 2631-1), ``"none"``: raw
ACC_WEIGHTINGS = ("none", "Wk")


def _check_track(track_class: Any, speed: Any, speed_limit: float | None) -> tuple[int, float]:
    """Validated ``(track_class, speed)``; speed at most ``speed_limit`` (m/s, default
    :data:`~railgym.envs.params.SPEED_FACTOR` × the class's maximum speed)."""
    track_class = TrackEnvParams.check("track_class", track_class)
    v_max = class_speed(track_class)
    v = v_max if speed is None else check_speed(speed)
    check_speed_limit(v, track_class, speed, speed_limit)
    return int(track_class), v


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


def _check_profile(profile: Any, wheelbase: float | None) -> tuple[np.ndarray, np.ndarray] | None:
    """``profile`` checked by :func:`railgym.profile.load_profile`; not with ``wheelbase``."""
    checked = load_profile(profile)
    if checked is not None and wheelbase is not None:
        raise val.FieldError(
            "profile",
            "cannot be combined with wheelbase= (the two-wheel average is for FRA track); "
            "give wheelbase=None",
            full=False,
        )
    return checked


@declared
class VerticalParams(DamperArgs, TrackEnvParams):
    """The arguments of ``VerticalSuspension-v1`` (:class:`VerticalSuspensionEnv`), declared
    once: defaults, units, limits (docs/envs/vertical.md, *Arguments*)."""

    OBSERVATIONS = OBSERVATIONS

    wheelbase: float | None = param(
        None,
        "m",
        "average the inputs of two wheelsets this far apart (FRA track only)",
        lo=0.0,
        lo_open=True,
        hi=50.0,
        optional=True,
    )
    acc_weighting: str = param(
        "none",
        "",
        '`"Wk"`: ISO 2631-1 weighted carbody acceleration in the reward (needs `control_dt` '
        f"at most {1.0 / MIN_FS:g} s)",
        kind="choice",
        values=ACC_WEIGHTINGS,
    )

    def _default_dt(self) -> float:
        return DEFAULT_DT[self.variant]

    def _load_vehicle(self) -> tuple[Any, float]:
        veh = load_vehicle(self.vehicle)
        return veh, veh.deflection_scale

    def _derive(self) -> None:
        super()._derive()
        _check_track(self.track_class, self.speed, self.speed_limit)
        _check_profile(self.profile, self.wheelbase)
        if self.acc_weighting != "none" and 1.0 / self.control_dt < MIN_FS:
            raise val.FieldError(
                "acc_weighting",
                f"{self.acc_weighting!r} needs a control rate of at least {MIN_FS:g} Hz "
                f"(control_dt at most {1.0 / MIN_FS:g} s), got control_dt={self.control_dt:g} s",
            )
        self._derive_damper(1)


#: documented limits (docs/envs/vertical.md): the declared bounds of :class:`VerticalParams`
#: and those of the speed, the vector env and its memory
LIMITS = {
    **limits(VerticalParams),
    "speed_factor": SPEED_FACTOR,
    "speed_min": SPEED_MIN,
    "num_envs": MAX_NUM_ENVS,
    "track_bytes": TRACK_BYTES,
}


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
    (:func:`~railgym.vehicles.vertical.surrogate_arrays`).
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
ELEMENT_UNITS = ("m", "m/s", "m")
ELEMENT_OUTPUT_UNIT = "N"


def _check_element_units(surrogate: Any, d: int) -> None:
    """A model with named inputs (``features_``: read from a file, or from
    ``surrogates.build(..., inputs=, units=)``) must give the units the kernel assumes:
    deflection m, velocity m/s (and the Maxwell state m) in, force N out; an element fitted on
    another problem, or in mm or kN, is refused (the error names the fix). A model fitted in
    this session without names carries no units and is taken as SI."""
    features = getattr(surrogate, "features_", None) or {}
    units, names = features.get("units") or {}, list(features.get("inputs") or [])
    if len(names) != d:  # no names: a model fitted in this session
        return
    output = features.get("output")
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
                f"--output {output} --units {' '.join(f'{n}={u}' for n, u in wanted)} ...` or "
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
            "for this vehicle (python -m railgym.vehicles.collect --vehicle ...)",
        )


def _batch(
    n: int, cfg: VerticalParams, lpr: LprArrays, envelope: OperatingEnvelope | None = None
) -> VerticalBatch:
    """The batch of ``n`` vehicles: compiled kernels (``envelope``: the element's, behind
    ``info["outside_envelope"]``; the damper of
    :func:`~railgym.envs.damper_params.damper_law_of`), or FMU instances for
    ``backend="fmu"`` (``cfg.fmu``: the FMU file, ``cfg.fmu_map``: its mapping file,
    :mod:`railgym.fmu.mapping`)."""
    check_element_vehicle(cfg.backend, lpr, cfg.model)
    if cfg.backend != "fmu":
        return VerticalBatch(n, cfg, cfg.model, lpr, envelope, damper_law_of(cfg))
    from railgym.fmu.batch import FMUBatch
    from railgym.fmu.mapping import load_mapping

    return FMUBatch(n, cfg, cfg.model, lpr, load_mapping(cfg.fmu_map, cfg.fmu, "vertical"))


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
            raise ValueError(f"unknown reset option(s) {sorted(unknown)}")
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


class _VerticalAccessors:
    """Public read-only accessors of the simulated vehicles: arrays over the sub-envs of the
    vector env, sub-env 0's entry (a copy, or a Python number) for the single env."""

    sim: VerticalBatch
    _rows: Any

    @property
    def state(self) -> np.ndarray:
        """Copy of the state(s) ``[x1, v1, x2, v2, …]`` (m, m/s; dynamic: Pa, Pa, m;
        surrogate: the element's Maxwell state ``s``, m; semi-active: then the damper's
        ``u, w``)."""
        return self._rows(self.sim.state)

    @property
    def carbody_acceleration(self) -> Any:
        """Carbody acceleration ẍ2 at the end of the last step, m/s² (float; vector: (n,))."""
        return self._rows(self.sim.acc[:, 1])

    @property
    def actuator_force(self) -> Any:
        """Actuator force applied over the last step (semi-active: the damper's force at its
        end), N (float; vector: (n,))."""
        return self._rows(self.sim.force)

    @property
    def out_of_domain(self) -> Any:
        """Out-of-domain surrogate evaluations this episode (int; vector: (n,))."""
        return self._rows(self.sim.ood)

    @property
    def vehicle_params(self) -> SuspensionParams:
        """The vehicle's kernel parameters."""
        return self.sim.params


class VerticalSuspensionEnv(_VerticalAccessors, TrackEnvShell):
    """Active secondary suspension of a railway vehicle on random FRA track.

    The keyword arguments are the fields of :class:`VerticalParams` (default, unit, limits
    and meaning of each: docs/envs/vertical.md, *Arguments*) and ``render_mode``; the checked
    arguments are :attr:`cfg`. :attr:`default_element` is ``("maxwell", "v0")`` for
    ``VerticalSuspension-v0``, :attr:`element_grid` is set for ``VerticalSuspension-v2``.

    Single-env accessors: :attr:`state` (s,), :attr:`carbody_acceleration`,
    :attr:`actuator_force` (floats), :attr:`out_of_domain`, :attr:`vehicle_params`, :meth:`track`,
    :meth:`reset_on_track`.
    """

    params_class = VerticalParams
    n_actuators = 1
    cfg: VerticalParams
    _case_attrs = ("track_class", "speed", "profile", "_speed_arg")

    @checked_keywords(VerticalParams)
    def __init__(
        self,
        *,
        render_mode: str | None = None,
        backend: str = "surrogate",
        surrogate: Any = None,
        track_class: int = 5,
        speed: Any = None,
        speed_limit: float | None = None,
        profile: Any = None,
        duration: float = 20.0,
        control_dt: float = 0.01,
        dt: float | None = None,
        f_max: float = 8000.0,
        observation: str = "sensors",
        sensor_noise: float = 0.0,
        reward_weights: dict[str, float] | None = REWARD_WEIGHTS,
        band: tuple[float, float] = (1.0, 100.0),
        vehicle: Any = None,
        fmu: Any = None,
        fmu_map: Any = None,
        actuator: str = "force",
        damper: Any = DEFAULT_DAMPER,
        damper_element: Any = None,
        wheelbase: float | None = None,
        acc_weighting: str = "none",
    ) -> None:
        surrogate = self._declare(VerticalParams.arguments_from(locals()))
        cfg = self.cfg
        self.track_class, self.speed = _check_track(cfg.track_class, cfg.speed, cfg.speed_limit)
        given = cfg.model if cfg.surrogate is not None else None  # the user's element
        lpr, envelope = element_arrays(
            cfg.backend, surrogate, cfg.dt, True, vehicle=given, grid=self.element_grid
        )
        low = 0.0 if cfg.actuator == "semi-active" else -1.0
        self._start(_batch(1, cfg, lpr, envelope), render_mode, low)

    def _apply_options(self, options: dict[str, Any]) -> None:
        """``track_class``, ``speed`` and ``profile`` (kept for later episodes; a new class
        without a speed uses that class's speed; ``profile=None`` returns to FRA track;
        ``hold``: :mod:`railgym.envs.base`)."""
        if not options:
            return
        tc, sp = self._track_options(options)
        track_class, speed = _check_track(tc, sp, self.speed_limit)
        if "profile" in options:
            self.profile = _check_profile(options["profile"], self.cfg.wheelbase)
        self.track_class, self.speed, self._speed_arg = track_class, speed, sp

    def _episode(self) -> tuple[int, float, tuple[np.ndarray, np.ndarray] | None]:
        return self.track_class, self.speed, self.profile

    def _frame(self, state: dict[str, Any]) -> np.ndarray:
        from railgym.envs.rendering import render_vertical

        return render_vertical(state)

    def track(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the current track input ``(z, zdot)`` on the grid ``k·dt``, m and m/s."""
        return self.sim.z[0].copy(), self.sim.zdot[0].copy()

    def reset_on_track(self, other: VerticalSuspensionEnv) -> None:
        """Put this env at rest at the start of ``other``'s current track (same grid needed);
        its generator and options are not changed."""
        src, dst = other.sim, self.sim
        if src.z.shape != dst.z.shape:
            raise ValueError(
                f"other env's track has {src.z.shape[1]} samples, this env needs {dst.z.shape[1]}"
            )
        np.copyto(dst.z, src.z)
        np.copyto(dst.zdot, src.zdot)
        np.copyto(dst.track_class, src.track_class)
        np.copyto(dst.speed, src.speed)
        np.copyto(dst.measured, src.measured)
        dst.reset_state(0)
        self._started = True


class VerticalSuspensionVectorEnv(_VerticalAccessors, TrackVectorShell):
    """Native vector version: all sub-envs stepped in one compiled kernel call.

    Sub-env ``i`` of ``reset(seed=s)`` reproduces ``VerticalSuspensionEnv.reset(seed=s + i)``
    step for step. Autoreset mode: next step (gymnasium's default). Accessors as the single
    env's, as arrays over the sub-envs.
    """

    single_class: type[VerticalSuspensionEnv] = VerticalSuspensionEnv
    cfg: VerticalParams

    @checked_keywords(VerticalParams)
    def __init__(
        self,
        num_envs: int = 1,
        *,
        render_mode: str | None = None,
        backend: str = "surrogate",
        surrogate: Any = None,
        track_class: int = 5,
        speed: Any = None,
        speed_limit: float | None = None,
        profile: Any = None,
        duration: float = 20.0,
        control_dt: float = 0.01,
        dt: float | None = None,
        f_max: float = 8000.0,
        observation: str = "sensors",
        sensor_noise: float = 0.0,
        reward_weights: dict[str, float] | None = REWARD_WEIGHTS,
        band: tuple[float, float] = (1.0, 100.0),
        vehicle: Any = None,
        fmu: Any = None,
        fmu_map: Any = None,
        actuator: str = "force",
        damper: Any = DEFAULT_DAMPER,
        damper_element: Any = None,
        wheelbase: float | None = None,
        acc_weighting: str = "none",
    ) -> None:
        args = VerticalParams.arguments_from(locals())
        num_envs, single = self._single(num_envs, render_mode, args)
        sim = _batch(num_envs, self.cfg, single.sim.lpr, single.sim.envelope)
        self._init_vector(single, sim, num_envs)


class VerticalSuspensionEnvV0(VerticalSuspensionEnv):
    """``VerticalSuspension-v1``: the packaged memory element of version 0 by default;
    everything else as :class:`VerticalSuspensionEnv` (docs/envs/vertical.md, *Version
    history*)."""

    default_element = ("maxwell", "v0")


class VerticalSuspensionVectorEnvV0(VerticalSuspensionVectorEnv):
    """Native vector version of :class:`VerticalSuspensionEnvV0`."""

    single_class = VerticalSuspensionEnvV0


class VerticalSuspensionEnvV2(VerticalSuspensionEnv):
    """``VerticalSuspension-v2``: an additive LPR element evaluated by its Hermite tables
    inside the box (:mod:`surrogates.models.lpr_grid`); everything else as
    :class:`VerticalSuspensionEnv` (docs/envs/vertical.md, *Version history*)."""

    element_grid = True


class VerticalSuspensionVectorEnvV2(VerticalSuspensionVectorEnv):
    """Native vector version of :class:`VerticalSuspensionEnvV2`."""

    single_class = VerticalSuspensionEnvV2
