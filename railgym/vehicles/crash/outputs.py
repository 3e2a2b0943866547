"""What both crash models share: the outputs of the batch kernels (:class:`CrashOutputs`), the
recorders' :class:`Record` and :class:`StopRule`, the recorded :class:`CrashResult`, the
divergence guard and the time-step rounding."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from railgym.vehicles.crash.criteria import CrashCriteria, CriteriaLimits, crash_criteria
from railgym.vehicles.crash.scenario import CrashScenario

__all__ = [
    "V_EPS",
    "CrashOutputs",
    "CrashResult",
    "Record",
    "StopRule",
    "new_outputs",
    "new_record",
    "one_train",
    "result_criteria",
    "zone_absorber_strokes",
]

#: batches of at least this many trains are stepped on all threads (``*_batch_step_parallel``)
PARALLEL_MIN = 256
#: friction regularisation velocity of tanh(v / v_ε), m/s
V_EPS = 0.01


class CrashOutputs(NamedTuple):
    """What the batch kernels report after each call, one row per simulation.

    Attributes
    ----------
    x, v, a : (n, bodies) centre-of-mass displacement (m), velocity (m/s) and acceleration
        (m/s²) of each body (cars front to back, then the obstacle if any).
    crush : (n, zones) crush of each zone (surrogate: element feature ``u``), m.
    force : (n, zones) zone force, compression positive (coupler damping included), N.
    rate : (n, zones) closing rate of each zone, m/s.
    work : (n, zones) net work done on each zone since the start, J.
    dissipated : (n, 2) friction work and carbody/coupler damping work since the start, J.
    stored : (n,) kinetic energy plus elastic carbody energy, J.
    """

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    crush: np.ndarray
    force: np.ndarray
    rate: np.ndarray
    work: np.ndarray
    dissipated: np.ndarray
    stored: np.ndarray


def new_outputs(n: int, n_bodies: int, n_zones: int) -> CrashOutputs:
    """Zeroed :class:`CrashOutputs` of ``n`` simulations."""
    body = [np.zeros((n, n_bodies)) for _ in range(3)]
    zone = [np.zeros((n, n_zones)) for _ in range(4)]
    return CrashOutputs(*body, *zone, np.zeros((n, 2)), np.zeros(n))


class StopRule(NamedTuple):
    """When a recorded run ends: at the first sample after the start where no zone carries
    more than ``f_stop`` (N) of compression and none closes faster than ``v_stop`` (m/s), if
    ``enabled``."""

    enabled: bool
    v_stop: float
    f_stop: float


class Record(NamedTuple):
    """Sampled histories filled by the recorders, one row per sample.

    ``energy`` columns: kinetic, elastic links, elastic zones, friction, damping (J);
    ``plastic`` (samples, zones), J; both have no rows for the surrogate.
    """

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    crush: np.ndarray
    force: np.ndarray
    permanent_set: np.ndarray
    energy: np.ndarray
    plastic: np.ndarray


def new_record(n: int, n_bodies: int, n_zones: int, energies: bool) -> Record:
    """Zeroed :class:`Record` of ``n`` samples (energy rows only if ``energies``)."""
    body = [np.zeros((n, n_bodies)) for _ in range(3)]
    zone = [np.zeros((n, n_zones)) for _ in range(3)]
    m = n if energies else 0
    return Record(*body, *zone, np.zeros((m, 5)), np.zeros((m, n_zones)))


def one_train(
    system: Any, new_state: Any, duration: float, sample_dt: float, energies: bool
) -> tuple[Any, CrashOutputs, Record]:
    """Kernel state (``new_state(1, masses, zones)``, moving at ``system.v0``), outputs and
    record (every ``sample_dt`` s over ``duration`` s) of one train of a model's ``system``
    (``params.m``, ``v0``, ``body_names``, ``zone_names``)."""
    n_samples = int(round(duration / sample_dt)) + 1
    nb, nz = len(system.body_names), len(system.zone_names)
    state = new_state(1, system.params.m, nz)
    state.v[0] = system.v0
    return state, new_outputs(1, nb, nz), new_record(n_samples, nb, nz, energies=energies)


@njit(cache=True)
def state_healthy(x, v, a, limit):
    """True if every entry is finite and |x|, |v| ≤ ``limit``."""
    for j in range(x.shape[0]):
        if not (abs(x[j]) <= limit and abs(v[j]) <= limit and math.isfinite(a[j])):
            return False
    return True


@njit(cache=True)
def crash_over(out, fz, stop):
    """True if no zone of simulation 0 carries more than ``stop.f_stop`` (conservative force
    ``fz``) and none closes faster than ``stop.v_stop``."""
    for z in range(fz.shape[1]):
        if fz[0, z] > stop.f_stop or out.rate[0, z] > stop.v_stop:
            return False
    return True


@dataclass
class CrashResult:
    """Time histories of a crash simulation, sampled every ``sample_dt``.

    Attributes
    ----------
    t : (n,) time, s.
    x, v, a : (n, bodies) centre-of-mass displacement (m), velocity (m/s) and acceleration
        (m/s²) of each body; bodies are the cars front to back, then the obstacle if any.
    body_names : names of the bodies (``"lead"``, ``"car2"``, ..., ``"obstacle"``).
    zone_names : names of the zone instances (``"wall"``, ``"interface_1"``, ...).
    crush, force : (n, zones) crush (m) and force (N, compression positive) of each zone; for
        the surrogate, the element feature ``u`` (m) and force.
    permanent_set : (n, zones) permanent set of each zone, m.
    energy : dict of (n,) or (n, zones) arrays, J: ``kinetic``, ``elastic`` (total),
        ``plastic`` (per zone), ``friction``, ``damping``; empty for the surrogate.
    initial_kinetic_energy : J.
    dt : integration time step, s.
    wall_time : wall-clock time of the integration (compiled kernel only), s.
    scenario : the simulated scenario.
    model : ``"reference"`` or ``"surrogate:<variant>"``.
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    body_names: list[str]
    zone_names: list[str]
    crush: np.ndarray
    force: np.ndarray
    permanent_set: np.ndarray
    energy: dict[str, np.ndarray]
    initial_kinetic_energy: float
    dt: float
    wall_time: float
    scenario: CrashScenario
    model: str = "reference"
    extra: dict[str, Any] = field(default_factory=dict)

    def energy_residual(self) -> np.ndarray:
        """(n,) relative energy-balance error ``(E_0 − Σ energies) / E_0`` (reference only)."""
        if not self.energy:
            raise ValueError(f"{self.model} results carry no energy histories")
        e = self.energy
        total = (
            e["kinetic"] + e["elastic"] + e["plastic"].sum(axis=1) + e["friction"] + e["damping"]
        )
        return (self.initial_kinetic_energy - total) / self.initial_kinetic_energy

    def intrusion(self) -> dict[str, float]:
        """Largest crush beyond each zone's absorber stroke (structure crush), m."""
        scenario = self.scenario
        zones = {
            "wall": scenario.wall,
            "obstacle": scenario.obstacle.zone if scenario.obstacle else None,
        }
        out = {}
        for j, name in enumerate(self.zone_names):
            zone = zones.get(name, scenario.interface)
            out[name] = max(0.0, float(self.permanent_set[:, j].max()) - zone.absorber_stroke)
        return out


def recorded_result(
    rec: Record, n: int, sample_dt: float, system: Any, **fields: Any
) -> CrashResult:
    """The :class:`CrashResult` of the first ``n`` samples of ``rec`` (sampled every
    ``sample_dt``, s); ``system`` (a reference chain or surrogate system: ``params.m``, ``v0``,
    names) gives the names and the initial kinetic energy, ``fields`` the other attributes."""
    return CrashResult(
        t=np.arange(n) * sample_dt,
        x=rec.x[:n],
        v=rec.v[:n],
        a=rec.a[:n],
        body_names=system.body_names,
        zone_names=system.zone_names,
        crush=rec.crush[:n],
        force=rec.force[:n],
        permanent_set=rec.permanent_set[:n],
        initial_kinetic_energy=float(0.5 * np.sum(system.params.m * system.v0**2)),
        **fields,
    )


def sub_steps(sample_dt: float, dt_max: float) -> tuple[float, int]:
    if not (math.isfinite(dt_max) and dt_max > 0):
        raise ValueError(f"dt must be a positive finite number (s), got {dt_max!r}")
    n_sub = max(1, math.ceil(sample_dt / dt_max - 1e-9))
    return sample_dt / n_sub, n_sub


def check_run(duration: float, sample_dt: float) -> None:
    for name, value in (("duration", duration), ("sample_dt", sample_dt)):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive finite number (s), got {value!r}")
    if sample_dt > duration:
        raise ValueError(f"sample_dt ({sample_dt} s) must not exceed duration ({duration} s)")


def zone_absorber_strokes(result: CrashResult) -> np.ndarray:
    """Absorber stroke (m) of each zone of ``result`` (``wall``, ``interface_k``, ``obstacle``)."""
    scenario = result.scenario
    zones = {
        "wall": scenario.wall,
        "obstacle": scenario.obstacle.zone if scenario.obstacle else None,
    }
    return np.array(
        [(zones.get(n) or scenario.interface).absorber_stroke for n in result.zone_names]
    )


def result_criteria(
    result: CrashResult, limits: CriteriaLimits | None = None, **kwargs: float
) -> CrashCriteria:
    """:func:`crash_criteria` of a :class:`CrashResult` (its cars, not
    the obstacle; ``kwargs``: ``window``, ``onset_g``)."""
    cars = result.scenario.n_cars
    v, a = result.v[:, :cars], result.a[:, :cars]
    strokes = zone_absorber_strokes(result)
    g = result.scenario.gravity
    return crash_criteria(result.t, v, a, result.crush, strokes, limits, g=g, **kwargs)
