"""``railgym/VerticalVehicle-v1``: active secondary suspension of the whole vehicle.

Carbody bounce, pitch and first bending on two bogies, four wheelsets on a seeded FRA track
or a measured/user profile (:mod:`railgym.vehicles.vehicle`); one actuator in the secondary
suspension of each bogie (``actuator="force"``), or a controllable damper at its place whose
command the agent sets (``actuator="semi-active"``, :mod:`railgym.vehicles.vehicle.damper`).
The secondary elements are the backends of
``VerticalSuspension-v1``: ``"surrogate"`` (LPR element, both bogies), ``"reference"``
(air spring with reservoir, Maxwell damper, bump stops) or ``"linear"``. Observation,
action, reward, ``info`` and the argument limits are tabulated in
``docs/envs/vehicle_vertical.md``.

The single env and the native vector env are the shells of :mod:`railgym.envs.base` around
:class:`~railgym.envs.vehicle.batch.VehicleBatch`, which steps any number of vehicles in one
compiled call (the single env is a batch of one).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from railgym import _checks as val
from railgym.envs.damper_params import DEFAULT_DAMPER, DamperArgs, damper_law_of
from railgym.envs.params import (
    REWARD_WEIGHTS,
    TrackEnvParams,
    check_speed,
    checked_keywords,
    declared,
    derived,
    limits,
    param,
)
from railgym.envs.track_shell import (
    ACC_WEIGHTINGS,
    TrackEnvShell,
    TrackVectorShell,
    check_element_vehicle,
    check_speed_limit,
    element_arrays,
)
from railgym.envs.vehicle.batch import (
    ACC_REF,
    DIVERGENCE_PENALTY,
    INFO_KEYS,
    MIN_COMFORT_SAMPLES,
    REWARD_TERMS,
    VehicleBatch,
    check_band_speed,
    episode_comfort,
)
from railgym.envs.vehicle.stream import VehicleStreamBatch
from railgym.envs.vertical.env import LIMITS as _VERTICAL_LIMITS
from railgym.profile import load_profile
from railgym.track import class_speed
from railgym.vehicles.element_envelope import OperatingEnvelope
from railgym.vehicles.vehicle.collect import default_vehicle_surrogate
from railgym.vehicles.vehicle.model import DEFAULT_DT, Params
from railgym.vehicles.vehicle.params import load_whole_vehicle

__all__ = [
    "ACC_REF",
    "ACC_WEIGHTINGS",
    "DEFAULT_WEIGHTS",
    "DIVERGENCE_PENALTY",
    "INFO_KEYS",
    "LIMITS",
    "MIN_COMFORT_SAMPLES",
    "OBSERVATIONS",
    "PREVIEW_SCALE",
    "PREVIEW_SPACING",
    "REWARD_TERMS",
    "SIZING_SPEED",
    "VehicleParams",
    "VerticalVehicleEnv",
    "VerticalVehicleEnvV0",
    "VerticalVehicleEnvV2",
    "VerticalVehicleEnvV3",
    "VerticalVehicleVectorEnv",
    "VerticalVehicleVectorEnvV0",
    "VerticalVehicleVectorEnvV2",
    "VerticalVehicleVectorEnvV3",
    "episode_comfort",
    "preview_points",
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
#: largest spacing of the preview samples, m: half the default shortest wavelength (1 m)
PREVIEW_SPACING = 0.5
#: scale of the preview channels: track height (m) and its rate under a wheelset (m/s), as the
#: wheelset inputs of ``observation="full"``
PREVIEW_SCALE = (0.01, 0.1)
DEFAULT_WEIGHTS = {"acceleration": 1.0, "deflection": 1.0, "force": 0.1}
#: lowest speed the track arrays are sized for unless the env is made with a lower one, m/s
SIZING_SPEED = 10.0


def _speeds(speed: Any, name: str) -> float | tuple[float, float]:
    """A speed (m/s) or a range ``(v_min, v_max)``, each at least the env's lowest speed."""
    if isinstance(speed, tuple | list) or (isinstance(speed, np.ndarray) and speed.ndim == 1):
        lo, hi = (check_speed(v, name) for v in val.sequence(speed, name, 2))
        if lo > hi:
            raise val.FieldError(name, f"range must have v_min <= v_max, got {speed!r}")
        return lo, hi
    return check_speed(speed, name)


def _speed_range(track_class: Any, speed: Any, speed_limit: float | None) -> tuple[float, float]:
    """``speed`` (m/s): None (class speed), a number or a ``(v_min, v_max)`` range, each at
    most ``speed_limit`` (default :data:`~railgym.envs.params.SPEED_FACTOR` × the class's
    maximum speed)."""
    track_class = VehicleParams.check("track_class", track_class)
    v_class = class_speed(track_class)
    if speed is None:
        return v_class, v_class
    checked = _speeds(speed, "speed")
    lo, hi = checked if isinstance(checked, tuple) else (checked, checked)
    check_speed_limit(hi, track_class, speed, speed_limit)
    return lo, hi


@declared
class VehicleParams(DamperArgs, TrackEnvParams):
    """The arguments of ``VerticalVehicle-v1`` (:class:`VerticalVehicleEnv`), declared once:
    defaults, units, limits (docs/envs/vehicle_vertical.md, *Arguments*)."""

    OBSERVATIONS = OBSERVATIONS

    surrogate: Any = param(
        None,
        "",
        "LPR element (static or memory form, the same at both bogies), JSON path, or `None` "
        '(the packaged whole-vehicle element); backend `"surrogate"` only',
        kind="object",
    )
    speed: Any = param(
        None,
        "m/s",
        "a number, a range `(v_min, v_max)` drawn uniformly per episode, or `None` = the "
        "class's maximum passenger speed (class 5: 144 km/h); at least 1 m/s, at most "
        "`speed_limit`",
        kind="object",
        optional=True,
        check=_speeds,
    )
    control_dt: float = param(
        0.01,
        "s",
        "agent step, a whole multiple of `dt`, below 1/60 s (the Sperling index needs a "
        "sample rate above 60 Hz)",
        lo=0.0,
        lo_open=True,
        hi=1.0 / 60.0,
        hi_open=True,
    )
    f_max: float = param(
        8000.0, "N", "force of each actuator at action ±1", lo=0.0, lo_open=True, hi=1e9
    )
    vehicle: Any = param(
        None,
        "",
        "whole-vehicle YAML: name in `configs/vehicles/` or path; `None`: "
        '`manchester_whole`, and with backend `"fmu"` the mapping\'s `vehicle:` (one of the two '
        "is required there)",
        kind="object",
        optional=True,
    )
    DEFAULT_VEHICLE: ClassVar[str] = "manchester_whole"
    FMU_ENV: ClassVar[str] = "vehicle"
    n_actuators: int = param(
        2,
        "",
        "actuators: one per bogie (per-side ones need the roll plane)",
        kind="int",
        lo=2,
        hi=2,
    )
    acc_weighting: str = param(
        "none",
        "",
        '`"Wk"`: ISO 2631-1 weighted floor accelerations in the reward',
        kind="choice",
        values=ACC_WEIGHTINGS,
    )
    flexible: bool = param(True, "", "False freezes the carbody's first bending mode", kind="bool")
    preview: float = param(
        0.0,
        "m",
        "track preview: the track height and rate (measured at the front wheelset) ahead of "
        "the rear wheelset up to this distance join the observation (*Preview*); 0: none; at "
        "most the front-to-rear wheelset distance 2(a + b) (21.56 m on `manchester_whole`)",
        lo=0.0,
    )
    preview_points: np.ndarray = derived(
        "m", "distances of the preview samples ahead of the rear wheelset (empty: no preview)"
    )

    def _default_dt(self) -> float:
        return DEFAULT_DT

    def _load_vehicle(self) -> tuple[Any, float]:
        veh = load_whole_vehicle(self.vehicle)
        return veh, veh.suspension.deflection_scale

    def _derive(self) -> None:
        super()._derive()
        speeds = _speed_range(self.track_class, self.speed, self.speed_limit)
        if self.profile is None:
            check_band_speed(self.band, speeds[1], self.dt)
        self._derive_preview()
        self._derive_damper(2)

    def _derive_preview(self) -> None:
        """The preview grid (:func:`preview_points`) and its channels appended to the
        observation: ``preview_z_i`` (m, scale 0.01), then ``preview_zdot_i`` (m/s, 0.1)."""
        points = preview_points(self.preview, self.model)
        self._set("preview_points", points)
        if points.size == 0:
            return
        idx = range(points.size)
        names = [f"preview_{q}_{i}" for q in ("z", "zdot") for i in idx]
        scales = np.repeat(np.array(PREVIEW_SCALE), points.size)
        self._set("obs_names", (*self.obs_names, *names))
        self._set("obs_scale", np.concatenate([self.obs_scale, scales]))


def preview_points(horizon: float, vehicle: Any) -> np.ndarray:
    """Distances ahead of the rear wheelset (m) of the preview samples of ``horizon`` (m):
    ``n + 1`` points ``i·horizon/n``, ``i = 0..n``, ``n = ceil(horizon / PREVIEW_SPACING)``
    (0: the track under the rear wheelset now; ``horizon`` at most the front-to-rear wheelset
    distance ``2(a + b)``, whose track the front wheelset has measured, to a rounding of
    10⁻⁹); empty for 0. FieldError naming ``preview`` beyond that distance."""
    span = float(vehicle.wheelset_positions[0] - vehicle.wheelset_positions[-1])
    if horizon > span * (1.0 + 1e-9):
        raise val.FieldError(
            "preview",
            f"{horizon!r} m is beyond the front wheelset, {span:.4g} m ahead of the rear one: "
            "the track ahead of the front wheelset is not measured; give at most "
            f"{span:.4g} m",
        )
    if horizon == 0.0:
        return np.zeros(0)
    horizon = min(horizon, span)  # a rounded full horizon ends at the front wheelset
    return np.linspace(0.0, horizon, math.ceil(horizon / PREVIEW_SPACING) + 1)


#: documented argument limits (docs/envs/vehicle_vertical.md): the declared bounds of
#: :class:`VehicleParams` and the others of ``VerticalSuspension-v1``
LIMITS = {**_VERTICAL_LIMITS, **limits(VehicleParams)}


def _batch(
    n: int,
    cfg: VehicleParams,
    lpr: Any,
    v_min: float,
    envelope: OperatingEnvelope | None = None,
    stream: bool = False,
) -> VehicleBatch:
    """The batch of ``n`` vehicles: the compiled kernel (``envelope``: the element's, behind
    ``info["outside_envelope"]``; the dampers of
    :func:`~railgym.envs.damper_params.damper_law_of`), or FMU instances for
    ``backend="fmu"`` (``cfg.fmu``, ``cfg.fmu_map``: :mod:`railgym.fmu.mapping`).
    ``stream``: the track streamed and the comfort figures online
    (:class:`~railgym.envs.vehicle.stream.VehicleStreamBatch`; not for the FMU)."""
    check_element_vehicle(cfg.backend, lpr, cfg.model)
    if cfg.backend != "fmu":
        batch = VehicleStreamBatch if stream else VehicleBatch
        return batch(n, cfg, cfg.model, lpr, v_min, envelope, damper_law_of(cfg))
    from railgym.envs.vehicle.fmu_batch import FMUVehicleBatch
    from railgym.fmu.mapping import load_mapping

    mapping = load_mapping(cfg.fmu_map, cfg.fmu, "vehicle")
    return FMUVehicleBatch(n, cfg, cfg.model, lpr, v_min, mapping)


def _vehicle_surrogate(
    backend: str, surrogate: Any, dt: float, vehicle: Any = None, grid: bool = False
) -> tuple[Any, OperatingEnvelope | None]:
    """Kernel arrays of the secondary-suspension element, the same at both bogies: a static
    (δ, δ̇) or a memory (δ, δ̇, δ − s) element, each bogie with its own Maxwell state; the
    default is the packaged whole-vehicle element (``vehicle_lpr.json``, docs/validation.md);
    and the element's operating envelope (``None``: none). ``vehicle``: the user gave the
    element, checked against that vehicle's secondary suspension (one warning when it does
    not look like it, docs/envs/vertical.md, *Element plausibility*). ``grid``: an additive
    memory element is evaluated by its Hermite tables inside its box."""
    return element_arrays(backend, surrogate, dt, relaxation=True, vehicle=vehicle, grid=grid)


class _VehicleAccessors:
    """Public read-only accessors of the simulated vehicles: arrays over the sub-envs of the
    vector env (leading axis n), sub-env 0's entry (a copy, or a Python number) for the single
    env."""

    sim: VehicleBatch
    cfg: VehicleParams
    _rows: Any

    @property
    def state(self) -> np.ndarray:
        """Copy of the state (s,): ``[z_c, θ_c, q, z_b0, θ_b0, z_b1, θ_b1]`` (m, rad, m),
        their rates, and for the reference backend the air-spring and damper states, for a
        memory surrogate element its Maxwell states ``[s_0, s_1]`` (m); semi-active: then the
        dampers' ``[u_0, w_0, u_1, w_1]``."""
        return self._rows(self.sim.arrays.state)

    @property
    def carbody_acceleration(self) -> np.ndarray:
        """Floor accelerations front, centre, rear at the end of the last step, m/s² (3,)."""
        return self._rows(self.sim.out.acc[:, :3])

    @property
    def actuator_force(self) -> np.ndarray:
        """Actuator forces front, rear applied over the last step (semi-active: the dampers'
        forces at its end), N (2,)."""
        return self._rows(self.sim.arrays.force)

    @property
    def out_of_domain(self) -> Any:
        """Out-of-domain surrogate evaluations this episode (int; vector: (n,))."""
        return self._rows(self.sim.book.ood)

    @property
    def vehicle_params(self) -> Params:
        """The vehicle's kernel parameters."""
        return self.sim.params

    @property
    def preview_points(self) -> np.ndarray:
        """Distances of the preview samples ahead of the rear wheelset, m (empty: no preview;
        docs/envs/vehicle_vertical.md, *Preview*)."""
        return self.cfg.preview_points.copy()


class VerticalVehicleEnv(_VehicleAccessors, TrackEnvShell):
    """Active secondary suspension of a whole railway vehicle (vertical plane).

    The keyword arguments are the fields of :class:`VehicleParams` (default, unit, limits and
    meaning of each: docs/envs/vehicle_vertical.md, *Arguments*) and ``render_mode``; the
    checked arguments are :attr:`cfg`. Without ``surrogate=`` the surrogate backend uses the
    whole vehicle's packaged element
    (:func:`~railgym.vehicles.vehicle.collect.default_vehicle_surrogate`);
    :attr:`default_element` is ``("static", "")`` for ``VerticalVehicle-v0``,
    :attr:`element_grid` is set for ``VerticalVehicle-v2``.

    Single-env accessors (the vector env's, of sub-env 0): :attr:`state` (s,),
    :attr:`carbody_acceleration` (3,), :attr:`actuator_force` (2,), :attr:`out_of_domain`,
    :attr:`vehicle_params`.
    """

    params_class = VehicleParams
    #: the track streamed and the comfort figures online (``VerticalVehicle-v3``)
    stream_track = False
    n_actuators = 2
    cfg: VehicleParams
    _case_attrs = ("track_class", "speeds", "profile", "_speed_arg")

    @checked_keywords(VehicleParams)
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
        n_actuators: int = 2,
        acc_weighting: str = "none",
        flexible: bool = True,
        preview: float = 0.0,
    ) -> None:
        surrogate = self._declare(VehicleParams.arguments_from(locals()))
        cfg = self.cfg
        self.speeds = _speed_range(cfg.track_class, cfg.speed, cfg.speed_limit)
        given = cfg.model if cfg.surrogate is not None else None  # the user's element
        lpr, envelope = _vehicle_surrogate(cfg.backend, surrogate, cfg.dt, given, self.element_grid)
        self.vehicle = cfg.model
        v_min = min(self.speeds[0], SIZING_SPEED)
        low = 0.0 if cfg.actuator == "semi-active" else -1.0
        self._start(_batch(1, cfg, lpr, v_min, envelope, self.stream_track), render_mode, low)

    def _default_surrogate(self) -> Any:
        """The whole vehicle's packaged element (v0: :attr:`default_element`)."""
        if self.default_element:
            return super()._default_surrogate()
        return default_vehicle_surrogate()

    def _apply_options(self, options: dict[str, Any]) -> None:
        """``track_class``, ``speed`` and ``profile`` (kept for later episodes; a new class
        without a speed uses that class's speed; ``profile=None`` returns to FRA track;
        ``hold``: :mod:`railgym.envs.base`)."""
        if not options:
            return
        tc, sp = self._track_options(options)
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

    def _case(self, sim: Any, idx: np.ndarray) -> dict[str, np.ndarray]:
        """The track shell's case (``speed``: the episode's drawn speed) and ``speed_range``,
        ``(v_min, v_max)`` m/s, the range it is drawn from (equal for a fixed speed)."""
        case = super()._case(sim, idx)
        case["speed_range"] = np.tile(np.array(self.speeds, np.float64), (len(idx), 1))
        return case

    def _frame(self, state: dict[str, Any]) -> np.ndarray:
        from railgym.envs.vehicle.render import render_vehicle

        return render_vehicle(state)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Advance ``control_dt``; the action is clipped to the action space ([−1, 1]; the
        damper commands: [0, 1]), non-finite raises. The last step of an episode adds
        ``info["comfort"]``."""
        obs, reward, terminated, truncated, info = super().step(action)
        if terminated or truncated:
            info["comfort"] = self.sim.comfort(0)
        return obs, reward, terminated, truncated, info


class VerticalVehicleVectorEnv(_VehicleAccessors, TrackVectorShell):
    """Native vector version: all sub-envs stepped in one compiled call.

    Sub-env ``i`` of ``reset(seed=s)`` reproduces ``VerticalVehicleEnv.reset(seed=s + i)``
    step for step. Autoreset mode: next step (gymnasium's default). ``infos["comfort"]``
    holds the end-of-episode figures of the sub-envs flagged in ``infos["_comfort"]``.
    Accessors as the single env's, as arrays over the sub-envs.
    """

    single_class: type[VerticalVehicleEnv] = VerticalVehicleEnv
    cfg: VehicleParams

    @checked_keywords(VehicleParams)
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
        n_actuators: int = 2,
        acc_weighting: str = "none",
        flexible: bool = True,
        preview: float = 0.0,
    ) -> None:
        args = VehicleParams.arguments_from(locals())
        num_envs, single = self._single(num_envs, render_mode, args)
        one = single.sim
        self.vehicle = one.vehicle
        stream = self.single_class.stream_track
        sim = _batch(num_envs, self.cfg, one.lpr, one.v_min, one.envelope, stream)
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


class VerticalVehicleEnvV2(VerticalVehicleEnv):
    """``VerticalVehicle-v2``: an additive memory element evaluated by its Hermite tables
    inside the box (:mod:`surrogates.models.lpr_grid`); everything else as
    :class:`VerticalVehicleEnv` (docs/envs/vehicle_vertical.md, *Version history*)."""

    element_grid = True


class VerticalVehicleVectorEnvV2(VerticalVehicleVectorEnv):
    """Native vector version of :class:`VerticalVehicleEnvV2`."""

    single_class = VerticalVehicleEnvV2


class VerticalVehicleEnvV3(VerticalVehicleEnvV2):
    """``VerticalVehicle-v3``: the track streamed, generated inside the compiled step by a
    shaping filter (:mod:`railgym.track_stream`), and the end-of-episode comfort figures
    accumulated online (:mod:`railgym.envs.vehicle.online_comfort`): memory per vehicle
    independent of ``duration``; everything else as :class:`VerticalVehicleEnvV2`
    (docs/envs/vehicle_vertical.md, *Version history*)."""

    stream_track = True


class VerticalVehicleVectorEnvV3(VerticalVehicleVectorEnv):
    """Native vector version of :class:`VerticalVehicleEnvV3`."""

    single_class = VerticalVehicleEnvV3
