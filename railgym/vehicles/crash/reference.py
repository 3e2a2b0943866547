"""Reference crash model (:func:`simulate_reference`): a lumped-mass chain per car.

Our stand-in for the paper's LS-DYNA model, about an order of magnitude finer than eq. (4):

* each car is a chain of ``n_nodes`` lumped masses (row-sum lumping of bar elements: the end
  nodes carry half the share of the inner nodes) joined by elastic carbody links of stiffness
  ``EA / ℓ`` with viscous damping ``c = 2 ζ √(k m_red)``, so carbody elasticity and stress
  waves exist;
* each crush zone is a hysteretic elastoplastic element (:func:`zone_force`): a loading
  envelope (the scenario's piecewise-linear force–crush stages times a progressive-folding
  wave ``1 + A sin(2π (δ − δ_1)/λ)`` beyond the first point ``δ_1``), elastic unloading from
  the current point with the documented unloading stiffness ``k_u``, reloading along the same
  line back to the envelope, and permanent set ``δ_p`` (the crush at zero force);
* contact is unilateral (a zone never pulls); between cars the coupler's draft gear carries
  tension: linear spring ``k_t`` with damping ratio ``ζ_t``, engaged once the zone has opened
  by more than the slack beyond its permanent set (the coupler is shortened by the crushed
  tube: tension ``f = k_t (δ − δ_p + s)`` for ``δ < δ_p − s``);
* wheel–rail friction on every mass ``f_c m g tanh(v / v_ε)`` (regularised sign,
  ``v_ε = 0.01 m/s``);
* velocity Verlet (explicit, velocity-dependent forces from the predicted velocity
  ``v + a dt``) with ``dt = safety · 2 / ω_max`` where ``ω_max² = max_i 2 Σ_e k_e / m_i``
  (Gershgorin bound of M⁻¹K over the links, zones' ``k_u`` and couplers' ``k_t``), rounded
  down so that a whole number of steps fits in ``sample_dt``;
* energies: kinetic, elastic (links + elastic part of zones and couplers), plastic dissipation
  per zone (work into the zone minus its elastic energy), friction work, damping work.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numba import njit

from railgym.vehicles.crash.outputs import (
    V_EPS,
    CrashResult,
    StopRule,
    check_run,
    crash_over,
    one_train,
    recorded_result,
    state_healthy,
    sub_steps,
)
from railgym.vehicles.crash.scenario import CrashScenario, CrushZone, Obstacle, load_scenario
from railgym.vehicles.crash.zone import absorber_zone_force

__all__ = [
    "MIN_REFERENCE_DT",
    "ReferenceParams",
    "ReferenceState",
    "ZoneTypes",
    "reference_batch_step",
    "reference_time_step",
    "simulate_reference",
]

#: smallest stable integration step of the reference model, s (lighter or stiffer chains are
#: rejected: their runs would take minutes)
MIN_REFERENCE_DT = 1e-6


class ZoneTypes(NamedTuple):
    """Crush-zone characteristics, one row per zone type (wall, interface, obstacle).

    Attributes
    ----------
    stroke, force : (types, points) envelope points, m and N (rows padded past ``n_points``).
    n_points : (types,) number of envelope points.
    fold_amplitude, fold_wavelength : (types,) folding wave ``A`` and ``λ`` (m).
    unloading_stiffness : (types,) ``k_u``, N/m.
    tension_stiffness, slack : (types,) coupler ``k_t`` (N/m, 0 = none) and slack (m).
    absorber : (types,) absorber stroke, m.
    """

    stroke: np.ndarray
    force: np.ndarray
    n_points: np.ndarray
    fold_amplitude: np.ndarray
    fold_wavelength: np.ndarray
    unloading_stiffness: np.ndarray
    tension_stiffness: np.ndarray
    slack: np.ndarray
    absorber: np.ndarray


class ReferenceParams(NamedTuple):
    """Static arrays of the reference chain (front to back), passed into the kernels.

    Attributes
    ----------
    m, mu : (nodes,) node mass (kg) and friction coefficient.
    gravity, v_eps : m/s² and the friction regularisation velocity, m/s.
    link_k, link_c : (nodes − 1,) carbody link stiffness (N/m) and damping (N s/m) of the
        element between node e and e + 1 (0 for a zone).
    elem_zone : (nodes − 1,) zone instance of element e, −1 for a link.
    zone_type : (zones,) row of ``types`` of each zone instance.
    zone_cc : (zones,) coupler damping coefficient, N s/m.
    zone_front, zone_back : (zones,) nodes each zone joins (front −1 = fixed wall).
    body_start, body_end : (bodies,) node range of each body.
    types : the :class:`ZoneTypes` table.
    """

    m: np.ndarray
    mu: np.ndarray
    gravity: float
    v_eps: float
    link_k: np.ndarray
    link_c: np.ndarray
    elem_zone: np.ndarray
    zone_type: np.ndarray
    zone_cc: np.ndarray
    zone_front: np.ndarray
    zone_back: np.ndarray
    body_start: np.ndarray
    body_end: np.ndarray
    types: ZoneTypes


class ReferenceState(NamedTuple):
    """Per-simulation state of :func:`reference_batch_step`, one row per simulation.

    Attributes
    ----------
    x, v, a : (n, nodes) node displacement (m), velocity (m/s), acceleration (m/s²).
    dp, fz, elastic : (n, zones) permanent set (m), conservative force (N) and elastic
        energy (J) of each zone (coupler spring included).
    fd : (n, max(nodes − 1, 1)) damping force of each element, N.
    ff : (n, nodes) friction force magnitude along v, N.
    m : (n, nodes) node mass of each simulation (a car's payload included), kg; the carbody
        and coupler damping coefficients stay those of :attr:`ReferenceParams.m`.
    """

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    dp: np.ndarray
    fz: np.ndarray
    elastic: np.ndarray
    fd: np.ndarray
    ff: np.ndarray
    m: np.ndarray


@dataclass
class _Chain:
    """The reference chain of a scenario: kernel parameters plus what the kernels do not need."""

    params: ReferenceParams
    v0: np.ndarray  # initial node velocities, m/s
    body_names: list[str]
    zone_names: list[str]
    omega_max: float  # Gershgorin bound of the highest angular frequency, rad/s


def _zone_types(types: list[CrushZone]) -> ZoneTypes:
    """:class:`ZoneTypes` of the zone types ``types`` (wall, interface, obstacle)."""
    P = max(len(z.stroke) for z in types)
    t_s = np.ones((len(types), P))
    t_f = np.zeros((len(types), P))
    for i, z in enumerate(types):
        t_s[i, : len(z.stroke)] = z.stroke
        t_f[i, : len(z.force)] = z.force
    return ZoneTypes(
        stroke=t_s,
        force=t_f,
        n_points=np.array([len(z.stroke) for z in types], dtype=np.int64),
        fold_amplitude=np.array([z.fold_amplitude for z in types]),
        fold_wavelength=np.array([z.fold_wavelength for z in types]),
        unloading_stiffness=np.array([z.unloading_stiffness for z in types]),
        tension_stiffness=np.array([z.coupler.stiffness if z.coupler else 0.0 for z in types]),
        slack=np.array([z.coupler.slack if z.coupler else 0.0 for z in types]),
        absorber=np.array([z.absorber_stroke for z in types]),
    )


@dataclass
class _ChainLists:
    """Nodes (mass, initial velocity, friction), elements (link stiffness and damping, zone)
    and zone instances of a chain, appended front to back; ``bodies``: name → node range."""

    m: list[float] = field(default_factory=list)
    v0: list[float] = field(default_factory=list)
    mu: list[float] = field(default_factory=list)
    link_k: list[float] = field(default_factory=list)
    link_c: list[float] = field(default_factory=list)
    elem_zone: list[int] = field(default_factory=list)
    zone_type: list[int] = field(default_factory=list)
    zone_cc: list[float] = field(default_factory=list)
    zone_front: list[int] = field(default_factory=list)
    zone_back: list[int] = field(default_factory=list)
    zone_names: list[str] = field(default_factory=list)
    bodies: dict[str, tuple[int, int]] = field(default_factory=dict)

    def add_zone(self, t: int, name: str, front: int, back: int, cc: float) -> int:
        """Index of a new zone instance of type ``t`` between nodes ``front`` and ``back``
        (``-1``: the wall) with coupler damping ``cc`` (N·s/m)."""
        self.zone_type.append(t)
        self.zone_cc.append(cc)
        self.zone_front.append(front)
        self.zone_back.append(back)
        self.zone_names.append(name)
        return len(self.zone_type) - 1

    def add_obstacle(self, ob: Obstacle) -> None:
        """The obstacle's two nodes (body and face) and its crush zone between them."""
        self.m += [ob.mass - ob.face_mass, ob.face_mass]
        self.v0 += [0.0, 0.0]
        self.mu += [ob.friction] * 2
        self.bodies["obstacle"] = (0, 2)
        self.link_k.append(0.0)
        self.link_c.append(0.0)
        self.elem_zone.append(self.add_zone(2, "obstacle", 0, 1, 0.0))

    def add_car(self, scenario: CrashScenario, k: int) -> None:
        """Car ``k`` (0: the lead): the zone joining it to the body in front (if any), its
        nodes and its carbody links."""
        car = scenario.lead if k == 0 else scenario.passenger
        first = len(self.m)
        if first > 0:  # element joining the previous body to this car
            self.link_k.append(0.0)
            self.link_c.append(0.0)
            if k == 0:
                self.elem_zone.append(self.add_zone(0, "wall", first - 1, first, 0.0))
            else:
                cc = 0.0
                if scenario.interface.coupler is not None:
                    masses = scenario.car_masses
                    mred = masses[k - 1] * masses[k] / (masses[k - 1] + masses[k])
                    cp = scenario.interface.coupler
                    cc = 2 * cp.damping_ratio * math.sqrt(cp.stiffness * mred)
                self.elem_zone.append(self.add_zone(1, f"interface_{k}", first - 1, first, cc))
        n = car.n_nodes
        mi = np.full(n, car.mass / (n - 1))
        mi[[0, -1]] *= 0.5
        self.m += mi.tolist()
        self.v0 += [scenario.speed] * n
        self.mu += [scenario.friction] * n
        k_link = car.axial_rigidity / (car.length / (n - 1))
        for j in range(n - 1):
            mred = mi[j] * mi[j + 1] / (mi[j] + mi[j + 1])
            self.link_k.append(k_link)
            self.link_c.append(2 * car.damping_ratio * math.sqrt(k_link * mred))
            self.elem_zone.append(-1)
        self.bodies["lead" if k == 0 else f"car{k + 1}"] = (first, first + n)


def _omega_max(chain: _ChainLists, zone_stiffness: np.ndarray, wall_zone: int) -> float:
    """Gershgorin bound of the highest angular frequency of M⁻¹K, rad/s:
    ``ω² ≤ max_i 2 Σ_e k_e / m_i`` with each zone element at its ``zone_stiffness``."""
    m = np.array(chain.m)
    k_elem = np.array(chain.link_k)
    for e, z in enumerate(chain.elem_zone):
        if z >= 0:
            k_elem[e] = zone_stiffness[z]
    k_node = np.zeros(m.size)
    k_node[:-1] += k_elem
    k_node[1:] += k_elem
    if wall_zone >= 0:
        k_node[0] += zone_stiffness[wall_zone]
    return float(np.sqrt(np.max(2.0 * k_node / m)))


def build_chain(scenario: CrashScenario) -> _Chain:
    """The reference chain of ``scenario``: the obstacle (if any) in front, then the cars."""
    types = [scenario.wall, scenario.interface] + (
        [scenario.obstacle.zone] if scenario.obstacle else []
    )
    zone_types = _zone_types(types)
    chain = _ChainLists()
    wall_zone = -1
    if scenario.obstacle is None:
        wall_zone = chain.add_zone(0, "wall", -1, 0, 0.0)
    else:
        chain.add_obstacle(scenario.obstacle)
    for k in range(scenario.n_cars):
        chain.add_car(scenario, k)
    kt = zone_types.tension_stiffness
    kz = np.array([max(types[t].unloading_stiffness, kt[t]) for t in chain.zone_type])
    bodies = chain.bodies
    names = [n for n in bodies if n != "obstacle"] + (["obstacle"] if "obstacle" in bodies else [])
    return _Chain(
        params=ReferenceParams(
            m=np.array(chain.m),
            mu=np.array(chain.mu),
            gravity=float(scenario.gravity),
            v_eps=V_EPS,
            link_k=np.array(chain.link_k),
            link_c=np.array(chain.link_c),
            elem_zone=np.array(chain.elem_zone, dtype=np.int64),
            zone_type=np.array(chain.zone_type, dtype=np.int64),
            zone_cc=np.array(chain.zone_cc),
            zone_front=np.array(chain.zone_front, dtype=np.int64),
            zone_back=np.array(chain.zone_back, dtype=np.int64),
            body_start=np.array([bodies[n][0] for n in names], dtype=np.int64),
            body_end=np.array([bodies[n][1] for n in names], dtype=np.int64),
            types=zone_types,
        ),
        v0=np.array(chain.v0),
        body_names=names,
        zone_names=chain.zone_names,
        omega_max=_omega_max(chain, kz, wall_zone),
    )


@njit(cache=True)
def _chain_forces(x, v, m, dp, p, scale, F, fz, fzel, fd, ff, dz):
    """Nodal forces ``F`` at state (x, v) of chain ``p`` (:class:`ReferenceParams`) with node
    masses ``m`` (kg); updates the permanent sets ``dp`` in place.

    ``scale`` (per zone instance) multiplies each zone's envelope up to its type's absorber
    stroke (:func:`absorber_zone_force`). Also returns per zone instance: conservative force
    ``fz`` (zone + coupler spring), its elastic energy ``fzel``, crush ``dz``; per element:
    damping force ``fd``; per node: friction magnitude along v, ``ff`` (the force is ``−ff``).
    """
    ty = p.types
    N = x.shape[0]
    for i in range(N):
        ff[i] = p.mu[i] * m[i] * p.gravity * math.tanh(v[i] / p.v_eps)
        F[i] = -ff[i]
    for z in range(p.zone_type.shape[0]):
        t = p.zone_type[z]
        front = p.zone_front[z]
        back = p.zone_back[z]
        d = x[back] - (x[front] if front >= 0 else 0.0)
        rate = v[back] - (v[front] if front >= 0 else 0.0)
        dz[z] = d
        ku, kt, slack = ty.unloading_stiffness[t], ty.tension_stiffness[t], ty.slack[t]
        f, dp[z] = absorber_zone_force(
            d,
            dp[z],
            ty.stroke[t],
            ty.force[t],
            ty.n_points[t],
            ty.fold_amplitude[t],
            ty.fold_wavelength[t],
            ku,
            ty.absorber[t],
            scale[z],
        )
        el = 0.5 * f * f / ku
        damp = 0.0
        if f == 0.0 and kt > 0.0 and d < dp[z] - slack:
            ext = d - dp[z] + slack
            f = kt * ext
            el = 0.5 * kt * ext * ext
            damp = p.zone_cc[z] * rate
        fz[z] = f
        fzel[z] = el
        if front >= 0:
            F[front] += f + damp
        F[back] -= f + damp
        if back > 0:
            fd[back - 1] = damp
    for e in range(N - 1):
        if p.elem_zone[e] >= 0:
            continue
        d = x[e + 1] - x[e]
        fd[e] = p.link_c[e] * (v[e + 1] - v[e])
        f = p.link_k[e] * d + fd[e]
        F[e] += f
        F[e + 1] -= f


@njit(cache=True)
def reference_batch_step(state, out, params, scale, active, init, dt, n_sub, limit, div):
    """Advance every ``active`` reference simulation by ``n_sub`` velocity-Verlet steps.

    Parameters
    ----------
    state : :class:`ReferenceState`, updated in place.
    out : :class:`CrashOutputs`; ``crush``, ``work`` and ``dissipated`` are also read back.
    params : :class:`ReferenceParams` of the chain.
    scale : (n, zones) absorber force scale of each zone (:func:`absorber_zone_force`).
    active : (n,) which simulations to advance.
    init : evaluate the forces at the current state instead of stepping (after a reset).
    dt, n_sub : integration step (s) and number of steps.
    limit : a simulation whose |x| (m) or |v| (m/s) exceeds ``limit`` or that becomes
        non-finite keeps its state from before the call and gets ``div[i] = True``.
    """
    p = params
    elem_zone, link_k = p.elem_zone, p.link_k
    N = p.m.shape[0]
    nz = p.zone_type.shape[0]
    nodes = np.empty((8, N))
    xl, vl, al, vp = nodes[0], nodes[1], nodes[2], nodes[3]
    F, dx, ffl, ff_o = nodes[4], nodes[5], nodes[6], nodes[7]
    zones = np.empty((7, nz))
    dpl, fzl, fz_o, fzel = zones[0], zones[1], zones[2], zones[3]
    dzl, dz_o, wzl = zones[4], zones[5], zones[6]
    fdl, fd_o = np.empty(state.fd.shape[1]), np.empty(state.fd.shape[1])
    for i in range(state.x.shape[0]):
        if not active[i]:
            continue
        xl[:], vl[:], al[:] = state.x[i], state.v[i], state.a[i]
        dpl[:], fzl[:] = state.dp[i], state.fz[i]
        fzel[:], fdl[:], ffl[:] = state.elastic[i], state.fd[i], state.ff[i]
        dzl[:], wzl[:] = out.crush[i], out.work[i]
        w_fric, w_damp = out.dissipated[i, 0], out.dissipated[i, 1]
        zone_scale, m = scale[i], state.m[i]
        if init:
            _chain_forces(xl, vl, m, dpl, p, zone_scale, F, fzl, fzel, fdl, ffl, dzl)
            for j in range(N):
                al[j] = F[j] / m[j]
        for _ in range(0 if init else n_sub):
            fz_o[:], fd_o[:], ff_o[:], dz_o[:] = fzl, fdl, ffl, dzl
            for j in range(N):
                dx[j] = vl[j] * dt + 0.5 * al[j] * dt * dt
                xl[j] += dx[j]
                vp[j] = vl[j] + al[j] * dt
            _chain_forces(xl, vp, m, dpl, p, zone_scale, F, fzl, fzel, fdl, ffl, dzl)
            for j in range(N):
                a_new = F[j] / m[j]
                vl[j] += 0.5 * (al[j] + a_new) * dt
                al[j] = a_new
            for z in range(nz):
                wzl[z] += 0.5 * (fz_o[z] + fzl[z]) * (dzl[z] - dz_o[z])
            for e in range(N - 1):
                w_damp += 0.5 * (fd_o[e] + fdl[e]) * (dx[e + 1] - dx[e])
            for j in range(N):
                w_fric += 0.5 * (ff_o[j] + ffl[j]) * dx[j]
        if not state_healthy(xl, vl, al, limit):
            div[i] = True
            continue
        state.x[i], state.v[i], state.a[i], state.dp[i], state.fz[i] = xl, vl, al, dpl, fzl
        state.elastic[i], state.fd[i], state.ff[i] = fzel, fdl, ffl
        out.crush[i], out.work[i] = dzl, wzl
        out.dissipated[i, 0], out.dissipated[i, 1] = w_fric, w_damp
        energy = 0.0
        for j in range(N):
            energy += 0.5 * m[j] * vl[j] * vl[j]
            if j < N - 1 and elem_zone[j] < 0:
                energy += 0.5 * link_k[j] * (xl[j + 1] - xl[j]) ** 2
        out.stored[i] = energy
        for z in range(nz):
            front, back = p.zone_front[z], p.zone_back[z]
            out.force[i, z] = fzl[z] + (fdl[back - 1] if front >= 0 else 0.0)
            out.rate[i, z] = vl[back] - (vl[front] if front >= 0 else 0.0)
        for b in range(p.body_start.shape[0]):
            mb = sx = sv = sf = 0.0
            for j in range(p.body_start[b], p.body_end[b]):
                mb += m[j]
                sx += m[j] * xl[j]
                sv += m[j] * vl[j]
                sf += F[j]
            out.x[i, b], out.v[i, b], out.a[i, b] = sx / mb, sv / mb, sf / mb


@njit(cache=True)
def _record_reference(state, out, params, dt, n_sub, stop, rec):
    """Record simulation 0 of ``state`` sample by sample with :func:`reference_batch_step`
    into ``rec`` (:class:`Record`); returns the number of samples taken."""
    p = params
    N, nz = p.m.shape[0], p.zone_type.shape[0]
    scale = np.ones((1, nz))
    active = np.ones(1, np.bool_)
    div = np.zeros(1, np.bool_)
    for k in range(rec.x.shape[0]):
        reference_batch_step(state, out, p, scale, active, k == 0, dt, n_sub, math.inf, div)
        x, v = state.x[0], state.v[0]
        ke = el = elz = 0.0
        for i in range(N):
            ke += 0.5 * state.m[0, i] * v[i] * v[i]
        for e in range(N - 1):
            if p.elem_zone[e] < 0:
                d = x[e + 1] - x[e]
                el += 0.5 * p.link_k[e] * d * d
        for z in range(nz):
            elz += state.elastic[0, z]
            rec.plastic[k, z] = out.work[0, z] - state.elastic[0, z]
        rec.energy[k, 0], rec.energy[k, 1], rec.energy[k, 2] = ke, el, elz
        rec.energy[k, 3], rec.energy[k, 4] = out.dissipated[0, 0], out.dissipated[0, 1]
        rec.x[k], rec.v[k], rec.a[k] = out.x[0], out.v[0], out.a[0]
        rec.crush[k], rec.force[k], rec.permanent_set[k] = out.crush[0], out.force[0], state.dp[0]
        if stop.enabled and k > 0 and crash_over(out, state.fz, stop):
            return k + 1
    return rec.x.shape[0]


def new_reference_state(n: int, masses: np.ndarray, n_zones: int) -> ReferenceState:
    """Zeroed :class:`ReferenceState` of ``n`` simulations with node ``masses`` (kg)."""
    n_nodes = masses.size
    node = [np.zeros((n, n_nodes)) for _ in range(3)]
    zone = [np.zeros((n, n_zones)) for _ in range(3)]
    fd = np.zeros((n, max(n_nodes - 1, 1)))
    return ReferenceState(*node, *zone, fd, np.zeros((n, n_nodes)), np.tile(masses, (n, 1)))


def reference_time_step(
    scenario: CrashScenario, sample_dt: float = 1e-3, safety: float = 0.2
) -> tuple[float, int]:
    """Integration step of the reference model and the number of steps per sample.

    ``dt = safety · 2 / ω_max`` rounded down to ``sample_dt / n_sub``.
    """
    return reference_steps(build_chain(scenario), sample_dt, safety)


def reference_steps(chain: _Chain, sample_dt: float, safety: float) -> tuple[float, int]:
    """:func:`sub_steps` of the chain's stable step ``safety · 2 / ω_max``, rejecting one below
    :data:`MIN_REFERENCE_DT`."""
    if not 0 < safety <= 1:
        raise ValueError(f"safety must be in (0, 1], got {safety!r}")
    dt_max = safety * 2.0 / chain.omega_max
    if dt_max < MIN_REFERENCE_DT:
        raise ValueError(
            f"scenario: the reference model's stable time step {dt_max:.3g} s is below "
            f"{MIN_REFERENCE_DT:g} s; its cars are too light or too stiff (crash.cars.*.mass_t, "
            "EA_MN, n_nodes, crash.zones.*.unloading_stiffness_kN_per_mm)"
        )
    return sub_steps(sample_dt, dt_max)


def simulate_reference(
    scenario: CrashScenario | str,
    n_cars: int | None = None,
    speed: float | None = None,
    duration: float = 2.0,
    sample_dt: float = 1e-3,
    safety: float = 0.2,
    stop_when_over: bool = True,
    v_stop: float = 0.01,
    f_stop: float = 1e3,
) -> CrashResult:
    """Run the reference lumped-mass crash model.

    Parameters
    ----------
    scenario : a :class:`CrashScenario` or a name/path for :func:`load_scenario`.
    n_cars, speed : optional overrides (number of cars; initial speed in m/s).
    duration : longest simulated time, s.
    sample_dt : output interval, s.
    safety : time-step safety factor on ``2 / ω_max`` (0 < safety ≤ 1).
    stop_when_over : end at the first sample where no zone carries more than ``f_stop`` (N) of
        compression and no zone closes faster than ``v_stop`` (m/s): all cars at rest or
        rebounding away.
    """
    scenario = load_scenario(scenario) if isinstance(scenario, str | Path) else scenario
    scenario = scenario.with_overrides(n_cars=n_cars, speed=speed)
    check_run(duration, sample_dt)
    ch = build_chain(scenario)
    dt, n_sub = reference_steps(ch, sample_dt, safety)
    state, out, rec = one_train(ch, new_reference_state, duration, sample_dt, energies=True)
    t0 = time.perf_counter()
    n = _record_reference(
        state, out, ch.params, dt, n_sub, StopRule(stop_when_over, v_stop, f_stop), rec
    )
    wall = time.perf_counter() - t0
    e = rec.energy
    return recorded_result(
        rec,
        n,
        sample_dt,
        ch,
        energy={
            "kinetic": e[:n, 0],
            "elastic": e[:n, 1] + e[:n, 2],
            "elastic_links": e[:n, 1],
            "elastic_zones": e[:n, 2],
            "plastic": rec.plastic[:n],
            "friction": e[:n, 3],
            "damping": e[:n, 4],
        },
        dt=dt,
        wall_time=wall,
        scenario=scenario,
        model="reference",
        extra={"omega_max": ch.omega_max, "n_sub": n_sub, "safety": safety},
    )
