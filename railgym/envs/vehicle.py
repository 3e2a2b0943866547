"""``railgym/VerticalVehicle-v1``: active secondary suspension of the whole vehicle.

Carbody bounce, pitch and first bending on two bogies, four wheelsets on a seeded FRA track
or a measured/user profile (:mod:`railgym.vehicles.vehicle`); one actuator in the secondary
suspension of each bogie. The secondary elements are the backends of
``VerticalSuspension-v1``: ``"surrogate"`` (LPR element, both bogies), ``"reference"``
(air spring with reservoir, Maxwell damper, bump stops) or ``"linear"``. Observation,
action, reward, ``info`` and the argument limits are tabulated in
``docs/envs/vehicle_vertical.md``.

The single env and the native vector env are the shells of :mod:`railgym.envs.base` around
:class:`~railgym.envs.vehicle_batch.VehicleBatch`, which steps any number of vehicles in one
compiled call (the single env is a batch of one).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from railgym import _checks as val
from railgym.envs.base import BatchEnv, BatchVectorEnv, step_grid
from railgym.envs.vehicle_batch import (
    ACC_REF,
    DIVERGENCE_PENALTY,
    INFO_KEYS,
    MIN_COMFORT_SAMPLES,
    REWARD_TERMS,
    VehicleBatch,
    VehicleConfig,
    check_band_speed,
    episode_comfort,
)
from railgym.envs.vertical import BACKENDS, _surrogate_arrays, check_speed
from railgym.envs.vertical_batch import LIMITS as _VERTICAL_LIMITS
from railgym.profile import load_profile
from railgym.track import class_parameters, class_speed
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.collect_vehicle import default_vehicle_surrogate
from railgym.vehicles.vehicle import DEFAULT_DT, Params, load_whole_vehicle

__all__ = [
    "ACC_REF",
    "ACC_WEIGHTINGS",
    "DEFAULT_WEIGHTS",
    "DIVERGENCE_PENALTY",
    "INFO_KEYS",
    "LIMITS",
    "MIN_COMFORT_SAMPLES",
    "OBSERVATIONS",
    "REWARD_TERMS",
    "SIZING_SPEED",
    "VehicleConfig",
    "VerticalVehicleEnv",
    "VerticalVehicleEnvV0",
    "VerticalVehicleVectorEnv",
    "VerticalVehicleVectorEnvV0",
    "episode_comfort",
    "make_config",
]

_POS = ("z_c", "theta_c", "q", "z_b0", "theta_b0", "z_b1", "theta_b1")
_POS_SCALE = (0.01, 0.001, 0.001, 0.01, 0.001, 0.01, 0.001)
_SENSORS = (
    # (channel, scale in SI units; None = secondary free travel)
    ("acc_front", 1.0),
    ("acc_centre", 1.0),
    ("acc_rear", 1.0),
    ("bogie_acc_front", 10.0),
    ("bogie_acc_rear", 10.0),
    ("deflection_front", None),
    ("deflection_rear", None),
    ("deflection_rate_front", 0.1),
    ("deflection_rate_rear", 0.1),
    ("carbody_vel_front", 0.1),
    ("carbody_vel_rear", 0.1),
)
_FULL = (
    *zip(_POS, _POS_SCALE, strict=True),
    *((f"{n}_dot", 10.0 * s) for n, s in zip(_POS, _POS_SCALE, strict=True)),
    *_SENSORS[:5],
    *((f"w{j}", 0.01) for j in range(4)),
    *((f"w{j}_dot", 0.1) for j in range(4)),
)
OBSERVATIONS = {
    # name: (channels, scale of each channel in SI units; None = secondary free travel)
    name: (tuple(c for c, _ in chans), tuple(s for _, s in chans))
    for name, chans in (("sensors", _SENSORS), ("full", _FULL))
}
DEFAULT_WEIGHTS = {"acceleration": 1.0, "deflection": 1.0, "force": 0.1}
ACC_WEIGHTINGS = ("none", "Wk")
#: documented argument limits (docs/envs/vehicle_vertical.md): those of VerticalSuspension-v1,
#: with actuator forces up to 1 GN (stress tests: the outputs stay finite)
LIMITS = {**_VERTICAL_LIMITS, "f_max": 1e9}
#: lowest speed the track arrays are sized for unless the env is made with a lower one, m/s
SIZING_SPEED = 10.0


def make_config(
    backend: str,
    duration: float,
    control_dt: float,
    dt: float | None,
    f_max: float,
    n_actuators: int,
    observation: str,
    sensor_noise: float,
    reward_weights: dict[str, float] | None,
    acc_weighting: str,
    band: tuple[float, float],
    free_travel: float,
    flexible: bool,
) -> VehicleConfig:
    """Check the env arguments against their types and :data:`LIMITS`; errors name them."""
    backends = {**BACKENDS, "fmu": "dynamic"}  # fmu: an FMU as the vehicle (railgym.fmu)
    variant = backends[val.choice(backend, "backend", backends)]
    duration = val.positive(duration, "duration", LIMITS["duration"])
    control_dt = val.positive(control_dt, "control_dt")
    if control_dt >= 1.0 / 60.0:
        raise val.FieldError(
            "control_dt",
            "must be below 1/60 s (the Sperling index needs a sample rate above 60 Hz), "
            f"got {control_dt!r}",
        )
    f_max = val.positive(f_max, "f_max", LIMITS["f_max"])
    n_actuators = val.integer(n_actuators, "n_actuators")
    if n_actuators != 2:
        raise val.FieldError(
            "n_actuators",
            f"must be 2 (one per bogie; per-side actuators need the roll plane), got "
            f"{n_actuators!r}",
        )
    dt = DEFAULT_DT if dt is None else val.positive(dt, "dt")
    n_sub, n_steps = step_grid(dt, control_dt, duration)
    observation = val.choice(observation, "observation", OBSERVATIONS)
    sensor_noise = val.non_negative(sensor_noise, "sensor_noise", LIMITS["sensor_noise"])
    acc_weighting = val.choice(acc_weighting, "acc_weighting", ACC_WEIGHTINGS)
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
    lo, hi = (val.in_range(b, "band", *LIMITS["band"]) for b in val.sequence(band, "band", 2))
    if not lo < hi:
        raise val.FieldError("band", f"must be (min, max) with min < max wavelength, got {band!r}")
    names, scales = OBSERVATIONS[observation]
    return VehicleConfig(
        variant=variant,
        dt=dt,
        n_sub=n_sub,
        n_steps=n_steps,
        control_dt=control_dt,
        duration=duration,
        f_max=f_max,
        free_travel=free_travel,
        obs_names=names,
        obs_scale=np.array([free_travel if s is None else s for s in scales]),
        weights=(weights["acceleration"], weights["deflection"], weights["force"]),
        acc_weighting=acc_weighting,
        sensor_noise=sensor_noise,
        band=(lo, hi),
        flexible=val.boolean(flexible, "flexible"),
    )


def _speed_range(track_class: Any, speed: Any, speed_limit: float | None) -> tuple[float, float]:
    """``speed`` (m/s): None (class speed), a number or a ``(v_min, v_max)`` range, each at
    most ``speed_limit`` (default ``LIMITS["speed_factor"]`` × the class's maximum speed)."""
    class_parameters(track_class)  # raises ValueError naming track_class
    v_class = class_speed(track_class)
    if speed is None:
        return v_class, v_class
    if isinstance(speed, tuple | list) or (isinstance(speed, np.ndarray) and speed.ndim == 1):
        lo, hi = (check_speed(v) for v in val.sequence(speed, "speed", 2))
        if lo > hi:
            raise val.FieldError("speed", f"range must have v_min <= v_max, got {speed!r}")
    else:
        lo = hi = check_speed(speed)
    limit = LIMITS["speed_factor"] * v_class if speed_limit is None else speed_limit
    if hi > limit:
        raise val.FieldError(
            "speed",
            f"must be at most {limit:.4g} m/s (2 × the class-{int(track_class)} maximum unless "
            f"speed_limit= is given), got {speed!r}",
        )
    return lo, hi


def _batch(
    n: int,
    cfg: VehicleConfig,
    veh: Any,
    lpr: Any,
    v_min: float,
    backend: str,
    fmu: Any,
    fmu_map: Any,
) -> VehicleBatch:
    """The batch of ``n`` vehicles: the compiled kernel, or FMU instances for
    ``backend="fmu"`` (``fmu``, ``fmu_map``: :mod:`railgym.fmu.mapping`)."""
    if backend != "fmu":
        for name, value in (("fmu", fmu), ("fmu_map", fmu_map)):
            if value is not None:
                raise val.FieldError(name, f"is only used with backend='fmu', not {backend!r}")
        return VehicleBatch(n, cfg, veh, lpr, v_min)
    if fmu_map is None:
        raise val.FieldError("fmu_map", "is required with backend='fmu' (docs/fmi.md)")
    from railgym.fmu.mapping import load_mapping
    from railgym.fmu.vehicle_batch import FMUVehicleBatch

    return FMUVehicleBatch(n, cfg, veh, lpr, v_min, load_mapping(fmu_map, fmu, "vehicle"))


def _vehicle_surrogate(backend: str, surrogate: Any, dt: float) -> Any:
    """Kernel arrays of the secondary-suspension element, the same at both bogies: a static
    (δ, δ̇) or a memory (δ, δ̇, δ − s) element, each bogie with its own Maxwell state; the
    default is the packaged whole-vehicle element (``vehicle_lpr.json``, docs/validation.md)."""
    return _surrogate_arrays(backend, surrogate, dt, relaxation=True)


class _VehicleAccessors:
    """Public read-only accessors of the simulated vehicles (arrays over the sub-envs)."""

    sim: VehicleBatch

    @property
    def state(self) -> np.ndarray:
        """Copy of the states (n, s): ``[z_c, θ_c, q, z_b0, θ_b0, z_b1, θ_b1]`` (m, rad, m),
        their rates, and for the reference backend the air-spring and damper states, for a
        memory surrogate element its Maxwell states ``[s_0, s_1]`` (m)."""
        return self.sim.bt.state.copy()

    @property
    def carbody_acceleration(self) -> np.ndarray:
        """Floor accelerations front, centre, rear at the end of the last step, m/s² (n, 3)."""
        return self.sim.out.acc[:, :3].copy()

    @property
    def actuator_force(self) -> np.ndarray:
        """Actuator forces front, rear applied over the last step, N (n, 2)."""
        return self.sim.bt.force.copy()

    @property
    def out_of_domain(self) -> np.ndarray:
        """Out-of-domain surrogate evaluations this episode (n,)."""
        return self.sim.bk.ood.copy()

    @property
    def vehicle_params(self) -> Params:
        """The vehicle's kernel parameters."""
        return self.sim.params


class VerticalVehicleEnv(_VehicleAccessors, BatchEnv):
    """Active secondary suspension of a whole railway vehicle (vertical plane).

    Parameters
    ----------
    backend : ``"surrogate"`` (default), ``"reference"`` or ``"linear"`` secondary elements.
    surrogate : LPR element (static or memory form, the same at both bogies), path of a
        model JSON, or ``None`` for the packaged memory element.
    track_class : FRA class 1–6 (default 5).
    speed : m/s: a number, a range ``(v_min, v_max)`` drawn uniformly per episode, or
        ``None`` = the class's maximum passenger speed (class 5: 144 km/h); at most
        ``speed_limit``.
    speed_limit : m/s; ``None`` = 2 × the class's maximum speed.
    profile : ``None`` (seeded FRA track), a CSV path (columns x, z in m) or ``(x, z)``.
    duration : episode length, s (truncation; at most 600 s). control_dt : agent step, s
        (< 1/60). dt : RK4 step, s (default ``DEFAULT_DT``, 2 ms). f_max : force of each
        actuator at action ±1, N (at most 1 GN). n_actuators : 2 (front and rear secondary
        suspension).
    observation : ``"sensors"`` or ``"full"``; sensor_noise : std of the additive noise on
        the normalised observation (at most 10). reward_weights : ``acceleration``,
        ``deflection``, ``force`` (each in [0, 1e6]). acc_weighting : ``"none"`` or ``"Wk"``
        (ISO 2631-1 weighted floor accelerations in the reward). band : irregularity
        wavelength band, m.
    vehicle : whole-vehicle YAML name/path. flexible : False freezes the bending mode.

    Single-env accessors (the vector env's, of sub-env 0): :attr:`state` (s,),
    :attr:`carbody_acceleration` (3,), :attr:`actuator_force` (2,), :attr:`out_of_domain`,
    :attr:`vehicle_params`.
    """

    #: packaged element used without ``surrogate=``, ``(form, release)`` of
    #: :func:`~railgym.vehicles.collect.default_vertical_surrogate`: ``None`` the whole
    #: vehicle's element (:func:`~railgym.vehicles.collect_vehicle.default_vehicle_surrogate`);
    #: ``("static", "")`` for ``VerticalVehicle-v0`` (docs: *Version history*)
    default_element: tuple[str, str] | None = None

    def __init__(
        self,
        backend: str = "surrogate",
        surrogate: Any = None,
        track_class: int = 5,
        speed: float | tuple[float, float] | None = None,
        profile: Any = None,
        duration: float = 20.0,
        control_dt: float = 0.01,
        dt: float | None = None,
        f_max: float = 8000.0,
        n_actuators: int = 2,
        observation: str = "sensors",
        sensor_noise: float = 0.0,
        reward_weights: dict[str, float] | None = None,
        acc_weighting: str = "none",
        band: tuple[float, float] = (1.0, 100.0),
        vehicle: str = "manchester_whole",
        flexible: bool = True,
        render_mode: str | None = None,
        speed_limit: float | None = None,
        fmu: Any = None,
        fmu_map: Any = None,
    ) -> None:
        veh = load_whole_vehicle(vehicle)
        free = veh.suspension.bump_stop.free_travel_compression
        self.cfg = make_config(
            backend,
            duration,
            control_dt,
            dt,
            f_max,
            n_actuators,
            observation,
            sensor_noise,
            reward_weights,
            acc_weighting,
            band,
            free,
            flexible,
        )
        self.backend = backend
        self.speed_limit = None if speed_limit is None else val.positive(speed_limit, "speed_limit")
        self.speeds = _speed_range(track_class, speed, self.speed_limit)
        self.track_class = int(track_class)
        self._speed_arg = speed
        self.profile = load_profile(profile)
        if self.profile is None:
            check_band_speed(self.cfg.band, self.speeds[1], self.cfg.dt)
        if surrogate is None and backend == "surrogate":
            if self.default_element is None:
                surrogate = default_vehicle_surrogate()
            else:
                surrogate = default_vertical_surrogate(*self.default_element)
        lpr = _vehicle_surrogate(backend, surrogate, self.cfg.dt)
        self._fmu_args = (backend, fmu, fmu_map)
        sim = _batch(1, self.cfg, veh, lpr, min(self.speeds[0], SIZING_SPEED), *self._fmu_args)
        self.vehicle = veh
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        self._init_shell(
            sim,
            render_mode,
            spaces.Box(-np.inf, np.inf, (len(self.obs_names),), np.float32),
            spaces.Box(-1.0, 1.0, (2,), np.float32),
        )

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
        speeds = _speed_range(tc, sp, self.speed_limit)
        if speeds[0] < self.sim.v_min:
            raise val.FieldError(
                "speed",
                f"{sp!r} is below the {self.sim.v_min} m/s the env was made for; make the env "
                "with that speed",
            )
        if "profile" in options:
            self.profile = load_profile(options["profile"])
        self.track_class, self.speeds, self._speed_arg = int(tc), speeds, sp

    def _episode(self) -> tuple[int, tuple[float, float], Any]:
        return self.track_class, self.speeds, self.profile

    def _frame(self, state: dict[str, Any]) -> np.ndarray:
        from railgym.envs.vehicle_render import render_vehicle

        return render_vehicle(state)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Advance ``control_dt``; the action is clipped to [−1, 1], non-finite raises. The
        last step of an episode adds ``info["comfort"]``."""
        obs, reward, terminated, truncated, info = super().step(action)
        if terminated or truncated:
            info["comfort"] = self.sim.comfort(0)
        return obs, reward, terminated, truncated, info

    @property
    def state(self) -> np.ndarray:
        """Copy of the state (s,) (see :class:`VerticalVehicleVectorEnv`)."""
        return self.sim.bt.state[0].copy()

    @property
    def carbody_acceleration(self) -> np.ndarray:
        """Floor accelerations front, centre, rear at the end of the last step, m/s² (3,)."""
        return self.sim.out.acc[0, :3].copy()

    @property
    def actuator_force(self) -> np.ndarray:
        """Actuator forces front, rear applied over the last step, N (2,)."""
        return self.sim.bt.force[0].copy()

    @property
    def out_of_domain(self) -> int:
        """Out-of-domain surrogate evaluations this episode."""
        return int(self.sim.bk.ood[0])


class VerticalVehicleVectorEnv(_VehicleAccessors, BatchVectorEnv):
    """Native vector version: all sub-envs stepped in one compiled call.

    Sub-env ``i`` of ``reset(seed=s)`` reproduces ``VerticalVehicleEnv.reset(seed=s + i)``
    step for step. Autoreset mode: next step (gymnasium's default). ``infos["comfort"]``
    holds the end-of-episode figures of the sub-envs flagged in ``infos["_comfort"]``.
    Accessors as the single env's, as arrays over the sub-envs.
    """

    #: the single env whose configuration and element the sub-envs share
    single_class: type[VerticalVehicleEnv] = VerticalVehicleEnv

    def __init__(self, num_envs: int = 1, render_mode: str | None = None, **kwargs: Any) -> None:
        num_envs = val.integer(num_envs, "num_envs", min=1, max=LIMITS["num_envs"])
        single = self.single_class(render_mode=render_mode, **kwargs)
        self.cfg = single.cfg
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        one = single.sim
        self.vehicle = one.vehicle
        sim = _batch(num_envs, self.cfg, one.vehicle, one.lpr, one.v_min, *single._fmu_args)
        self._init_vector(single, sim, num_envs)

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step all sub-envs; those that ended on the previous step are reset instead."""
        obs, reward, terminated, truncated, infos = super().step(actions)
        ended = terminated | truncated
        if ended.any():
            comfort = {k: np.zeros((self.num_envs, 3)) for k in ("a_w", "a_ZP95_Wb", "Wz")}
            for i in np.flatnonzero(ended):
                for k, v in self.sim.comfort(i).items():
                    comfort[k][i] = v
            infos["comfort"], infos["_comfort"] = comfort, ended
        return obs, reward, terminated, truncated, infos


class VerticalVehicleEnvV0(VerticalVehicleEnv):
    """``VerticalVehicle-v0``: the static packaged element by default (``surrogate=`` takes
    any element, memory elements included); everything else as :class:`VerticalVehicleEnv`
    (docs/envs/vehicle_vertical.md, *Version history*)."""

    default_element = ("static", "")


class VerticalVehicleVectorEnvV0(VerticalVehicleVectorEnv):
    """Native vector version of :class:`VerticalVehicleEnvV0`."""

    single_class = VerticalVehicleEnvV0
