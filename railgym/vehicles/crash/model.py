"""A scenario's model ready for batch stepping (:func:`crash_model`), for the gymnasium envs.

Either model of a scenario advanced sample by sample for many trains in one compiled call, with
a controllable absorber in every zone: a force scale per zone multiplies its loading envelope
(surrogate: its element force) up to the absorber stroke (:func:`absorber_zone_force`). The
same kernels record :func:`simulate_reference` and :func:`simulate_surrogate` (one train, all
scales 1).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from railgym.vehicles.crash.outputs import CrashOutputs, check_run, new_outputs, sub_steps
from railgym.vehicles.crash.reference import (
    ReferenceParams,
    ReferenceState,
    build_chain,
    new_reference_state,
    reference_batch_step,
    reference_steps,
)
from railgym.vehicles.crash.scenario import CrashScenario, load_scenario
from railgym.vehicles.crash.surrogate import CrashSurrogate
from railgym.vehicles.crash.surrogate_model import (
    SurrogateParams,
    SurrogateState,
    new_surrogate_state,
    surrogate_batch_step,
    surrogate_system,
)

__all__ = ["MODEL_BACKENDS", "CrashModel", "crash_model"]

#: models of :func:`crash_model`
MODEL_BACKENDS = ("reference", "surrogate")


@dataclass(frozen=True)
class CrashModel:
    """A scenario's reference or surrogate model, ready for batch stepping.

    Made by :func:`crash_model`. Holds no simulation state: :meth:`new_state` and
    :meth:`new_outputs` allocate the arrays of ``n`` simulations, :meth:`reset` puts one at
    first contact, :meth:`step` advances the active ones by ``sample_dt`` in one compiled call.

    Attributes
    ----------
    backend : ``"reference"`` or ``"surrogate"``.
    scenario : the simulated scenario (its ``speed`` is the nominal initial speed).
    sample_dt : time advanced by one :meth:`step`, s.
    dt, n_sub : integration step (s) and steps per :meth:`step`.
    params : :class:`ReferenceParams` or :class:`SurrogateParams` of the kernel.
    masses : mass of each integration node, kg.
    v_unit : initial velocity of each node per unit train speed (1 train, 0 obstacle).
    car_nodes : (cars, 2) first and past-the-end node of each car.
    body_names, zone_names : as in :class:`CrashResult`.
    """

    backend: str
    scenario: CrashScenario
    sample_dt: float
    dt: float
    n_sub: int
    params: ReferenceParams | SurrogateParams
    masses: np.ndarray
    v_unit: np.ndarray
    car_nodes: np.ndarray
    body_names: list[str]
    zone_names: list[str]

    def new_state(self, n: int) -> ReferenceState | SurrogateState:
        """Zeroed kernel state of ``n`` simulations."""
        nz = len(self.zone_names)
        if self.backend == "reference":
            return new_reference_state(n, self.masses, nz)
        return new_surrogate_state(n, self.masses, nz)

    def new_outputs(self, n: int) -> CrashOutputs:
        """Zeroed outputs of ``n`` simulations."""
        return new_outputs(n, len(self.body_names), len(self.zone_names))

    def node_masses(self, payload: np.ndarray | None = None) -> np.ndarray:
        """Mass of each node or body (kg) with ``payload`` (cars,) kg added to the cars, each
        car's nodes in proportion to their mass; ``None`` = no payload."""
        m = self.masses.copy()
        if payload is not None:
            car_mass = self.scenario.car_masses
            for k, (a, b) in enumerate(self.car_nodes):
                if payload[k] != 0.0:
                    m[a:b] *= (car_mass[k] + payload[k]) / car_mass[k]
        return m

    def reset(
        self,
        state: ReferenceState | SurrogateState,
        out: CrashOutputs,
        i: int,
        speed: float,
        payload: np.ndarray | None = None,
    ) -> None:
        """Simulation ``i`` at first contact, the train at ``speed`` (m/s) with ``payload``
        (cars,) kg added (:meth:`node_masses`); call :meth:`step` with ``init=True``
        afterwards to evaluate its forces."""
        for arr in (*state, *out):
            arr[i] = 0.0
        state.v[i] = self.v_unit * speed
        state.m[i] = self.node_masses(payload)

    def step(
        self,
        state: ReferenceState | SurrogateState,
        out: CrashOutputs,
        scale: np.ndarray,
        active: np.ndarray,
        div: np.ndarray,
        init: bool = False,
        limit: float = 1e3,
    ) -> None:
        """Advance the ``active`` simulations by ``sample_dt`` (:func:`reference_batch_step`)."""
        kernel = reference_batch_step if self.backend == "reference" else surrogate_batch_step
        kernel(state, out, self.params, scale, active, init, self.dt, self.n_sub, limit, div)


def crash_model(
    scenario: CrashScenario | str,
    backend: str = "reference",
    sample_dt: float = 1e-3,
    surrogate: CrashSurrogate | None = None,
    safety: float = 0.2,
    dt: float = 5e-4,
) -> CrashModel:
    """The :class:`CrashModel` of a scenario with the ``backend`` model.

    Parameters
    ----------
    scenario : a :class:`CrashScenario` or a name/path for :func:`load_scenario`.
    backend : ``"reference"`` (lumped-mass chain, :func:`simulate_reference`) or
        ``"surrogate"`` (paper eq. 4, :func:`simulate_surrogate`; needs ``surrogate``).
    sample_dt : time advanced per :meth:`CrashModel.step`, s.
    safety : reference time-step safety factor; dt : largest surrogate step, s (both as in
        the ``simulate_*`` functions, which record with the same kernels).
    """
    scenario = load_scenario(scenario) if isinstance(scenario, str | Path) else scenario
    if backend not in MODEL_BACKENDS:
        raise ValueError(f"backend must be one of {MODEL_BACKENDS}, got {backend!r}")
    check_run(sample_dt, sample_dt)
    if backend == "reference":
        if surrogate is not None:
            raise ValueError(
                "surrogate is only used by backend='surrogate', got one for 'reference'"
            )
        system = build_chain(scenario)
        step, n_sub = reference_steps(system, sample_dt, safety)
        p = system.params
        car_nodes = np.column_stack([p.body_start, p.body_end])[: scenario.n_cars]
    else:
        if surrogate is None:
            raise ValueError("surrogate is required for backend='surrogate'")
        step, n_sub = sub_steps(sample_dt, dt)
        system = surrogate_system(scenario, surrogate)
        p = system.params
        car_nodes = np.column_stack([p.body_start, p.body_end])[: scenario.n_cars]
    return CrashModel(
        backend=backend,
        scenario=scenario,
        sample_dt=float(sample_dt),
        dt=step,
        n_sub=n_sub,
        params=system.params,
        masses=system.params.m,
        v_unit=system.v0 / scenario.speed,
        car_nodes=car_nodes,
        body_names=system.body_names,
        zone_names=system.zone_names,
    )
