"""``railgym/TrainCrash-v1``: adaptive crash energy management of a train hitting a wall.

A lead car and ``n_cars − 1`` passenger cars run into a rigid wall (or a free deformable
obstacle) from the scenario's speed (default: the paper's table 9 case, 40 km/h), or — for a
scenario with an ``envelope`` (``"envelope"``: 25–50 km/h and a payload per car) — from
conditions drawn at each reset from the env's ``np_random``. Every crush zone — the lead car's
front end at the wall and each interface between two cars — holds a controllable absorber:
the agent sets the force level of each absorber between 0.7 and 1.3 times nominal
(rate-limited), trading the cars' decelerations against crush beyond the absorbers' stroke,
i.e. loss of survival space. Action 0 everywhere is the passive train.

The physics is in :mod:`railgym.vehicles.crash`: ``backend="reference"`` is the lumped-mass
chain with hysteretic crush zones (``simulate_reference``), ``"surrogate"`` the paper's eq. (4)
with surrogate elements (packaged ones, else fitted on a reference run of the scenario). The
single env and the native vector env are the shells of :mod:`railgym.envs.base` around
:class:`~railgym.envs.crash.batch.CrashBatch`, which steps any number of trains in one
compiled call. ``info`` carries the crash criteria of
:mod:`railgym.vehicles.crash.criteria` with the scenario's limits. See ``docs/envs/crash.md``.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces

from railgym import _checks as val
from railgym.envs.base import BatchEnv, BatchVectorEnv
from railgym.envs.crash.batch import CrashBatch
from railgym.envs.crash.layout import INFO_FIELDS, REWARD_TERMS
from railgym.envs.crash.params import BACKENDS, DEFAULT_WEIGHTS, CrashParams, nominal_force
from railgym.envs.params import checked_keywords
from railgym.vehicles.crash.elements import packaged_surrogate, packaged_trains
from railgym.vehicles.crash.model import CrashModel, crash_model
from railgym.vehicles.crash.reference import simulate_reference
from railgym.vehicles.crash.scenario import LIMITS, CrashScenario
from railgym.vehicles.crash.surrogate import CrashSurrogate, NoUnloadingError, build_crash_surrogate

__all__ = [
    "BACKENDS",
    "CrashBatch",
    "CrashParams",
    "DEFAULT_WEIGHTS",
    "INFO_FIELDS",
    "MAX_NUM_ENVS",
    "OPTIONS",
    "REWARD_TERMS",
    "TrainCrashEnv",
    "TrainCrashEnvV0",
    "TrainCrashVectorEnv",
    "TrainCrashVectorEnvV0",
    "default_surrogate",
    "env_surrogate",
    "make_model",
    "nominal_force",
]

#: most sub-envs of the vector env
MAX_NUM_ENVS = 65536
#: the reset options (impact conditions, in the scenario file's units)
OPTIONS = ("speed_kmh", "payload_t")


@functools.lru_cache(maxsize=16)
def default_surrogate(scenario: CrashScenario, variant: str = "hysteretic") -> CrashSurrogate:
    """Surrogate elements fitted on a passive reference run of ``scenario`` (cached per
    scenario, i.e. per name/file, number of cars and speed, and process).

    Raises
    ------
    ValueError
        That run cannot be fitted (e.g. it holds no elastic unloading); the message says that
        the elements are fitted on this run and what to give instead.
    """
    try:
        return build_crash_surrogate(simulate_reference(scenario), variant=variant, seed=0)
    except ValueError as err:
        raise ValueError(_unfittable(scenario, variant, err)) from err


def _unfittable(scenario: CrashScenario, variant: str, err: ValueError) -> str:
    """The message of a :func:`default_surrogate` that cannot be fitted on its run."""
    case = (
        f"n_cars={scenario.n_cars}, speed={scenario.speed:g} m/s = {3.6 * scenario.speed:.4g} km/h"
    )
    if isinstance(err, NoUnloadingError):
        why = (
            f"this case gives no elastic unloading of the {err.element} element (its zone never "
            "springs back under load), so its unloading stiffness k_u cannot be estimated"
        )
    else:
        why = f"they cannot be fitted on it: {err}"
    packaged = "; ".join(packaged_trains(variant)) or "none"
    return (
        f"scenario {scenario.name!r}: the default surrogate elements (what backend='surrogate' "
        "uses without surrogate= when no packaged elements fit the train) are fitted on a "
        f"passive reference run of this scenario ({case}), and {why}. Use a packaged train at "
        f"a speed within its envelope (packaged: {packaged}), or give surrogate= elements "
        "fitted on your own runs (railgym.vehicles.crash.surrogate.build_crash_surrogate, or "
        "railgym crash-fe from LS-DYNA output)"
    )


@functools.lru_cache(maxsize=16)
def env_surrogate(
    scenario: CrashScenario, variant: str = "hysteretic", release: str = ""
) -> CrashSurrogate:
    """The elements ``gym.make`` uses without ``surrogate=``: the packaged envelope elements
    of the scenario's train (:func:`railgym.vehicles.crash.elements.packaged_surrogate`; those
    of ``release``, e.g. ``"v0"`` for ``TrainCrash-v1``), else :func:`default_surrogate`
    (fitted once per process); cached per scenario and process."""
    packaged = packaged_surrogate(scenario, variant, release)
    return packaged if packaged is not None else default_surrogate(scenario, variant)


def make_model(cfg: CrashParams, release: str = "") -> CrashModel:
    """Batch model of the configured backend, with ``cfg.surrogate`` or, if ``None``, the
    :func:`env_surrogate` of ``release``."""
    surrogate = cfg.surrogate
    if cfg.backend == "reference":
        if surrogate is not None:
            raise ValueError("surrogate is only used by backend='surrogate', not 'reference'")
        return crash_model(cfg.scenario, "reference", cfg.control_dt)
    if surrogate is None:
        surrogate = env_surrogate(cfg.scenario, cfg.surrogate_variant, release)
    if not isinstance(surrogate, CrashSurrogate):
        raise ValueError(
            f"surrogate must be a CrashSurrogate (build_crash_surrogate), got "
            f"{type(surrogate).__name__}"
        )
    if surrogate.source != cfg.scenario.name:
        raise ValueError(
            f"surrogate was built for scenario {surrogate.source!r}, not {cfg.scenario.name!r}"
        )
    try:
        return crash_model(cfg.scenario, "surrogate", cfg.control_dt, surrogate=surrogate)
    except (ValueError, AttributeError, TypeError, IndexError) as err:
        raise ValueError(f"surrogate does not fit this env: {err}") from err


def _options_payload(value: Any, n_cars: int) -> np.ndarray:
    """``payload_t`` of ``reset(options=...)``: one number (t) for every car, a sequence of
    ``n_cars`` numbers or a mapping with ``lead`` and ``passenger``; returned in kg."""
    field = "options['payload_t']"
    lo, hi = LIMITS["payload_t"]
    if isinstance(value, Mapping):
        unknown = sorted(set(value) - {"lead", "passenger"})
        if unknown:
            raise val.FieldError(f"{field}[{unknown[0]!r}]", "is not a car type (lead, passenger)")
        lead = val.in_range(value.get("lead", 0.0), f"{field}['lead']", lo, hi)
        other = val.in_range(value.get("passenger", 0.0), f"{field}['passenger']", lo, hi)
        tonnes = [lead] + [other] * (n_cars - 1)
    elif isinstance(value, list | tuple | np.ndarray):
        items = val.sequence(value, field, n_cars)
        tonnes = [val.in_range(v, f"{field}[{k}]", lo, hi) for k, v in enumerate(items)]
    else:
        tonnes = [val.in_range(value, field, lo, hi)] * n_cars
    return np.array(tonnes) * 1e3


class _CrashShell:
    """Option handling and the public accessors shared by the single and the vector env.

    Accessors return copies of the end-of-step state: for the single env arrays over the cars
    or zones, for the vector env with a first axis over the sub-envs.
    """

    sim: CrashBatch
    cfg: CrashParams
    _single: bool

    def _rows(self, a: np.ndarray) -> np.ndarray:
        return a[0].copy() if self._single else a.copy()

    @property
    def positions(self) -> np.ndarray:
        """Car displacements from first contact (centre of mass), m."""
        return self._rows(self.sim.out.x[:, : self.sim.n_cars])

    @property
    def velocities(self) -> np.ndarray:
        """Car velocities towards the barrier, m/s."""
        return self._rows(self.sim.out.v[:, : self.sim.n_cars])

    @property
    def accelerations(self) -> np.ndarray:
        """Car accelerations (negative when braking), m/s²."""
        return self._rows(self.sim.out.a[:, : self.sim.n_cars])

    @property
    def crush(self) -> np.ndarray:
        """Crush of each zone (wall first; surrogate: element feature u), m."""
        return self._rows(self.sim.out.crush[:, self.sim.zones])

    @property
    def zone_forces(self) -> np.ndarray:
        """Force of each zone, compression positive, N."""
        return self._rows(self.sim.out.force[:, self.sim.zones])

    @property
    def absorber_scales(self) -> np.ndarray:
        """Force scale of each zone's absorber over the last step."""
        return self._rows(self.sim.scale[:, self.sim.zones])

    @property
    def car_masses(self) -> np.ndarray:
        """Mass of each car in this episode (payload included), kg."""
        return self._rows(self.cfg.scenario.car_masses + self.sim.payload)

    @property
    def initial_speed(self) -> Any:
        """This episode's initial speed, m/s (float; vector env: (n,) array)."""
        return float(self.sim.speed[0]) if self._single else self.sim.speed.copy()

    @property
    def absorber_stroke(self) -> np.ndarray:
        """Absorber stroke of each zone, m."""
        return self.cfg.absorber_stroke.copy()

    def _apply_options(self, options: dict[str, Any]) -> None:
        """``speed_kmh`` (km/h) and ``payload_t`` (t, see :func:`_options_payload`) fix the
        impact conditions of this and later episodes (``None`` draws them again); the
        envelope's draws are made all the same, so that the episodes after still follow the
        seed (``hold``: :mod:`railgym.envs.base`)."""
        if not options:
            return
        unknown = sorted(set(options) - set(OPTIONS))
        if unknown:
            raise val.FieldError(
                f"options[{unknown[0]!r}]",
                f"is not a reset option; options: {[*OPTIONS, 'hold']}",
            )
        fixed = dict(self._fixed)
        if "speed_kmh" in options:
            v = options["speed_kmh"]
            lo, hi = LIMITS["speed_kmh"]
            fixed["speed_kmh"] = (
                None if v is None else val.in_range(v, "options['speed_kmh']", lo, hi) / 3.6
            )
        if "payload_t" in options:
            p = options["payload_t"]
            fixed["payload_t"] = None if p is None else _options_payload(p, self.sim.n_cars)
        self._fixed = fixed

    def _episode(self) -> tuple[Any, Any]:
        return self._fixed.get("speed_kmh"), self._fixed.get("payload_t")

    def _case(self, sim: Any, idx: np.ndarray) -> dict[str, np.ndarray]:
        """The initial speed (m/s) and payload of each car (kg) of the episodes of ``sim``'s
        trains ``idx`` (as ``info["initial_speed"]``, ``info["payload_kg"]``), and whether
        reset options fixed them (``speed_fixed``, ``payload_fixed``; else drawn, or the
        scenario's)."""
        n = len(idx)
        speed, payload = self._episode()
        return {
            "speed": sim.speed[idx],
            "payload_kg": sim.payload[idx],
            "speed_fixed": np.full(n, speed is not None),
            "payload_fixed": np.full(n, payload is not None),
        }

    def _case_text(self, episode: tuple) -> str:
        """``episode`` = ``(speed, payload)`` fixed by options (m/s, kg per car; ``None``:
        drawn or the scenario's)."""
        speed, payload = episode
        if speed is None and payload is None:
            return "the scenario's impact conditions (drawn from its envelope, if it has one)"
        parts = [] if speed is None else [f"the initial speed fixed at {3.6 * speed:.4g} km/h"]
        if payload is not None:
            parts.append(f"the payload fixed at {', '.join(f'{p / 1e3:.4g}' for p in payload)} t")
        return " and ".join(parts)

    def _frame(self, state: dict[str, Any]) -> np.ndarray:
        from railgym.envs.crash.render import render_crash

        return render_crash(state)


class TrainCrashEnv(_CrashShell, BatchEnv):
    """Adaptive crash energy management: a train runs into a wall, the agent sets the force
    level of a controllable absorber in every crush zone.

    The keyword arguments are the fields of :class:`CrashParams` (default, unit, limits and
    meaning of each: docs/envs/crash.md, *Arguments*) and ``render_mode``; the checked
    arguments are :attr:`cfg`.

    ``reset(options=...)``: ``speed_kmh``, ``payload_t`` (:meth:`_apply_options`). Accessors:
    :attr:`positions`, :attr:`velocities`, :attr:`accelerations`, :attr:`crush`,
    :attr:`zone_forces`, :attr:`absorber_scales`, :attr:`car_masses`, :attr:`initial_speed`,
    :attr:`absorber_stroke`.
    """

    _single = True
    #: the declared arguments of the env
    params_class = CrashParams
    #: packaged elements of this version (``""``: current; ``"v0"``: ``TrainCrash-v1``'s)
    elements_release = ""
    _case_attrs = ("_fixed",)

    @checked_keywords(CrashParams)
    def __init__(
        self,
        *,
        render_mode: str | None = None,
        backend: str = "surrogate",
        scenario: Any = "paper",
        n_cars: int | None = None,
        speed: float | None = None,
        control_dt: float = 0.001,
        max_duration: float = 2.0,
        absorber_range: float = 0.3,
        absorber_rate: float = 20.0,
        speed_jitter: float = 0.0,
        reward_weights: dict[str, float] | None = DEFAULT_WEIGHTS,
        surrogate: Any = None,
        surrogate_variant: str = "hysteretic",
    ) -> None:
        self.cfg = CrashParams.from_kwargs(CrashParams.arguments_from(locals()))
        self.backend = self.cfg.backend
        self.model = make_model(self.cfg, self.elements_release)
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        self._fixed: dict[str, Any] = {}
        sim = CrashBatch(1, self.cfg, self.model)
        self._init_shell(
            sim,
            render_mode,
            spaces.Box(-np.inf, np.inf, (len(self.obs_names),), np.float32),
            spaces.Box(-1.0, 1.0, (sim.n_zones,), np.float32),
        )


class TrainCrashVectorEnv(_CrashShell, BatchVectorEnv):
    """Native vector version: all sub-envs stepped in one compiled kernel call.

    Sub-env ``i`` of ``reset(seed=s)`` reproduces ``TrainCrashEnv.reset(seed=s + i)`` step
    for step. Autoreset mode: next step (gymnasium's default). ``reset(options=...)`` as the
    single env's (plus ``reset_mask``); accessors as arrays over the sub-envs.
    """

    _single = False
    #: the single env whose configuration and elements the sub-envs share
    single_class: type[TrainCrashEnv] = TrainCrashEnv

    @checked_keywords(CrashParams)
    def __init__(
        self,
        num_envs: int = 1,
        *,
        render_mode: str | None = None,
        backend: str = "surrogate",
        scenario: Any = "paper",
        n_cars: int | None = None,
        speed: float | None = None,
        control_dt: float = 0.001,
        max_duration: float = 2.0,
        absorber_range: float = 0.3,
        absorber_rate: float = 20.0,
        speed_jitter: float = 0.0,
        reward_weights: dict[str, float] | None = DEFAULT_WEIGHTS,
        surrogate: Any = None,
        surrogate_variant: str = "hysteretic",
    ) -> None:
        args = CrashParams.arguments_from(locals())
        num_envs = val.integer(num_envs, "num_envs", min=1, max=MAX_NUM_ENVS)
        single = self.single_class(render_mode=render_mode, **args)
        self.cfg = single.cfg
        self.obs_names, self.obs_scale = self.cfg.obs_names, self.cfg.obs_scale
        self._init_vector(single, CrashBatch(num_envs, self.cfg, single.model), num_envs)


class TrainCrashEnvV0(TrainCrashEnv):
    """``TrainCrash-v1``: the packaged elements of version 0 (one mass per car, one global
    LPR per zone); everything else as :class:`TrainCrashEnv` (docs/envs/crash.md, *Version
    history*)."""

    elements_release = "v0"


class TrainCrashVectorEnvV0(TrainCrashVectorEnv):
    """Native vector version of :class:`TrainCrashEnvV0`."""

    single_class = TrainCrashEnvV0
