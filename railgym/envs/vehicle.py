"""``railgym/VerticalVehicle-v0``: active secondary suspension of the whole vehicle.

Carbody bounce, pitch and first bending on two bogies, four wheelsets on a seeded FRA track
or a measured/user profile (:mod:`railgym.vehicles.vehicle`); one actuator in the secondary
suspension of each bogie. The secondary elements are the backends of
``VerticalSuspension-v0``: ``"surrogate"`` (LPR element, both bogies), ``"reference"``
(air spring with reservoir, Maxwell damper, bump stops) or ``"linear"``. Observation,
action, reward and ``info`` are tabulated in ``docs/envs/vehicle_vertical.md``.

The single env and the native vector env are thin shells around :class:`VehicleBatch`,
which steps any number of vehicles in one compiled call (the single env is a batch of one).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numba import njit
from scipy import signal

from railgym.comfort import WeightingFilter, sperling_wz, window_rms_p95
from railgym.envs.vector import reset_plan
from railgym.envs.vertical import BACKENDS, _surrogate_arrays
from railgym.profile import check_profile, profile_time_input, read_profile_csv
from railgym.track import class_parameters, class_speed, fra_profile_with_slope
from railgym.vehicles.vehicle import (
    DEFAULT_DT,
    Lpr,
    WholeVehicle,
    _hermite,
    advance,
    check_variant,
    kernel_params,
    load_whole_vehicle,
    make_batch,
    mode_shape,
    wheelset_offsets,
)

POINTS = ("front", "centre", "rear")
_POS = ("z_c", "theta_c", "q", "z_b0", "theta_b0", "z_b1", "theta_b1")
_POS_SCALE = (0.01, 0.001, 0.001, 0.01, 0.001, 0.01, 0.001)
OBSERVATIONS = {
    # name: (channels, scale of each channel in SI units; None = secondary free travel)
    "sensors": (
        ("acc_front", "acc_centre", "acc_rear", "bogie_acc_front", "bogie_acc_rear",
         "deflection_front", "deflection_rear", "deflection_rate_front",
         "deflection_rate_rear", "carbody_vel_front", "carbody_vel_rear"),
        (1.0, 1.0, 1.0, 10.0, 10.0, None, None, 0.1, 0.1, 0.1, 0.1),
    ),
    "full": (
        (*_POS, *(f"{n}_dot" for n in _POS), "acc_front", "acc_centre", "acc_rear",
         "bogie_acc_front", "bogie_acc_rear", "w0", "w1", "w2", "w3",
         "w0_dot", "w1_dot", "w2_dot", "w3_dot"),
        (*_POS_SCALE, *(10.0 * s for s in _POS_SCALE), 1.0, 1.0, 1.0, 10.0, 10.0,
         0.01, 0.01, 0.01, 0.01, 0.1, 0.1, 0.1, 0.1),
    ),
}  # fmt: skip
#: reference floor acceleration of the reward, m/s²: passive mean-square over the three
#: floor points on the training case (class 5, 144 km/h, reference backend) is ≈ ACC_REF²
ACC_REF = 0.6
DEFAULT_WEIGHTS = {"acceleration": 1.0, "deflection": 1.0, "force": 0.1}
DIVERGENCE_PENALTY = 100.0
ACC_WEIGHTINGS = ("none", "Wk")
#: fewest recorded control steps for which the end-of-episode comfort figures are computed
MIN_COMFORT_SAMPLES = 8


@dataclass(frozen=True)
class VehicleConfig:
    """Validated settings shared by the single and the vector env (SI units)."""

    variant: str
    dt: float
    n_sub: int
    n_steps: int
    control_dt: float
    duration: float
    f_max: float
    free_travel: float
    obs_names: tuple[str, ...]
    obs_scale: np.ndarray
    weights: tuple[float, float, float]
    acc_weighting: str
    sensor_noise: float
    band: tuple[float, float]
    flexible: bool


def make_config(
    backend: str, duration: float, control_dt: float, dt: float | None, f_max: float,
    n_actuators: int, observation: str, sensor_noise: float,
    reward_weights: dict[str, float] | None, acc_weighting: str,
    band: tuple[float, float], free_travel: float, flexible: bool,
) -> VehicleConfig:  # fmt: skip
    """Check the env arguments; every error names the argument."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {sorted(BACKENDS)}, got {backend!r}")
    variant = BACKENDS[backend]
    for name, value in (("duration", duration), ("control_dt", control_dt), ("f_max", f_max)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number, got {value!r}")
    if control_dt >= 1.0 / 60.0:
        raise ValueError(
            f"control_dt must be below 1/60 s (the Sperling index needs a sample rate above "
            f"60 Hz), got {control_dt!r}"
        )
    if n_actuators != 2:
        raise ValueError(
            f"n_actuators must be 2 (one per bogie; per-side actuators need the roll "
            f"plane), got {n_actuators!r}"
        )
    dt = DEFAULT_DT if dt is None else float(dt)
    if not (math.isfinite(dt) and 0 < dt <= control_dt):
        raise ValueError(f"dt must be positive and at most control_dt, got {dt!r}")
    n_sub = round(control_dt / dt)
    if abs(n_sub * dt - control_dt) > 1e-9 * control_dt:
        raise ValueError(f"control_dt ({control_dt} s) must be a whole multiple of dt ({dt} s)")
    n_steps = round(duration / control_dt)
    if n_steps < 1 or abs(n_steps * control_dt - duration) > 1e-9 * duration:
        raise ValueError(f"duration ({duration} s) must be a whole multiple of control_dt")
    if observation not in OBSERVATIONS:
        raise ValueError(f"observation must be one of {sorted(OBSERVATIONS)}, got {observation!r}")
    if not (math.isfinite(sensor_noise) and sensor_noise >= 0):
        raise ValueError(f"sensor_noise must be a non-negative number, got {sensor_noise!r}")
    if acc_weighting not in ACC_WEIGHTINGS:
        raise ValueError(f"acc_weighting must be one of {ACC_WEIGHTINGS}, got {acc_weighting!r}")
    weights = dict(DEFAULT_WEIGHTS)
    for key, value in (reward_weights or {}).items():
        if key not in DEFAULT_WEIGHTS:
            raise ValueError(f"reward_weights has unknown key {key!r}; keys: {list(weights)}")
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
            raise ValueError(f"reward_weights[{key!r}] must be a non-negative number")
        weights[key] = float(value)
    names, scales = OBSERVATIONS[observation]
    return VehicleConfig(
        variant=variant, dt=dt, n_sub=n_sub, n_steps=n_steps, control_dt=float(control_dt),
        duration=float(duration), f_max=float(f_max), free_travel=free_travel,
        obs_names=names, obs_scale=np.array([free_travel if s is None else s for s in scales]),
        weights=(weights["acceleration"], weights["deflection"], weights["force"]),
        acc_weighting=acc_weighting, sensor_noise=float(sensor_noise), band=tuple(band),
        flexible=bool(flexible),
    )  # fmt: skip


class Book(NamedTuple):
    """Per-vehicle bookkeeping of the env (``n`` vehicles)."""

    steps: np.ndarray  # (n,) int64 control steps done
    contacts: np.ndarray  # (n,) int64 substeps in bump-stop contact (both bogies)
    ood: np.ndarray  # (n,) int64 out-of-domain surrogate evaluations
    acc_sq: np.ndarray  # (n, 3) sum of squared floor accelerations
    rms: np.ndarray  # (n, 3) their running r.m.s., m/s²
    rec: np.ndarray  # (n, n_steps, 3) floor accelerations, m/s²
    obs: np.ndarray  # (n, n_obs) normalised observation
    rew: np.ndarray  # (n,) reward
    zi: np.ndarray  # (n, 3, n_sec, 2) Wk filter state of the reward


class StepCfg(NamedTuple):
    """Constants of :func:`control_step`."""

    n_sub: int
    dt: float
    full: bool
    inv_scale: np.ndarray
    weights: np.ndarray  # (3,) acceleration, deflection, force
    free_travel: float
    f_max: float
    sos: np.ndarray  # (n_sec, 6) Wk sections at the control rate
    weighted: bool


@njit(cache=True, error_model="numpy")
def _observe(bt, out, p, sc, bk, i):  # fmt: skip
    """Normalised observation of vehicle ``i`` into ``bk.obs[i]``."""
    x = bt.state[i]
    o = bk.obs[i]
    inv = sc.inv_scale
    if sc.full:
        for j in range(14):
            o[j] = x[j] * inv[j]
        for j in range(5):
            o[14 + j] = out.acc[i, j] * inv[14 + j]
        kk = min(float(bt.k[i]), bt.z.shape[1] - 1 - bt.off[i, 0])
        for j in range(4):
            zw, zdw = _hermite(bt.z[i], bt.zdot[i], kk + bt.off[i, j], sc.dt)
            o[19 + j] = zw * inv[19 + j]
            o[23 + j] = zdw * inv[23 + j]
        return
    for j in range(5):
        o[j] = out.acc[i, j] * inv[j]
    for b in range(2):
        xb = p.a if b == 0 else -p.a
        o[5 + b] = (x[3 + 2 * b] - x[0] - xb * x[1] - p.phi_a * x[2]) * inv[5 + b]
        vel = x[7] + xb * x[8] + p.phi_a * x[9]
        o[7 + b] = (x[10 + 2 * b] - vel) * inv[7 + b]
        o[9 + b] = vel * inv[9 + b]


@njit(cache=True, error_model="numpy")
def _weigh(sos, zi, v):
    """One sample ``v`` through the cascade ``sos`` (transposed direct form II, state zi)."""
    y = v
    for s in range(sos.shape[0]):
        b0, b1, b2, a1, a2 = sos[s, 0], sos[s, 1], sos[s, 2], sos[s, 4], sos[s, 5]
        out = b0 * y + zi[s, 0]
        zi[s, 0] = b1 * y - a1 * out + zi[s, 1]
        zi[s, 1] = b2 * y - a2 * out
        y = out
    return y


@njit(cache=True, error_model="numpy")
def control_step(kind, bt, p, e, lpr, out, bk, sc):  # fmt: skip
    """One control step of every vehicle: kernel, counters, observation and reward."""
    advance(kind, bt, sc.n_sub, sc.dt, p, e, lpr, out)
    w_a, w_d, w_f = sc.weights[0], sc.weights[1], sc.weights[2]
    for i in range(bt.state.shape[0]):
        bt.k[i] += sc.n_sub
        m = bk.steps[i]
        bk.steps[i] += 1
        bk.contacts[i] += out.count[i, 0]
        bk.ood[i] += out.count[i, 1]
        r_acc = 0.0
        for j in range(3):
            a = out.acc[i, j]
            bk.acc_sq[i, j] += a * a
            bk.rms[i, j] = math.sqrt(bk.acc_sq[i, j] / bk.steps[i])
            if m < bk.rec.shape[1]:
                bk.rec[i, m, j] = a
            if sc.weighted:
                a = _weigh(sc.sos, bk.zi[i, j], a)
            r_acc += (a / ACC_REF) ** 2
        _observe(bt, out, p, sc, bk, i)
        r_defl = 0.0
        r_force = 0.0
        x = bt.state[i]
        for b in range(2):
            xb = p.a if b == 0 else -p.a
            d = (x[3 + 2 * b] - x[0] - xb * x[1] - p.phi_a * x[2]) / sc.free_travel
            f = bt.force[i, b] / sc.f_max
            r_defl += d * d
            r_force += f * f
        bk.rew[i] = -(w_a * r_acc / 3.0 + 0.5 * w_d * r_defl + 0.5 * w_f * r_force)
        if out.div[i]:
            bk.rew[i] = -DIVERGENCE_PENALTY


def compiled_entry(fn: Any, args: tuple) -> Any:
    """Compiled entry point of the numba function ``fn`` for the types of ``args``.

    Calling it skips numba's per-call type dispatch, which for the named tuples of arrays
    of the kernels costs more than the step itself; the arrays passed later must keep the
    dtypes, dimensions and layouts of ``args`` (the batch holds them for its lifetime).
    """
    sig = tuple(fn.typeof_pyval(a) for a in args)
    if sig not in fn.overloads:
        fn.compile(sig)
    return fn.overloads[sig].entry_point


def episode_comfort(
    rec: np.ndarray, fs: float, wk: WeightingFilter, wb: WeightingFilter
) -> dict[str, np.ndarray]:
    """EN 12299 / ISO 2631 / Sperling figures per floor point of a record (n_steps, 3).

    ``a_w``: ISO 2631-1 Wk-weighted r.m.s. (filter ``wk``), m/s²; ``a_ZP95_Wb``: EN 12299 95th
    percentile of the 5-s Wb r.m.s. (filter ``wb``; one window of the whole record when it
    is shorter), m/s²; ``Wz``: Sperling ride index (vertical). Both filters start at rest
    (as :func:`~railgym.comfort.weighted_rms` and :func:`~railgym.comfort.a_zp95`).
    Records shorter than ``MIN_COMFORT_SAMPLES`` (an episode ended by divergence at once)
    give zeros.
    """
    if rec.shape[0] < MIN_COMFORT_SAMPLES:
        return {k: np.zeros(3) for k in ("a_w", "a_ZP95_Wb", "Wz")}
    window = min(5.0, rec.shape[0] / fs)
    return {
        "a_w": np.sqrt(np.mean(signal.sosfilt(wk.sos, rec, axis=0) ** 2, axis=0)),
        "a_ZP95_Wb": window_rms_p95(signal.sosfilt(wb.sos, rec, axis=0), fs, window),
        "Wz": np.array([sperling_wz(rec[:, j], fs) for j in range(3)]),
    }


def _speed_range(track_class: int, speed: Any) -> tuple[float, float]:
    """``speed`` (m/s): None (class speed), a number or a ``(v_min, v_max)`` range."""
    if speed is None:
        v = class_speed(track_class)
        return v, v
    if isinstance(speed, (tuple, list)):
        if len(speed) != 2:
            raise ValueError(f"speed range must be (v_min, v_max) in m/s, got {speed!r}")
        lo, hi = speed
    else:
        lo = hi = speed
    for v in (lo, hi):
        if isinstance(v, bool) or not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"speed must be positive numbers in m/s, got {speed!r}")
    if lo > hi:
        raise ValueError(f"speed range must have v_min <= v_max, got {speed!r}")
    return float(lo), float(hi)


def _load_profile(profile: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """None, a CSV path or an ``(x, z)`` pair, checked."""
    if profile is None:
        return None
    if isinstance(profile, (str, Path)):
        return read_profile_csv(profile)
    if not (isinstance(profile, (tuple, list)) and len(profile) == 2):
        raise ValueError("profile must be None, a CSV path or a pair (x, z) of arrays in m")
    return check_profile(profile[0], profile[1], source="profile")


class VehicleBatch:
    """``n`` whole vehicles, each on its own track, stepped by one compiled call.

    Not a Gymnasium object: the arrays of the kernel and the env's observation, reward and
    ``info`` quantities.
    """

    def __init__(self, n: int, cfg: VehicleConfig, vehicle: WholeVehicle, lpr: tuple,
                 v_min: float) -> None:  # fmt: skip
        self.n, self.cfg, self.vehicle = n, cfg, vehicle
        self.kind = check_variant(cfg.variant)
        self.params = kernel_params(vehicle, cfg.flexible)
        self.elem = vehicle.suspension.kernel_params().record()
        self.lpr = Lpr(*lpr)
        span = 2.0 * (vehicle.bogie_semi_spacing + vehicle.semi_wheelbase)
        self.v_min = v_min
        self.n_samples = cfg.n_steps * cfg.n_sub + math.ceil(span / (v_min * cfg.dt)) + 2
        self.bt, self.out = make_batch(n, cfg.variant, self.n_samples)
        n_obs = len(cfg.obs_names)
        fs = 1.0 / cfg.control_dt
        self.wk = WeightingFilter(fs, "Wk", lowpass=False)
        self.wb = WeightingFilter(fs, "Wb", lowpass=False)
        sos = self.wk.sos
        self.bk = Book(np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64),
                       np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, cfg.n_steps, 3)),
                       np.zeros((n, n_obs)), np.zeros(n),
                       np.zeros((n, 3, sos.shape[0], 2)))  # fmt: skip
        self.sc = StepCfg(cfg.n_sub, cfg.dt, cfg.obs_names[0] == "z_c", 1.0 / cfg.obs_scale,
                          np.array(cfg.weights), cfg.free_travel, cfg.f_max, sos,
                          cfg.acc_weighting == "Wk")  # fmt: skip
        self.speed = np.zeros(n)
        self.track_class = np.zeros(n, np.int64)
        self._args = (self.kind, self.bt, self.params, self.elem, self.lpr, self.out, self.bk,
                      self.sc)  # fmt: skip
        self._step = compiled_entry(control_step, self._args)

    def reset(self, i: int, rng: np.random.Generator, track_class: int,
              speeds: tuple[float, float], profile: tuple | None) -> None:  # fmt: skip
        """New track for vehicle ``i``: speed drawn in ``speeds`` (uniform, if a range), then
        a seeded FRA profile or the given one; state at rest."""
        cfg = self.cfg
        lo, hi = speeds
        v = lo if lo == hi else float(rng.uniform(lo, hi))
        if v < self.v_min:
            raise ValueError(f"speed {v} m/s is below the {self.v_min} m/s the env was made for")
        m = self.n_samples
        if profile is None:
            seed = int(rng.integers(2**63 - 1))
            dx = v * cfg.dt
            _, z, slope = fra_profile_with_slope(track_class, (m - 1) * dx, dx, seed, cfg.band)
            self.bt.z[i], self.bt.zdot[i] = z[:m], v * slope[:m]
        else:
            self.bt.z[i], self.bt.zdot[i] = profile_time_input(profile, v, cfg.dt, m)
        self.bt.off[i] = wheelset_offsets(self.vehicle, v, cfg.dt)
        self.speed[i], self.track_class[i] = v, track_class
        self.bt.force[i] = 0.0
        self.reset_state(i)

    def reset_state(self, i: int) -> None:
        """Vehicle ``i`` at rest at the start of its track, counters cleared."""
        bt, bk, out = self.bt, self.bk, self.out
        bt.state[i] = 0.0
        bt.k[i] = bk.steps[i] = bk.contacts[i] = bk.ood[i] = 0
        bk.acc_sq[i] = bk.rms[i] = bk.rec[i] = bk.zi[i] = bk.rew[i] = 0.0
        out.acc[i] = out.fs[i] = 0.0
        out.div[i] = False
        _observe(bt, out, self.params, self.sc, bk, i)

    def advance(self) -> None:
        """One control step of every vehicle with the forces in ``bt.force`` (N)."""
        self._step(*self._args)

    def observe(self, rngs: list[np.random.Generator]) -> np.ndarray:
        """Observations (n, n_obs) float32, plus sensor noise from the per-env ``rngs``."""
        obs = self.bk.obs
        if self.cfg.sensor_noise > 0:
            noise = np.stack([g.standard_normal(obs.shape[1]) for g in rngs])
            return (obs + self.cfg.sensor_noise * noise).astype(np.float32)
        return obs.astype(np.float32)

    def observe_one(self, i: int, rng: np.random.Generator) -> np.ndarray:
        """Observation (n_obs,) float32 of vehicle ``i``, noise from ``rng`` (see observe)."""
        obs = self.bk.obs[i]
        if self.cfg.sensor_noise > 0:
            return (obs + self.cfg.sensor_noise * rng.standard_normal(obs.shape[0])).astype(
                np.float32
            )
        return obs.astype(np.float32)

    def rms_acc(self) -> np.ndarray:
        """Running r.m.s. floor accelerations (n, 3), m/s²."""
        return self.bk.rms.copy()

    def comfort(self, i: int) -> dict[str, np.ndarray]:
        """:func:`episode_comfort` of vehicle ``i``'s record so far."""
        m = max(int(self.bk.steps[i]), 1)
        return episode_comfort(self.bk.rec[i, :m], 1.0 / self.cfg.control_dt, self.wk, self.wb)

    def render_state(self, i: int) -> dict[str, Any]:
        """What :func:`railgym.envs.vehicle_render.render_vehicle` draws for vehicle ``i``:
        positions from the carbody centre (m), heights (m), forces (N)."""
        bt, v = self.bt, self.vehicle
        dx = self.speed[i] * self.cfg.dt
        kk = int(bt.k[i])
        centre = kk * dx - v.wheelset_positions[-1]  # track position of the carbody centre
        half = 0.75 * v.carbody_length
        xs = np.linspace(-half, half, 301)
        grid = np.arange(self.n_samples)
        x = bt.state[i]
        xb = np.linspace(-0.5 * v.carbody_length, 0.5 * v.carbody_length, 41)
        bend = mode_shape(xb, v.carbody_length) * x[2] if self.cfg.flexible else 0.0
        return {
            "track_x": xs, "track_z": np.interp((centre + xs) / dx, grid, bt.z[i]),
            "body_x": xb, "body_z": x[0] + xb * x[1] + bend,
            "bogie_x": v.floor_positions[[0, 2]], "bogie_z": x[[3, 5]].copy(),
            "bogie_pitch": x[[4, 6]].copy(), "wheel_x": v.wheelset_positions,
            "wheel_z": np.interp(kk + bt.off[i], grid, bt.z[i]),
            "force": bt.force[i].copy(), "f_max": self.cfg.f_max,
            "time": float(self.bk.steps[i] * self.cfg.control_dt), "duration": self.cfg.duration,
        }  # fmt: skip


#: lowest speed the track arrays are sized for unless the env is made with a lower one, m/s
SIZING_SPEED = 10.0


class VerticalVehicleEnv(gym.Env[np.ndarray, np.ndarray]):
    """Active secondary suspension of a whole railway vehicle (vertical plane).

    Parameters
    ----------
    backend : ``"surrogate"`` (default), ``"reference"`` or ``"linear"`` secondary elements.
    surrogate : LPR model, path of a model JSON, or ``None`` for the packaged element.
    track_class : FRA class 1–6 (default 5).
    speed : m/s: a number, a range ``(v_min, v_max)`` drawn uniformly per episode, or
        ``None`` = the class's maximum passenger speed (class 5: 144 km/h).
    profile : ``None`` (seeded FRA track), a CSV path (columns x, z in m) or ``(x, z)``.
    duration : episode length, s (truncation). control_dt : agent step, s (< 1/60).
    dt : RK4 step, s (default ``DEFAULT_DT``, 2 ms). f_max : force of each actuator at action ±1, N.
    n_actuators : 2 (front and rear secondary suspension).
    observation : ``"sensors"`` or ``"full"``; sensor_noise : std of the additive noise on
        the normalised observation. reward_weights : ``acceleration``, ``deflection``,
        ``force``. acc_weighting : ``"none"`` or ``"Wk"`` (ISO 2631-1 weighted floor
        accelerations in the reward). band : irregularity wavelength band, m.
    vehicle : whole-vehicle YAML name/path. flexible : False freezes the bending mode.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

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
    ) -> None:
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        veh = load_whole_vehicle(vehicle)
        free = veh.suspension.bump_stop.free_travel_compression
        self.cfg = make_config(backend, duration, control_dt, dt, f_max, n_actuators,
                               observation, sensor_noise, reward_weights, acc_weighting, band,
                               free, flexible)  # fmt: skip
        self.backend = backend
        class_parameters(track_class)  # raises ValueError naming track_class
        self.track_class = int(track_class)
        self._speed_arg = speed
        self.speeds = _speed_range(self.track_class, speed)
        self.profile = _load_profile(profile)
        lpr = _surrogate_arrays(backend, surrogate)
        self.sim = VehicleBatch(1, self.cfg, veh, lpr, min(self.speeds[0], SIZING_SPEED))
        self.vehicle = veh
        self.render_mode = render_mode
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        n_obs = len(self.obs_names)
        self.observation_space = spaces.Box(-np.inf, np.inf, (n_obs,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self._started = False

    def apply_options(self, options: dict[str, Any] | None) -> None:
        """Validate and keep ``track_class``, ``speed`` and ``profile`` reset options (a new
        class without a speed uses that class's speed; ``profile=None`` returns to FRA)."""
        if not options:
            return
        unknown = set(options) - {"track_class", "speed", "profile"}
        if unknown:
            raise ValueError(f"unknown reset option(s) {sorted(unknown)}")
        tc = options.get("track_class", self.track_class)
        class_parameters(tc)
        sp = options.get("speed", self._speed_arg if "track_class" not in options else None)
        speeds = _speed_range(int(tc), sp)
        if speeds[0] < self.sim.v_min:
            raise ValueError(f"speed {sp!r} is below the {self.sim.v_min} m/s the env was made "
                             "for; make the env with that speed")  # fmt: skip
        if "profile" in options:
            self.profile = _load_profile(options["profile"])
        self.track_class, self.speeds, self._speed_arg = int(tc), speeds, sp

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """New track (and speed, if drawn); ``options``: see :meth:`apply_options`."""
        super().reset(seed=seed)
        self.apply_options(options)
        self.sim.reset(0, self.np_random, self.track_class, self.speeds, self.profile)
        self._started = True
        return self.sim.observe_one(0, self.np_random), self._info(0)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Advance ``control_dt``; the action is clipped to [−1, 1], non-finite raises."""
        if not self._started:
            raise RuntimeError("call reset() before step()")
        sim = self.sim
        a = np.asarray(action, dtype=np.float64)
        if a.shape != (2,):
            raise ValueError(f"action must have shape (2,), got {a.shape}")
        u0, u1 = float(a[0]), float(a[1])
        if not (math.isfinite(u0) and math.isfinite(u1)):
            raise ValueError(f"action must be finite, got {action!r}")
        force, f_max = sim.bt.force, self.cfg.f_max
        force[0, 0] = min(max(u0, -1.0), 1.0) * f_max
        force[0, 1] = min(max(u1, -1.0), 1.0) * f_max
        sim.advance()
        diverged = bool(sim.out.div[0])
        steps = int(sim.bk.steps[0])
        truncated = steps >= self.cfg.n_steps and not diverged
        info = self._info(steps)
        if diverged or truncated:
            self._started = False
            info["comfort"] = sim.comfort(0)
        if diverged:
            info["diverged"] = True
        return sim.observe_one(0, self.np_random), float(sim.bk.rew[0]), diverged, truncated, info

    def _info(self, steps: int) -> dict[str, Any]:
        sim = self.sim
        bk, acc = sim.bk, sim.out.acc[0].copy()
        return {
            "time": steps * self.cfg.control_dt,
            "speed": float(sim.speed[0]),
            "carbody_acc": acc[:3],
            "bogie_acc": acc[3:],
            "rms_carbody_acc": bk.rms[0].copy(),
            "bump_stop_contacts": int(bk.contacts[0]),
            "out_of_domain": int(bk.ood[0]),
            "actuator_force": sim.bt.force[0].copy(),
        }

    def render(self) -> np.ndarray | None:
        """RGB frame (H, W, 3) of the schematic when ``render_mode="rgb_array"``."""
        if self.render_mode is None:
            gym.logger.warn("render() called without render_mode; use render_mode='rgb_array'")
            return None
        from railgym.envs.vehicle_render import render_vehicle

        return render_vehicle(self.sim.render_state(0))


class VerticalVehicleVectorEnv(VectorEnv):
    """Native vector version: all sub-envs stepped in one compiled call.

    Sub-env ``i`` of ``reset(seed=s)`` reproduces ``VerticalVehicleEnv.reset(seed=s + i)``
    step for step. Autoreset mode: next step (gymnasium's default). ``infos["comfort"]``
    holds the end-of-episode figures of the sub-envs flagged in ``infos["_comfort"]``.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50,
                "autoreset_mode": AutoresetMode.NEXT_STEP}  # fmt: skip

    def __init__(self, num_envs: int = 1, render_mode: str | None = None, **kwargs: Any) -> None:
        if not (isinstance(num_envs, (int, np.integer)) and num_envs >= 1):
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        self.single_env = VerticalVehicleEnv(render_mode=render_mode, **kwargs)
        self.num_envs = int(num_envs)
        self.render_mode = render_mode
        self.cfg = self.single_env.cfg
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        one = self.single_env.sim
        self.sim = VehicleBatch(self.num_envs, self.cfg, one.vehicle, tuple(one.lpr), one.v_min)
        self.vehicle = one.vehicle
        self.single_observation_space = self.single_env.observation_space
        self.single_action_space = self.single_env.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._rngs: list[np.random.Generator | None] = []
        self._prev_done = np.zeros(self.num_envs, np.bool_)

    def _reset_one(self, i: int) -> None:
        env = self.single_env
        self.sim.reset(i, self._rngs[i], env.track_class, env.speeds, env.profile)

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the sub-envs; sub-env ``i`` is seeded with ``seed + i`` (or ``seed[i]``).

        ``options["reset_mask"]`` (bool (num_envs,)) resets only those sub-envs; the other
        options are those of :meth:`VerticalVehicleEnv.apply_options`.
        """
        if seed is not None:
            first = seed if isinstance(seed, (int, np.integer)) else seed[0]
            self._np_random, self._np_random_seed = seeding.np_random(first)
        mask, self._rngs, options = reset_plan(self.num_envs, seed, options, self._rngs)
        self.single_env.apply_options(options)
        for i in np.flatnonzero(mask):
            self._reset_one(i)
        self._prev_done[mask] = False
        return self.sim.observe(self._rngs), self._infos(np.zeros(self.num_envs, np.bool_))

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step all sub-envs; those that ended on the previous step are reset instead."""
        if not self._rngs:
            raise RuntimeError("call reset() before step()")
        sim = self.sim
        a = np.asarray(actions, dtype=np.float64)
        if a.shape != (self.num_envs, 2):
            raise ValueError(f"actions must have shape ({self.num_envs}, 2), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError("actions must be finite; got NaN or Inf")
        np.multiply(np.clip(a, -1.0, 1.0), self.cfg.f_max, out=sim.bt.force)
        done = np.flatnonzero(self._prev_done)
        for i in done:
            self._reset_one(i)
        sim.advance()
        for i in done:  # sub-envs that were reset do not move on this step
            sim.reset_state(i)
        terminated = sim.out.div.copy()
        truncated = (sim.bk.steps >= self.cfg.n_steps) & ~terminated
        reward = sim.bk.rew.copy()
        terminated[done] = truncated[done] = False
        self._prev_done = terminated | truncated
        infos = self._infos(self._prev_done)
        infos["diverged"] = terminated.copy()
        infos["_diverged"] = np.ones(self.num_envs, np.bool_)
        return sim.observe(self._rngs), reward, terminated, truncated, infos

    def _infos(self, ended: np.ndarray) -> dict[str, Any]:
        sim = self.sim
        infos: dict[str, Any] = {
            "time": sim.bk.steps * self.cfg.control_dt,
            "speed": sim.speed.copy(),
            "carbody_acc": sim.out.acc[:, :3].copy(),
            "bogie_acc": sim.out.acc[:, 3:].copy(),
            "rms_carbody_acc": sim.rms_acc(),
            "bump_stop_contacts": sim.bk.contacts.copy(),
            "out_of_domain": sim.bk.ood.copy(),
            "actuator_force": sim.bt.force.copy(),
        }
        mask = np.ones(self.num_envs, np.bool_)
        infos = {**infos, **{f"_{k}": mask for k in infos}}
        if ended.any():
            comfort = {k: np.zeros((self.num_envs, 3)) for k in ("a_w", "a_ZP95_Wb", "Wz")}
            for i in np.flatnonzero(ended):
                for k, v in sim.comfort(i).items():
                    comfort[k][i] = v
            infos["comfort"], infos["_comfort"] = comfort, ended.copy()
        return infos

    def render(self) -> tuple[np.ndarray, ...] | None:
        """One RGB frame per sub-env."""
        if self.render_mode is None:
            gym.logger.warn("render() called without render_mode; use render_mode='rgb_array'")
            return None
        from railgym.envs.vehicle_render import render_vehicle

        return tuple(render_vehicle(self.sim.render_state(i)) for i in range(self.num_envs))
