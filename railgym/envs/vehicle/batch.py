"""The batch of :mod:`railgym.envs.vehicle`: ``n`` whole vehicles stepped by one compiled call.

:class:`VehicleBatch` implements the batch contract of :mod:`railgym.envs.base`: it holds the
arrays the kernel of :mod:`railgym.vehicles.vehicle` works on, and a compiled control step
(:func:`control_step`) turns each kernel call into observation, reward, reward terms and the
counters behind the ``info`` values, whose keys are declared once (:data:`INFO_KEYS`). With
controllable dampers (``actuator="semi-active"``,
:class:`~railgym.vehicles.vehicle.damper.VehicleDampers`) the actions are their commands, the
kernel writes their forces in place of the actuator forces, and their filtered commands are
observed (last) and in ``info`` with their forces (:data:`SEMI_ACTIVE_INFO_LAYOUT`).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit
from scipy import signal

from railgym import _checks as val
from railgym.comfort import WeightingFilter, sperling_wz, window_rms_p95
from railgym.envs.batch_base import TrackBatch, draw_tracks
from railgym.envs.compiled import DIVERGENCE_PENALTY, compiled_entry, settle_reward, weigh
from railgym.envs.params import TrackEnvParams, consts
from railgym.envs.track_shell import reward_sections, track_window
from railgym.profile import profile_time_input
from railgym.track import fra_profile_window, fra_profile_with_slope
from railgym.vehicles.element_envelope import EnvelopeCheck, OperatingEnvelope
from railgym.vehicles.vehicle.damper import DAMPER_COLUMNS, VehicleDampers
from railgym.vehicles.vehicle.lanes import hermite
from railgym.vehicles.vehicle.model import (
    Lpr,
    advance,
    check_variant,
    element_lpr,
    kernel_params,
    new_arrays,
    wheelset_offsets,
)
from railgym.vehicles.vehicle.params import WholeVehicle, mode_shape
from railgym.vehicles.vertical.elements import DamperLaw
from railgym.vehicles.vertical.kernels import RAISE_MODE

__all__ = [
    "ACC_REF",
    "DIVERGENCE_PENALTY",
    "INFO_COLUMNS",
    "INFO_KEYS",
    "INFO_LAYOUT",
    "MIN_COMFORT_SAMPLES",
    "REWARD_TERMS",
    "SEMI_ACTIVE_INFO_LAYOUT",
    "VehicleBatch",
    "book_step",
    "control_step",
    "episode_comfort",
]

#: tests only: force chunked mode with windows of this many samples (None: by memory)
_FORCED_WINDOW: int | None = None

#: reference floor acceleration of the reward, m/s²: passive mean-square over the three
#: floor points on the training case (class 5, 144 km/h, reference backend) is ≈ ACC_REF²
ACC_REF = 0.6
#: fewest recorded control steps for which the end-of-episode comfort figures are computed
MIN_COMFORT_SAMPLES = 8
#: the ``info`` layout of the single and the vector env, declared once: key, shape per
#: vehicle (array-valued keys: columns of ``Book.info``, written by :func:`book_step`) and the
#: type of the single env's scalar (:meth:`VehicleBatch.info`)
INFO_LAYOUT = (
    ("time", (), float),  # s
    ("speed", (), float),  # m/s
    ("carbody_acc", (3,), float),  # floor points front, centre, rear, m/s²
    ("bogie_acc", (2,), float),  # front, rear bogie, m/s²
    ("rms_carbody_acc", (3,), float),  # running r.m.s. of carbody_acc, m/s²
    ("bump_stop_contacts", (), int),  # substeps in bump-stop contact, both bogies
    ("out_of_domain", (), int),  # out-of-domain surrogate evaluations
    ("outside_element", (), bool),  # an element evaluation of this step was outside its box
    ("outside_envelope", (), bool),  # the episode's class / speed is outside the element's envelope
    ("actuator_force", (2,), float),  # N
)
INFO_KEYS = tuple(key for key, _, _ in INFO_LAYOUT)
#: the keys ``actuator="semi-active"`` adds after :data:`INFO_LAYOUT`
SEMI_ACTIVE_INFO_LAYOUT = (
    ("damper_force", (2,), float),  # N, front and rear damper at the end of the step
    ("damper_command", (2,), float),  # their filtered commands u at the end of the step
)
#: columns of each array-valued info key in ``Book.info`` (one row is copied per single-env
#: step), in declared order (the semi-active keys after the others)
INFO_COLUMNS: dict[str, slice] = {}
for _key, _shape, _ in INFO_LAYOUT + SEMI_ACTIVE_INFO_LAYOUT:
    if _shape:
        _start = sum(c.stop - c.start for c in INFO_COLUMNS.values())
        INFO_COLUMNS[_key] = slice(_start, _start + _shape[0])
#: width of a row of ``Book.info`` without and with the dampers
INFO_ROW = INFO_COLUMNS["actuator_force"].stop
SEMI_ACTIVE_INFO_ROW = INFO_COLUMNS["damper_command"].stop
#: the columns of the array-valued keys (the single env's ``info`` takes views of them)
_S_ACC, _S_BOGIE, _S_RMS, _S_FORCE, _S_DAMPER_FORCE, _S_DAMPER_COMMAND = (
    INFO_COLUMNS[k]
    for k in (
        "carbody_acc",
        "bogie_acc",
        "rms_carbody_acc",
        "actuator_force",
        "damper_force",
        "damper_command",
    )
)
_C_ACC, _C_BOGIE, _C_RMS, _C_FORCE, _C_DAMPER_FORCE, _C_DAMPER_COMMAND = (
    c.start for c in (_S_ACC, _S_BOGIE, _S_RMS, _S_FORCE, _S_DAMPER_FORCE, _S_DAMPER_COMMAND)
)
#: columns of ``Book.terms``, the keys of ``info["reward_terms"]``
REWARD_TERMS = ("acceleration", "deflection", "force", "divergence")


def check_band_speed(band: tuple[float, float], speed: float, dt: float) -> None:
    """The FRA track is sampled every ``speed·dt`` (m), which must be below half the shortest
    wavelength ``band[0]`` (m); FieldError naming ``band`` and ``speed`` otherwise."""
    dx = speed * dt
    if not dx < 0.5 * band[0]:
        raise val.FieldError(
            "band",
            f"shortest wavelength {band[0]:g} m is not above 2·speed·dt = {2 * dx:.4g} m at "
            f"speed {speed:.4g} m/s (dt = {dt:g} s): the track cannot be sampled; raise "
            f"band[0] above {2 * dx:.4g} m, lower the speed or dt",
        )


class Book(NamedTuple):
    """Per-vehicle bookkeeping of the env (``n`` vehicles)."""

    steps: np.ndarray  # (n,) int64 control steps done
    contacts: np.ndarray  # (n,) int64 substeps in bump-stop contact (both bogies)
    ood: np.ndarray  # (n,) int64 out-of-domain surrogate evaluations
    acc_sq: np.ndarray  # (n, 3) sum of squared floor accelerations
    rms: np.ndarray  # (n, 3) their running r.m.s., m/s²
    rec: np.ndarray  # (n, n_steps, 3) floor accelerations, m/s² (float32 in chunked mode)
    obs: np.ndarray  # (n, n_obs) normalised observation
    rew: np.ndarray  # (n,) reward
    terms: np.ndarray  # (n, len(REWARD_TERMS)) weighted reward terms, summing to rew
    zi: np.ndarray  # (n, 3, n_sec, 2) Wk filter state of the reward
    action: np.ndarray  # (n, 2) clipped actions of the step
    info: np.ndarray  # (n, INFO_ROW) the array-valued info entries of the step (INFO_COLUMNS)
    truncated: np.ndarray  # (n,) bool episode reached duration
    extrapolated: np.ndarray  # (n,) bool out-of-domain evaluations under the "raise" policy


class StepCfg(NamedTuple):
    """Constants of :func:`control_step`."""

    n_sub: int
    dt: float
    full: bool
    inv_scale: np.ndarray
    weights: np.ndarray  # (3,) acceleration, deflection, force
    free_travel: float
    f_max: float
    sos: np.ndarray  # (n_sec, 6) the reward's weighting of the floor accelerations
    n_steps: int  # control steps per episode (truncation)
    flag_ood: bool  # "raise" policy: flag steps with out-of-domain surrogate evaluations
    preview_frac: np.ndarray  # (n_p,) preview points as fractions of the front wheelset's offset
    semi_active: bool  # controllable dampers: their filtered commands observed and in info


@njit(cache=True, error_model="numpy")
def _observe(vehicles, out, params, consts, book, i):
    """Normalised observation of vehicle ``i`` into ``book.obs[i]`` (``vehicles``: the
    kernel's :class:`~railgym.vehicles.vehicle.model.VehicleArrays`, ``params`` its
    :class:`~railgym.vehicles.vehicle.model.Params`): the channels of ``observation``, then the
    preview samples (heights, then rates) at ``consts.preview_frac`` of the front wheelset's
    distance ahead of the rear one, then with dampers their filtered commands ``u_0, u_1``
    (the state's columns −4 and −2)."""
    x = vehicles.state[i]
    o = book.obs[i]
    inv = consts.inv_scale
    start = vehicles.start[i]
    kk = min(float(vehicles.k[i]), start + vehicles.z.shape[1] - 1 - vehicles.off[i, 0])
    if consts.full:
        for j in range(14):
            o[j] = x[j] * inv[j]
        for j in range(5):
            o[14 + j] = out.acc[i, j] * inv[14 + j]
        for j in range(4):
            pos = kk + vehicles.off[i, j]
            zw, zdw = hermite(vehicles.z[i], vehicles.zdot[i], pos, consts.dt, start)
            o[19 + j] = zw * inv[19 + j]
            o[23 + j] = zdw * inv[23 + j]
        n_obs = 27
    else:
        for j in range(5):
            o[j] = out.acc[i, j] * inv[j]
        for b in range(2):
            xb = params.a if b == 0 else -params.a
            o[5 + b] = (x[3 + 2 * b] - x[0] - xb * x[1] - params.phi_a * x[2]) * inv[5 + b]
            vel = x[7] + xb * x[8] + params.phi_a * x[9]
            o[7 + b] = (x[10 + 2 * b] - vel) * inv[7 + b]
            o[9 + b] = vel * inv[9 + b]
        n_obs = 11
    n_p = consts.preview_frac.shape[0]
    for j in range(n_p):
        pos = kk + vehicles.off[i, 0] * consts.preview_frac[j]
        zp, zdp = hermite(vehicles.z[i], vehicles.zdot[i], pos, consts.dt, start)
        o[n_obs + j] = zp * inv[n_obs + j]
        o[n_obs + n_p + j] = zdp * inv[n_obs + n_p + j]
    if consts.semi_active:
        s = x.shape[0] - DAMPER_COLUMNS
        for b in range(2):
            j = n_obs + 2 * n_p + b
            o[j] = x[s + 2 * b] * inv[j]


# Without the runtime's reference counting: the arrays come from the batch, which owns them
# for the call, so the entry point unboxes them without runtime records and the kernel's
# counting of every array it passes on (per RK4 stage) is skipped. The kernel's own scratch
# arrays are still allocated and freed by the runtime
# (tests/envs/vehicle/test_vehicle_shell.py checks the balance).
@njit(cache=True, error_model="numpy", _nrt=False)
def control_step(kind, vehicles, params, element, lpr, out, book, consts, damper):
    """One control step of every vehicle: actuator forces ``book.action · f_max`` (N), the
    kernel (:func:`~railgym.vehicles.vehicle.model.advance` of ``kind`` on ``vehicles``, with the
    vehicle's ``params``, the suspension ``element`` record and the surrogate ``lpr``), then
    :func:`book_step`. With ``damper`` (:class:`~railgym.vehicles.vehicle.damper.VehicleDampers`
    whose commands are ``book.action``, else ``None``) the kernel writes the dampers' forces
    instead."""
    if damper is None:
        for i in range(vehicles.state.shape[0]):
            for b in range(2):
                vehicles.force[i, b] = book.action[i, b] * consts.f_max
    advance(kind, vehicles, consts.n_sub, consts.dt, params, element, lpr, out, damper)
    book_step(vehicles, params, out, book, consts)


@njit(cache=True, error_model="numpy", _nrt=False)
def book_step(vehicles, params, out, book, consts):
    """The bookkeeping of :func:`control_step` after the kernel call (also run after an
    FMU's step, :mod:`railgym.envs.vehicle.fmu_batch`): counters, floor-acceleration record,
    observation, reward and its terms (:func:`~railgym.envs.compiled.settle_reward`: a
    divergence also when the reward is not finite or the observation too large), info row and
    the truncated and extrapolated flags."""
    w_a, w_d, w_f = consts.weights[0], consts.weights[1], consts.weights[2]
    for i in range(vehicles.state.shape[0]):
        vehicles.k[i] += consts.n_sub
        m = book.steps[i]
        book.steps[i] += 1
        book.contacts[i] += out.count[i, 0]
        book.ood[i] += out.count[i, 1]
        r_acc = 0.0
        for j in range(3):
            a = out.acc[i, j]
            book.acc_sq[i, j] += a * a
            book.rms[i, j] = math.sqrt(book.acc_sq[i, j] / book.steps[i])
            if m < book.rec.shape[1]:
                book.rec[i, m, j] = a
            r_acc += (weigh(consts.sos, book.zi[i, j], a) / ACC_REF) ** 2
        _observe(vehicles, out, params, consts, book, i)
        r_defl = 0.0
        r_force = 0.0
        x = vehicles.state[i]
        for b in range(2):
            xb = params.a if b == 0 else -params.a
            d = (x[3 + 2 * b] - x[0] - xb * x[1] - params.phi_a * x[2]) / consts.free_travel
            f = vehicles.force[i, b] / consts.f_max
            r_defl += d * d
            r_force += f * f
        t_a = -(w_a * r_acc / 3.0)
        t_d = -(0.5 * w_d * r_defl)
        t_f = -(0.5 * w_f * r_force)
        settle_reward(book.obs, book.terms, book.rew, out.div, i, t_a, t_d, t_f)
        for j in range(3):
            book.info[i, _C_ACC + j] = out.acc[i, j]
            book.info[i, _C_RMS + j] = book.rms[i, j]
        for b in range(2):
            book.info[i, _C_BOGIE + b] = out.acc[i, 3 + b]
        for b in range(2):
            book.info[i, _C_FORCE + b] = vehicles.force[i, b]
        if consts.semi_active:
            s = x.shape[0] - DAMPER_COLUMNS
            for b in range(2):
                book.info[i, _C_DAMPER_FORCE + b] = vehicles.force[i, b]
                book.info[i, _C_DAMPER_COMMAND + b] = x[s + 2 * b]
        book.truncated[i] = book.steps[i] >= consts.n_steps
        if consts.flag_ood:
            book.extrapolated[i] = out.count[i, 1] > 0


def episode_comfort(
    rec: np.ndarray, fs: float, wk: WeightingFilter, wb: WeightingFilter
) -> dict[str, np.ndarray]:
    """EN 12299 / ISO 2631 / Sperling figures per floor point of a record (n_steps, 3).

    ``a_w``: ISO 2631-1 Wk-weighted r.m.s. (filter ``wk``), m/s²; ``a_ZP95_Wb``: EN 12299 95th
    percentile of the 5-s Wb r.m.s. (filter ``wb``; one window of the whole record when it
    is shorter), m/s²; ``Wz``: Sperling ride index (vertical). Both filters start at rest
    (as :func:`~railgym.comfort.weighted_rms` and :func:`~railgym.comfort.a_zp95`).
    Records shorter than ``MIN_COMFORT_SAMPLES`` (an episode ended by divergence at once)
    give zeros. The figures are computed in float64 (a float32 record of chunked mode is
    cast first).
    """
    rec = np.asarray(rec, np.float64)
    if rec.shape[0] < MIN_COMFORT_SAMPLES:
        return {k: np.zeros(3) for k in ("a_w", "a_ZP95_Wb", "Wz")}
    window = min(5.0, rec.shape[0] / fs)
    return {
        "a_w": np.sqrt(np.mean(signal.sosfilt(wk.sos, rec, axis=0) ** 2, axis=0)),
        "a_ZP95_Wb": window_rms_p95(signal.sosfilt(wb.sos, rec, axis=0), fs, window),
        "Wz": np.array([sperling_wz(rec[:, j], fs) for j in range(3)]),
    }


def _new_book(
    n: int, n_steps: int, n_obs: int, sos: np.ndarray, rows: int, rec_dtype: type
) -> Book:
    """Zeroed :class:`Book` of ``n`` vehicles: ``n_steps`` control steps recorded as
    ``rec_dtype``, ``n_obs`` observations, the reward's weighting ``sos`` (n_sec, 6) and
    ``rows`` info columns."""
    return Book(
        steps=np.zeros(n, np.int64),
        contacts=np.zeros(n, np.int64),
        ood=np.zeros(n, np.int64),
        acc_sq=np.zeros((n, 3)),
        rms=np.zeros((n, 3)),
        rec=np.zeros((n, n_steps, 3), rec_dtype),
        obs=np.zeros((n, n_obs)),
        rew=np.zeros(n),
        terms=np.zeros((n, len(REWARD_TERMS))),
        zi=np.zeros((n, 3, sos.shape[0], 2)),
        action=np.zeros((n, 2)),
        info=np.zeros((n, rows)),
        truncated=np.zeros(n, np.bool_),
        extrapolated=np.zeros(n, np.bool_),
    )


class VehicleBatch(TrackBatch):
    """``n`` whole vehicles, each on its own track, stepped by one compiled call.

    Not a Gymnasium object: the batch of :mod:`railgym.envs.base` (its contract is there).
    It holds the arrays of the kernel and computes observation, reward, its terms and the
    ``info`` quantities of :class:`~railgym.envs.vehicle.env.VerticalVehicleEnv`. The track
    arrays are sized for speeds down to ``v_min`` (m/s). ``envelope``: the operating envelope
    of the surrogate element (``None``: none, or not the surrogate backend), behind
    ``info["outside_envelope"]`` and the warning of the first episode outside it. ``damper``:
    the law of the controllable dampers of ``actuator="semi-active"`` (``None``: the actuator
    forces).
    """

    REWARD_TERMS = REWARD_TERMS
    _VIEWS = (
        *("reward", "obs", "_terms", "_truncated", "extrapolated", "_flags", "_info_scalars"),
        *("dampers", "_args", "_step", "_outside_count"),
    )

    def __init__(
        self,
        n: int,
        cfg: TrackEnvParams,
        vehicle: WholeVehicle,
        lpr: Lpr,
        v_min: float,
        envelope: OperatingEnvelope | None = None,
        damper: DamperLaw | None = None,
    ) -> None:
        self.n, self.cfg, self.vehicle = n, cfg, vehicle
        self.damper = damper
        #: the ``info`` layout of this batch (with dampers: :data:`SEMI_ACTIVE_INFO_LAYOUT`)
        self.info_layout = INFO_LAYOUT + (() if damper is None else SEMI_ACTIVE_INFO_LAYOUT)
        self.kind = check_variant(cfg.variant)
        self.params = kernel_params(vehicle, cfg.flexible)
        self.elem = vehicle.suspension.kernel_params().record()
        self.lpr = element_lpr(lpr)  # the LPR fields (a Kriging is refused)
        self.span = 2.0 * (vehicle.bogie_semi_spacing + vehicle.semi_wheelbase)  # m
        self.v_min = v_min
        #: samples from the rear to the front wheelset at ``v_min``
        self.reach = math.ceil(self.span / (v_min * cfg.dt))
        #: samples of an episode's track (rear wheelset's time grid, front wheelset ahead)
        self.n_samples = cfg.n_steps * cfg.n_sub + self.reach + 2
        sos = reward_sections(cfg.acc_weighting, cfg.control_dt)
        rows = INFO_ROW if damper is None else SEMI_ACTIVE_INFO_ROW
        held, rec_steps, rec_dtype = self._storage(n, sos, rows)
        self.arrays, self.out = new_arrays(n, cfg.variant, held, self.lpr, damper is not None)
        self._episodes(n)
        fs = 1.0 / cfg.control_dt
        self.wk = WeightingFilter(fs, "Wk", lowpass=False)
        self.wb = WeightingFilter(fs, "Wb", lowpass=False)
        self.book = _new_book(n, rec_steps, len(cfg.obs_names), sos, rows, rec_dtype)
        self.step_consts = consts(
            StepCfg,
            cfg,
            full=cfg.observation == "full",
            inv_scale=1.0 / cfg.obs_scale,
            weights=np.array(cfg.weights),
            sos=sos,
            flag_ood=self.lpr.mode == RAISE_MODE,
            preview_frac=self._preview_fractions(),
            semi_active=damper is not None,
        )
        self.envelope = envelope
        self._envelope_check = EnvelopeCheck(envelope, "VerticalVehicle")
        #: per step: an element evaluation was outside the training box (``outside_element``)
        self.outside = np.zeros(n, np.bool_)
        #: per episode: its class / speed is outside :attr:`envelope` (``outside_envelope``)
        self.off_envelope = np.zeros(n, np.bool_)
        self._link()

    def _storage(self, n: int, sos: np.ndarray, rows: int) -> tuple[int, int, type]:
        """Track samples held per vehicle (:attr:`window`: None when the whole episode), and
        the control steps and dtype of the comfort record."""
        cfg = self.cfg
        #: samples held per vehicle in chunked mode (None: the whole episode); chunked, the
        #: windows, the float32 records and the other per-vehicle arrays share the budget
        self.window = track_window(
            n,
            self.n_samples,
            24 * cfg.n_steps,
            cfg.n_sub + self.reach + 2,
            "track, record and bookkeeping arrays",
            _FORCED_WINDOW,
            chunk_bytes=12 * cfg.n_steps + self._vehicle_bytes(len(cfg.obs_names), sos, rows),
        )
        held = self.n_samples if self.window is None else self.window
        # chunked: the floor accelerations as float32 (the figures in float64, episode_comfort)
        return held, cfg.n_steps, np.float64 if self.window is None else np.float32

    def _vehicle_bytes(self, n_obs: int, sos: np.ndarray, rows: int) -> int:
        """Bytes per vehicle of the arrays held besides the track and the comfort record:
        kernel arrays, outputs and bookkeeping (measured on one vehicle) and the batch's own
        per-vehicle arrays (speed, class, seed, three flags)."""
        arrays, out = new_arrays(1, self.cfg.variant, 0, self.lpr, self.damper is not None)
        book = _new_book(1, 0, n_obs, sos, rows, np.float32)
        held = sum(a.nbytes for a in (*arrays, *out, *book))
        return held + 3 * 8 + 3 * 1

    def _preview_fractions(self) -> np.ndarray:
        """The preview points (``cfg.preview_points``, m) as fractions of the front
        wheelset's distance ahead of the rear one (1: the front wheelset)."""
        points = getattr(self.cfg, "preview_points", np.zeros(0))
        positions = self.vehicle.wheelset_positions
        return np.asarray(points, np.float64) / (positions[0] - positions[-1])

    def _link(self) -> None:
        """Views and the compiled entry point (re-made after a copy: not picklable)."""
        self.reward, self.obs, self._terms = self.book.rew, self.book.obs, self.book.terms
        self._truncated = self.book.truncated
        #: float64 (n, 2) the actions of the next step (the batch contract)
        self.actions = self.book.action
        self.extrapolated = self.book.extrapolated
        #: the per-vehicle arrays of the scalar info keys (``time`` is computed)
        self._info_scalars = {
            "speed": self.speed,
            "bump_stop_contacts": self.book.contacts,
            "out_of_domain": self.book.ood,
            "outside_element": self.outside,
            "outside_envelope": self.off_envelope,
        }
        self._flags = {"diverged": self.out.div, "extrapolated": self.extrapolated}
        #: per vehicle the step's element evaluations outside the box (read after each step)
        self._outside_count = self.out.count[:, 1]
        #: the dampers read their commands from the stored actions
        self.dampers = (
            None if self.damper is None else VehicleDampers(self.damper, self.book.action)
        )
        self._args = (
            self.kind,
            self.arrays,
            self.params,
            self.elem,
            self.lpr,
            self.out,
            self.book,
            self.step_consts,
            self.dampers,
        )
        self._step = compiled_entry(control_step, self._args)

    def _start(
        self, i: int, rng: np.random.Generator, episode: tuple[int, tuple[float, float], Any]
    ) -> None:
        """Vehicle ``i``'s episode ``(track_class, (v_min, v_max), profile)``: speed drawn
        uniformly in the range (when not a single value), then a seeded FRA profile
        (``profile=None``) or the given ``(x, z)``."""
        cfg = self.cfg
        track_class, (lo, hi), profile = episode
        v = lo if lo == hi else float(rng.uniform(lo, hi))
        if v < self.v_min:
            raise val.FieldError(
                "speed", f"{v} m/s is below the {self.v_min} m/s the env was made for"
            )
        self._set_episode(i, rng, track_class, v, profile)
        if profile is None:
            check_band_speed(cfg.band, v, cfg.dt)
        self.arrays.off[i] = wheelset_offsets(self.vehicle, v, cfg.dt)
        self.arrays.force[i] = 0.0

    def _track(self) -> tuple[np.ndarray, np.ndarray]:
        return self.arrays.z, self.arrays.zdot

    def _fill(self, i: int, start: int) -> None:
        """Chunked mode: vehicle ``i``'s window from episode sample ``start`` on (the
        episode's track drawn again, bit for bit the whole arrays' values)."""
        cfg, arrays = self.cfg, self.arrays
        held, m = arrays.z.shape[1], self.n_samples
        v, profile = float(self.speed[i]), self._profiles[i]
        if profile is None:
            dx = v * cfg.dt
            z, slope = fra_profile_window(
                int(self.track_class[i]),
                (m - 1) * dx,
                dx,
                int(self._seeds[i]),
                start,
                held,
                cfg.band,
            )
            arrays.z[i], arrays.zdot[i] = z, v * slope
        else:
            z, zdot = profile_time_input(
                profile, v, cfg.dt, m, length=v * cfg.n_steps * cfg.control_dt + self.span
            )
            arrays.z[i], arrays.zdot[i] = z[start : start + held], zdot[start : start + held]
        arrays.start[i] = start

    def _cover_step(self) -> None:
        """Chunked mode: move the window of every vehicle whose next control step (front
        wheelset ``k + n_sub + off[0]``) would run past it to start at its current sample
        ``k``, or to end at the episode's last sample."""
        arrays, held = self.arrays, self.arrays.z.shape[1]
        ahead = arrays.k - arrays.start + self.cfg.n_sub + arrays.off[:, 0]
        late = np.flatnonzero((ahead > held - 1) & (arrays.start < self.n_samples - held))
        draw_tracks(late, lambda i: self._fill(i, min(int(arrays.k[i]), self.n_samples - held)))

    def _episode_track(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Vehicle ``i``'s whole episode track ``(z, zdot)`` on the rear wheelset's time grid
        (m, m/s) drawn from its seed or profile."""
        cfg, m, v = self.cfg, self.n_samples, float(self.speed[i])
        if self._profiles[i] is not None:
            length = v * cfg.n_steps * cfg.control_dt + self.span
            return profile_time_input(self._profiles[i], v, cfg.dt, m, length=length)
        dx = v * cfg.dt
        track_class, seed = int(self.track_class[i]), int(self._seeds[i])
        _, z, slope = fra_profile_with_slope(track_class, (m - 1) * dx, dx, seed, cfg.band)
        return z[:m], v * slope[:m]

    def reset_state(self, i: int) -> None:
        """Vehicle ``i`` at rest at the start of its track, counters cleared; its
        ``outside_envelope`` set for the episode (a ``UserWarning`` the first time)."""
        arrays, book, out = self.arrays, self.book, self.out
        if self.window is not None and arrays.start[i] != 0:
            self._fill(i, 0)
        arrays.state[i] = 0.0
        arrays.k[i] = book.steps[i] = book.contacts[i] = book.ood[i] = 0
        book.acc_sq[i] = book.rms[i] = book.rec[i] = book.zi[i] = book.rew[i] = book.terms[i] = 0.0
        book.info[i] = arrays.force[i] = out.acc[i] = out.fs[i] = 0.0
        out.div[i] = book.extrapolated[i] = book.truncated[i] = self.outside[i] = False
        self.off_envelope[i] = self._outside_envelope(i)
        _observe(arrays, out, self.params, self.step_consts, book, i)

    def advance(self) -> None:
        """One control step of every vehicle with :attr:`actions` (``action · f_max``, N, or
        with dampers their commands; one compiled call; in
        chunked mode the windows the step would run past are moved first)."""
        super().advance()
        # the step had an element evaluation (any RK4 stage, either bogie) outside the box
        np.greater(self._outside_count, 0, out=self.outside)

    def info(self, i: int | None = None) -> dict[str, Any]:
        """The :data:`INFO_LAYOUT` (with dampers also :data:`SEMI_ACTIVE_INFO_LAYOUT`) of
        vehicle ``i`` (Python numbers and views of one fresh copy of its info row) or of all
        (arrays with a leading axis n); copies."""
        book, dt = self.book, self.cfg.control_dt
        if i is None:
            scalars = self._info_scalars
            return {
                key: book.steps * dt
                if key == "time"
                else (book.info[:, INFO_COLUMNS[key]] if shape else scalars[key]).copy()
                for key, shape, _ in self.info_layout
            }
        row = book.info[i].copy()
        info = {
            "time": book.steps.item(i) * dt,
            "speed": self.speed.item(i),
            "carbody_acc": row[_S_ACC],
            "bogie_acc": row[_S_BOGIE],
            "rms_carbody_acc": row[_S_RMS],
            "bump_stop_contacts": book.contacts.item(i),
            "out_of_domain": book.ood.item(i),
            "outside_element": self.outside.item(i),
            "outside_envelope": self.off_envelope.item(i),
            "actuator_force": row[_S_FORCE],
        }
        if self.damper is not None:
            info["damper_force"], info["damper_command"] = (
                row[_S_DAMPER_FORCE],
                row[_S_DAMPER_COMMAND],
            )
        return info

    def outcome(self, i: int) -> tuple[float, bool, bool, dict[str, Any]]:
        """``(reward, terminated, truncated, info)`` of vehicle ``i`` as the single env's step
        returns them (the batch contract): :meth:`info` with ``reward_terms`` and each flag set
        this step (``diverged``, ``extrapolated``), read directly from the arrays."""
        book = self.book
        info = self.info(i)
        acc, defl, force, div = book.terms[i].tolist()
        info["reward_terms"] = {
            "acceleration": acc,
            "deflection": defl,
            "force": force,
            "divergence": div,
        }
        terminated = False
        if self.out.div.item(i):
            info["diverged"] = terminated = True
        if book.extrapolated.item(i):
            info["extrapolated"] = terminated = True
        return book.rew.item(i), terminated, not terminated and book.truncated.item(i), info

    def comfort(self, i: int) -> dict[str, np.ndarray]:
        """:func:`episode_comfort` of vehicle ``i``'s record so far."""
        m = max(int(self.book.steps[i]), 1)
        return episode_comfort(self.book.rec[i, :m], 1.0 / self.cfg.control_dt, self.wk, self.wb)

    def _render_track(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Vehicle ``i``'s track heights (m) that :meth:`render_state` draws, their indices."""
        z = self.arrays.z[i] if self.window is None else self.track_arrays(i)[0]
        return z, np.arange(self.n_samples)

    def render_state(self, i: int) -> dict[str, Any]:
        """What :func:`railgym.envs.vehicle.render.render_vehicle` draws for vehicle ``i``:
        positions from the carbody centre (m), heights (m), forces (N); in chunked mode the
        track is drawn again for it."""
        arrays, v = self.arrays, self.vehicle
        dx = self.speed[i] * self.cfg.dt
        kk = int(arrays.k[i])
        centre = kk * dx - v.wheelset_positions[-1]  # track position of the carbody centre
        half = 0.75 * v.carbody_length
        xs = np.linspace(-half, half, 301)
        z, grid = self._render_track(i)
        x = arrays.state[i]
        xb = np.linspace(-0.5 * v.carbody_length, 0.5 * v.carbody_length, 41)
        bend = mode_shape(xb, v.carbody_length) * x[2] if self.cfg.flexible else 0.0
        return {
            "track_x": xs,
            "track_z": np.interp((centre + xs) / dx, grid, z),
            "body_x": xb,
            "body_z": x[0] + xb * x[1] + bend,
            "bogie_x": v.floor_positions[[0, 2]],
            "bogie_z": x[[3, 5]].copy(),
            "bogie_pitch": x[[4, 6]].copy(),
            "wheel_x": v.wheelset_positions,
            "wheel_z": np.interp(kk + arrays.off[i], grid, z),
            "force": arrays.force[i].copy(),
            "f_max": self.cfg.f_max,
            "time": float(self.book.steps[i] * self.cfg.control_dt),
            "duration": self.cfg.duration,
            "speed": self.speed.item(i),
            "carbody_acc": float(self.out.acc[i, 1]),  # centre floor point, m/s²
        }
