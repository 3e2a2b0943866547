"""``railgym/VerticalSuspension-v1``: active secondary suspension on FRA or measured track.

A bogie (m1) and its share of the carbody (m2) ride on the primary suspension over a
seeded FRA track profile (paper eq. 1/2) or a measured/user profile
(:mod:`railgym.profile`); the secondary suspension is either a surrogate
element F̂(δ, δ̇) (``backend="surrogate"``, paper eq. 2), the high-fidelity reference
(``"reference"``: air spring with reservoir + Maxwell damper + bump stops) or the linear
suspension (``"linear"``). The agent commands an actuator force between bogie and carbody.
See ``docs/envs/vertical.md`` for the tables of observation, action, reward, ``info`` and
the argument limits.

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
from railgym.envs.base import BatchEnv, BatchVectorEnv, step_grid
from railgym.envs.vertical_batch import (
    ACC_REF,
    INFO_KEYS,
    LIMITS,
    VerticalBatch,
    VerticalConfig,
)
from railgym.profile import load_profile
from railgym.track import class_parameters, class_speed
from railgym.vehicles.collect import default_vertical_surrogate
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
    "BACKENDS",
    "ENV_BACKENDS",
    "DEFAULT_WEIGHTS",
    "INFO_KEYS",
    "LIMITS",
    "OBSERVATIONS",
    "VerticalBatch",
    "VerticalConfig",
    "VerticalSuspensionEnv",
    "VerticalSuspensionEnvV0",
    "VerticalSuspensionVectorEnv",
    "VerticalSuspensionVectorEnvV0",
    "make_config",
]

#: backend → kernel variant of the secondary suspension (shared with VerticalVehicle-v1)
BACKENDS = {"surrogate": "surrogate", "reference": "dynamic", "linear": "linear"}
#: backends of this env: also "fmu", an FMU as the whole vehicle (railgym.fmu; its state
#: layout is the dynamic variant's)
ENV_BACKENDS = {**BACKENDS, "fmu": "dynamic"}
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


def make_config(
    backend: str,
    duration: float,
    control_dt: float,
    dt: float | None,
    f_max: float,
    observation: str,
    sensor_noise: float,
    reward_weights: dict[str, float] | None,
    wheelbase: float | None,
    band: tuple[float, float],
    free_travel: float,
) -> VerticalConfig:
    """Check the env arguments against their types and :data:`LIMITS`; errors name them."""
    variant = ENV_BACKENDS[val.choice(backend, "backend", ENV_BACKENDS)]
    duration = val.positive(duration, "duration", LIMITS["duration"])
    control_dt = val.positive(control_dt, "control_dt")
    f_max = val.positive(f_max, "f_max", LIMITS["f_max"])
    dt = DEFAULT_DT[variant] if dt is None else val.positive(dt, "dt")
    n_sub, n_steps = step_grid(dt, control_dt, duration)
    observation = val.choice(observation, "observation", OBSERVATIONS)
    sensor_noise = val.non_negative(sensor_noise, "sensor_noise", LIMITS["sensor_noise"])
    weights = dict(DEFAULT_WEIGHTS)
    if reward_weights is not None:
        for key, value in val.mapping(reward_weights, "reward_weights").items():
            if key not in DEFAULT_WEIGHTS:
                raise val.FieldError(
                    "reward_weights", f"has unknown key {key!r}; keys: {list(weights)}"
                )
            weights[key] = val.non_negative(
                value, f"reward_weights[{key!r}]", LIMITS["reward_weight"]
            )
    if wheelbase is not None:
        wheelbase = val.positive(wheelbase, "wheelbase", LIMITS["wheelbase"])
    lo, hi = (val.in_range(b, "band", *LIMITS["band"]) for b in val.sequence(band, "band", 2))
    if not lo < hi:
        raise val.FieldError("band", f"must be (min, max) with min < max wavelength, got {band!r}")
    names, scales = OBSERVATIONS[observation]
    scale = np.array([free_travel if s is None else s for s in scales])
    return VerticalConfig(
        variant=variant,
        dt=dt,
        n_sub=n_sub,
        n_steps=n_steps,
        control_dt=control_dt,
        duration=duration,
        f_max=f_max,
        free_travel=free_travel,
        obs_names=names,
        obs_scale=scale,
        weights=(weights["acceleration"], weights["deflection"], weights["force"]),
        sensor_noise=sensor_noise,
        wheelbase=wheelbase,
        band=(lo, hi),
    )


def _surrogate_arrays(
    backend: str, surrogate: Any, dt: float, kriging: bool = False, relaxation: bool = False
) -> LprArrays:
    """Kernel arrays of the surrogate element: packaged default, a JSON path or a model.

    ``surrogate=`` for a backend that does not use it gives a ``UserWarning`` (it is ignored);
    a model whose inputs do not match its feature form (static: δ, δ̇; maxwell: δ, δ̇, δ − s)
    or whose ``τ`` is below ``dt/2`` (s) is rejected, and so is a Kriging unless ``kriging``
    is set (the one-bogie kernels evaluate it), and so is a relaxation law unless
    ``relaxation`` is set (the whole vehicle's kernels integrate it).
    """
    if backend != "surrogate":
        if surrogate is not None:
            warnings.warn(
                f"surrogate is ignored by backend={backend!r} (only backend='surrogate' uses it)",
                UserWarning,
                stacklevel=4,
            )
        return surrogate_arrays(None)
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
        lpr = surrogate_arrays(surrogate, dt, kriging, relaxation)
    except ValueError as exc:
        raise val.FieldError("surrogate", str(exc), full=True) from None
    _check_element_units(surrogate, lpr.lo.shape[0])
    return lpr


#: units of the suspension element's inputs (deflection, its rate, Maxwell state) and output
ELEMENT_UNITS = ("m", "m/s", "m")
ELEMENT_OUTPUT_UNIT = "N"


def _check_element_units(surrogate: Any, d: int) -> None:
    """A model read from a file (``features_``) must give the units the kernel assumes:
    deflection m, velocity m/s (and the Maxwell state m) in, force N out; an element fitted on
    another problem, or in mm or kN, is refused. A model fitted in this session carries no
    units and is taken as SI."""
    features = getattr(surrogate, "features_", None) or {}
    units, names = features.get("units") or {}, list(features.get("inputs") or [])
    if len(names) != d:  # no file's features block: a model fitted in this session
        return
    output = features.get("output")
    wanted = [*zip(names[:d], ELEMENT_UNITS[:d], strict=True), (output, ELEMENT_OUTPUT_UNIT)]
    for name, unit in wanted:
        got = units.get(name)
        if got != unit:
            found = "no unit" if got is None else f"unit {got!r}"
            raise val.FieldError(
                "surrogate",
                f"{'output' if name == output else 'input'} {name!r} has {found} in "
                "features.units; the suspension element "
                f"takes {', '.join(f'{n!r} in {u}' for n, u in wanted[:-1])} "
                f"and gives {output!r} in {ELEMENT_OUTPUT_UNIT} (save it with those units)",
            )


def check_speed(speed: Any, field: str = "speed") -> float:
    """A speed in m/s, at least ``LIMITS["speed_min"]``."""
    v = val.positive(speed, field)
    if v < LIMITS["speed_min"]:
        raise val.FieldError(
            field,
            f"must be at least {LIMITS['speed_min']:g} m/s (the env's lowest speed), got {speed!r}",
        )
    return v


def _batch(
    n: int, cfg: VerticalConfig, veh: Any, lpr: LprArrays, backend: str, fmu: Any, fmu_map: Any
) -> VerticalBatch:
    """The batch of ``n`` vehicles: compiled kernels, or FMU instances for ``backend="fmu"``
    (``fmu``: the FMU file, ``fmu_map``: its mapping file, :mod:`railgym.fmu.mapping`)."""
    if backend != "fmu":
        for name, value in (("fmu", fmu), ("fmu_map", fmu_map)):
            if value is not None:
                raise val.FieldError(name, f"is only used with backend='fmu', not {backend!r}")
        return VerticalBatch(n, cfg, veh, lpr)
    if fmu_map is None:
        raise val.FieldError("fmu_map", "is required with backend='fmu' (docs/fmi.md)")
    from railgym.fmu.batch import FMUBatch
    from railgym.fmu.mapping import load_mapping

    return FMUBatch(n, cfg, veh, lpr, load_mapping(fmu_map, fmu, "vertical"))


def _check_track(track_class: Any, speed: Any, speed_limit: float | None) -> tuple[int, float]:
    """Validated ``(track_class, speed)``; speed at most ``speed_limit`` (m/s, default
    ``LIMITS["speed_factor"]`` × the class's maximum speed)."""
    class_parameters(track_class)  # raises ValueError naming track_class
    v_max = class_speed(track_class)
    v = v_max if speed is None else check_speed(speed)
    limit = LIMITS["speed_factor"] * v_max if speed_limit is None else speed_limit
    if v > limit:
        raise val.FieldError(
            "speed",
            f"must be at most {limit:.4g} m/s (2 × the class-{int(track_class)} maximum unless "
            f"speed_limit= is given), got {speed!r}",
        )
    return int(track_class), v


class _VerticalAccessors:
    """Public read-only accessors of the simulated vehicles (arrays over the sub-envs)."""

    sim: VerticalBatch

    @property
    def state(self) -> np.ndarray:
        """Copy of the state(s) ``[x1, v1, x2, v2, …]`` (m, m/s; dynamic: Pa, Pa, m;
        surrogate: the element's Maxwell state ``s``, m)."""
        return self.sim.state.copy()

    @property
    def carbody_acceleration(self) -> np.ndarray:
        """Carbody acceleration ẍ2 at the end of the last step, m/s² (n,)."""
        return self.sim.acc[:, 1].copy()

    @property
    def actuator_force(self) -> np.ndarray:
        """Actuator force applied over the last step, N (n,)."""
        return self.sim.force.copy()

    @property
    def out_of_domain(self) -> np.ndarray:
        """Out-of-domain surrogate evaluations this episode (n,)."""
        return self.sim.ood.copy()

    @property
    def vehicle_params(self) -> SuspensionParams:
        """The vehicle's kernel parameters."""
        return self.sim.params


class VerticalSuspensionEnv(_VerticalAccessors, BatchEnv):
    """Active secondary suspension of a railway vehicle on random FRA track.

    Parameters
    ----------
    backend : ``"surrogate"`` (default, paper eq. 2), ``"reference"``, ``"linear"`` or
        ``"fmu"`` (an FMU as the vehicle: ``fmu`` and ``fmu_map``, see ``docs/fmi.md``).
    surrogate : LPR or Kriging model, path of a model JSON, or ``None`` for the packaged
        element; only for ``backend="surrogate"``.
    track_class : FRA class 1–6 (default 5, the paper's training case).
    fmu, fmu_map : the FMU file and its mapping file (:mod:`railgym.fmu.mapping`; ``fmu``
        defaults to the mapping's ``fmu:``), only for ``backend="fmu"``.
    speed : m/s; ``None`` = the class's maximum passenger speed (class 5: 144 km/h); at most
        ``speed_limit``.
    speed_limit : m/s; ``None`` = 2 × the class's maximum speed.
    profile : ``None`` (seeded FRA track), a CSV path (columns x, z in m) or ``(x, z)``;
        it must cover speed × duration; not combined with ``wheelbase``.
    duration : episode length, s (truncation), at most 600 s. control_dt : agent step, s.
    dt : integration step, s (default the kernel's ``DEFAULT_DT``).
    f_max : actuator force at action ±1, N (at most 1 MN).
    observation : ``"sensors"`` or ``"full"``. sensor_noise : std of the additive noise on
        the normalised observation (at most 10). reward_weights : mapping with the
        ``acceleration``, ``deflection``, ``force`` weights (each in [0, 1e6]).
    wheelbase : m, average two delayed wheel inputs (default off; at most 50 m).
    band : wavelength band of the track irregularity, m. vehicle : vehicle YAML name/path.

    Single-env accessors: :attr:`state` (s,), :attr:`carbody_acceleration`,
    :attr:`actuator_force` (floats), :attr:`out_of_domain`, :attr:`vehicle_params`, :meth:`track`,
    :meth:`reset_on_track`.
    """

    #: packaged element used without ``surrogate=``, ``(form, release)`` of
    #: :func:`~railgym.vehicles.collect.default_vertical_surrogate`: ``None`` the current memory
    #: element; ``("maxwell", "v0")`` for ``VerticalSuspension-v1`` (docs: *Version history*)
    default_element: tuple[str, str] | None = None

    def __init__(
        self,
        backend: str = "surrogate",
        surrogate: Any = None,
        track_class: int = 5,
        speed: float | None = None,
        profile: Any = None,
        duration: float = 20.0,
        control_dt: float = 0.01,
        dt: float | None = None,
        f_max: float = 8000.0,
        observation: str = "sensors",
        sensor_noise: float = 0.0,
        reward_weights: dict[str, float] | None = None,
        wheelbase: float | None = None,
        band: tuple[float, float] = (1.0, 100.0),
        vehicle: str = "manchester",
        render_mode: str | None = None,
        speed_limit: float | None = None,
        fmu: str | Path | None = None,
        fmu_map: str | Path | None = None,
    ) -> None:
        veh = load_vehicle(vehicle)
        self.cfg = make_config(
            backend,
            duration,
            control_dt,
            dt,
            f_max,
            observation,
            sensor_noise,
            reward_weights,
            wheelbase,
            band,
            veh.bump_stop.free_travel_compression,
        )
        self.backend = backend
        self.speed_limit = None if speed_limit is None else val.positive(speed_limit, "speed_limit")
        self.track_class, self.speed = _check_track(track_class, speed, self.speed_limit)
        self._speed_arg = speed
        self.profile = self._check_profile(profile)
        self._fmu_args = (backend, fmu, fmu_map)
        if surrogate is None and backend == "surrogate" and self.default_element is not None:
            surrogate = default_vertical_surrogate(*self.default_element)
        sim = _batch(
            1,
            self.cfg,
            veh,
            _surrogate_arrays(backend, surrogate, self.cfg.dt, True),
            *self._fmu_args,
        )
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        n_obs = len(self.obs_names)
        self._init_shell(
            sim,
            render_mode,
            spaces.Box(-np.inf, np.inf, (n_obs,), np.float32),
            spaces.Box(-1.0, 1.0, (1,), np.float32),
        )

    def _check_profile(self, profile: Any) -> tuple[np.ndarray, np.ndarray] | None:
        """``profile`` checked by :func:`railgym.profile.load_profile`; not with ``wheelbase``."""
        checked = load_profile(profile)
        if checked is not None and self.cfg.wheelbase is not None:
            raise val.FieldError(
                "profile",
                "cannot be combined with wheelbase= (the two-wheel average is for FRA track); "
                "give wheelbase=None",
                full=False,
            )
        return checked

    def _apply_options(self, options: dict[str, Any]) -> None:
        """``track_class``, ``speed`` and ``profile`` (kept for later episodes; a new class
        without a speed uses that class's speed; ``profile=None`` returns to FRA track)."""
        if not options:
            return
        unknown = set(options) - {"track_class", "speed", "profile"}
        if unknown:
            raise ValueError(f"unknown reset option(s) {sorted(unknown)}")
        tc = options.get("track_class", self.track_class)
        sp = options.get("speed", self._speed_arg if "track_class" not in options else None)
        track_class, speed = _check_track(tc, sp, self.speed_limit)
        if "profile" in options:
            self.profile = self._check_profile(options["profile"])
        self.track_class, self.speed = track_class, speed
        self._speed_arg = options.get("speed", self._speed_arg)

    def _episode(self) -> tuple[int, float, tuple[np.ndarray, np.ndarray] | None]:
        return self.track_class, self.speed, self.profile

    def _frame(self, state: dict[str, Any]) -> np.ndarray:
        from railgym.envs.rendering import render_vertical

        return render_vertical(state)

    @property
    def state(self) -> np.ndarray:
        """Copy of the state ``[x1, v1, x2, v2, …]`` (m, m/s; dynamic also Pa, Pa, m;
        surrogate the element's Maxwell state ``s``, m)."""
        return self.sim.state[0].copy()

    @property
    def carbody_acceleration(self) -> float:
        """Carbody acceleration ẍ2 at the end of the last step, m/s²."""
        return float(self.sim.acc[0, 1])

    @property
    def actuator_force(self) -> float:
        """Actuator force applied over the last step, N."""
        return float(self.sim.force[0])

    @property
    def out_of_domain(self) -> int:
        """Out-of-domain surrogate evaluations this episode."""
        return int(self.sim.ood[0])

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
        dst.reset_state(0)
        self._started = True


class VerticalSuspensionVectorEnv(_VerticalAccessors, BatchVectorEnv):
    """Native vector version: all sub-envs stepped in one compiled kernel call.

    Sub-env ``i`` of ``reset(seed=s)`` reproduces ``VerticalSuspensionEnv.reset(seed=s + i)``
    step for step. Autoreset mode: next step (gymnasium's default). Accessors as the single
    env's, as arrays over the sub-envs.
    """

    #: the single env whose configuration and element the sub-envs share
    single_class: type[VerticalSuspensionEnv] = VerticalSuspensionEnv

    def __init__(self, num_envs: int = 1, render_mode: str | None = None, **kwargs: Any) -> None:
        num_envs = val.integer(num_envs, "num_envs", min=1, max=LIMITS["num_envs"])
        single = self.single_class(render_mode=render_mode, **kwargs)
        self.cfg = single.cfg
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        sim = _batch(num_envs, self.cfg, single.sim.vehicle, single.sim.lpr, *single._fmu_args)
        self._init_vector(single, sim, num_envs)


class VerticalSuspensionEnvV0(VerticalSuspensionEnv):
    """``VerticalSuspension-v1``: the packaged memory element of version 0 by default;
    everything else as :class:`VerticalSuspensionEnv` (docs/envs/vertical.md, *Version
    history*)."""

    default_element = ("maxwell", "v0")


class VerticalSuspensionVectorEnvV0(VerticalSuspensionVectorEnv):
    """Native vector version of :class:`VerticalSuspensionEnvV0`."""

    single_class = VerticalSuspensionEnvV0
