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
:class:`~railgym.envs.vertical.batch.VerticalBatch`, which steps any number of vehicles,
each on its own track, in one compiled call.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from railgym import _checks as val
from railgym.comfort import MIN_FS
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
from railgym.envs.track_shell import (
    ACC_WEIGHTINGS,
    MAX_NUM_ENVS,
    TRACK_BYTES,
    TrackEnvShell,
    TrackVectorShell,
    check_element_vehicle,
    check_speed_limit,
    element_arrays,
)
from railgym.envs.vertical.batch import ACC_REF, INFO_KEYS, VerticalBatch
from railgym.envs.vertical.stream import VerticalStreamBatch
from railgym.profile import load_profile
from railgym.track import class_speed
from railgym.vehicles.element_envelope import OperatingEnvelope
from railgym.vehicles.vertical.elements import LprArrays
from railgym.vehicles.vertical.kernels import DEFAULT_DT
from railgym.vehicles.vertical.params import SuspensionParams, load_vehicle

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
    "VerticalSuspensionEnvV3",
    "VerticalSuspensionVectorEnv",
    "VerticalSuspensionVectorEnvV0",
    "VerticalSuspensionVectorEnvV2",
    "VerticalSuspensionVectorEnvV3",
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


def _check_track(track_class: Any, speed: Any, speed_limit: float | None) -> tuple[int, float]:
    """Validated ``(track_class, speed)``; speed at most ``speed_limit`` (m/s, default
    :data:`~railgym.envs.params.SPEED_FACTOR` × the class's maximum speed)."""
    track_class = TrackEnvParams.check("track_class", track_class)
    v_max = class_speed(track_class)
    v = v_max if speed is None else check_speed(speed)
    check_speed_limit(v, track_class, speed, speed_limit)
    return int(track_class), v


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


def _batch(
    n: int,
    cfg: VerticalParams,
    lpr: LprArrays,
    envelope: OperatingEnvelope | None = None,
    stream: bool = False,
) -> VerticalBatch:
    """The batch of ``n`` vehicles: compiled kernels (``envelope``: the element's, behind
    ``info["outside_envelope"]``; the damper of
    :func:`~railgym.envs.damper_params.damper_law_of`), or FMU instances for
    ``backend="fmu"`` (``cfg.fmu``: the FMU file, ``cfg.fmu_map``: its mapping file,
    :mod:`railgym.fmu.mapping`). ``stream``: the track streamed
    (:class:`~railgym.envs.vertical.stream.VerticalStreamBatch`; not for the FMU)."""
    check_element_vehicle(cfg.backend, lpr, cfg.model)
    if cfg.backend != "fmu":
        batch = VerticalStreamBatch if stream else VerticalBatch
        return batch(n, cfg, cfg.model, lpr, envelope, damper_law_of(cfg))
    from railgym.envs.vertical.fmu_batch import FMUBatch
    from railgym.fmu.mapping import load_mapping

    return FMUBatch(n, cfg, cfg.model, lpr, load_mapping(cfg.fmu_map, cfg.fmu, "vertical"))


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
    #: the track generated inside the compiled step (``VerticalSuspension-v3``)
    stream_track = False
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
        self._start(_batch(1, cfg, lpr, envelope, self.stream_track), render_mode, low)

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
        from railgym.envs.vertical.render import render_vertical

        return render_vertical(state)

    def track(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the current track input ``(z, zdot)`` on the grid ``k·dt``, m and m/s: the
        whole episode's, or with a streamed track (v3) the held window from the current
        sample on."""
        return self.sim.track_arrays(0)

    def reset_on_track(self, other: VerticalSuspensionEnv) -> None:
        """Put this env at rest at the start of ``other``'s current track (same grid needed);
        its generator and options are not changed."""
        self.sim.copy_track(other.sim)
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
        sim = _batch(num_envs, self.cfg, single.sim.lpr, single.sim.envelope, single.stream_track)
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


class VerticalSuspensionEnvV3(VerticalSuspensionEnvV2):
    """``VerticalSuspension-v3``: the track streamed, generated inside the compiled step by a
    shaping filter (:mod:`railgym.track_stream`, memory per vehicle independent of
    ``duration``); everything else as :class:`VerticalSuspensionEnvV2` (docs/envs/vertical.md,
    *Version history*)."""

    stream_track = True


class VerticalSuspensionVectorEnvV3(VerticalSuspensionVectorEnv):
    """Native vector version of :class:`VerticalSuspensionEnvV3`."""

    single_class = VerticalSuspensionEnvV3
