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
from typing import Any

import numpy as np
from numba import njit

from railgym.vehicles.crash.scenario import CrashScenario, load_scenario
from railgym.vehicles.crash.zone import absorber_zone_force

__all__ = ["V_EPS", "CrashResult", "reference_time_step", "simulate_reference"]

#: friction regularisation velocity of tanh(v / v_ε), m/s
V_EPS = 0.01


@dataclass
class _Chain:
    """Node/element arrays of the reference model (front to back)."""

    m: np.ndarray
    v0: np.ndarray
    mu: np.ndarray
    link_k: np.ndarray  # per element between node e and e+1 (0 for zones)
    link_c: np.ndarray
    elem_zone: np.ndarray  # zone instance of element e, −1 for a link
    wall_zone: int  # zone instance at a fixed wall ahead of node 0, −1 if none
    zone_type: np.ndarray  # type table row of each zone instance
    zone_cc: np.ndarray  # coupler damping coefficient of each instance, N s/m
    t_s: np.ndarray  # (types, P) stroke points
    t_f: np.ndarray
    t_n: np.ndarray
    t_amp: np.ndarray
    t_lam: np.ndarray
    t_ku: np.ndarray
    t_kt: np.ndarray
    t_slack: np.ndarray
    t_abs: np.ndarray  # absorber stroke of each type, m
    body_start: np.ndarray
    body_end: np.ndarray
    body_names: list[str]
    zone_names: list[str]
    zone_front: np.ndarray  # front node of each zone instance (−1 = fixed wall)
    zone_back: np.ndarray
    omega_max: float


def _build_chain(sc: CrashScenario) -> _Chain:
    types = [sc.wall, sc.interface] + ([sc.obstacle.zone] if sc.obstacle else [])
    P = max(len(z.stroke) for z in types)
    t_s = np.ones((len(types), P))
    t_f = np.zeros((len(types), P))
    for i, z in enumerate(types):
        t_s[i, : len(z.stroke)] = z.stroke
        t_f[i, : len(z.force)] = z.force
    t_n = np.array([len(z.stroke) for z in types], dtype=np.int64)
    t_kt = np.array([z.coupler.stiffness if z.coupler else 0.0 for z in types])
    t_slack = np.array([z.coupler.slack if z.coupler else 0.0 for z in types])

    m: list[float] = []
    v0: list[float] = []
    mu: list[float] = []
    link_k: list[float] = []
    link_c: list[float] = []
    elem_zone: list[int] = []
    zone_type: list[int] = []
    zone_cc: list[float] = []
    zone_front: list[int] = []
    zone_back: list[int] = []
    zone_names: list[str] = []
    bodies: dict[str, tuple[int, int]] = {}

    def add_zone(t: int, name: str, front: int, back: int, cc: float) -> int:
        zone_type.append(t)
        zone_cc.append(cc)
        zone_front.append(front)
        zone_back.append(back)
        zone_names.append(name)
        return len(zone_type) - 1

    wall_zone = -1
    if sc.obstacle is None:
        wall_zone = add_zone(0, "wall", -1, 0, 0.0)
    else:
        ob = sc.obstacle
        m += [ob.mass - ob.face_mass, ob.face_mass]
        v0 += [0.0, 0.0]
        mu += [ob.friction] * 2
        bodies["obstacle"] = (0, 2)
        link_k.append(0.0)
        link_c.append(0.0)
        elem_zone.append(add_zone(2, "obstacle", 0, 1, 0.0))
    masses = sc.car_masses
    for k in range(sc.n_cars):
        car = sc.lead if k == 0 else sc.passenger
        first = len(m)
        if first > 0:  # element joining the previous body to this car
            link_k.append(0.0)
            link_c.append(0.0)
            if k == 0:
                elem_zone.append(add_zone(0, "wall", first - 1, first, 0.0))
            else:
                cc = 0.0
                if sc.interface.coupler is not None:
                    mred = masses[k - 1] * masses[k] / (masses[k - 1] + masses[k])
                    cp = sc.interface.coupler
                    cc = 2 * cp.damping_ratio * math.sqrt(cp.stiffness * mred)
                elem_zone.append(add_zone(1, f"interface_{k}", first - 1, first, cc))
        n = car.n_nodes
        mi = np.full(n, car.mass / (n - 1))
        mi[[0, -1]] *= 0.5
        m += mi.tolist()
        v0 += [sc.speed] * n
        mu += [sc.friction] * n
        k_link = car.axial_rigidity / (car.length / (n - 1))
        for j in range(n - 1):
            mred = mi[j] * mi[j + 1] / (mi[j] + mi[j + 1])
            link_k.append(k_link)
            link_c.append(2 * car.damping_ratio * math.sqrt(k_link * mred))
            elem_zone.append(-1)
        bodies["lead" if k == 0 else f"car{k + 1}"] = (first, first + n)

    m_arr = np.array(m)
    # Gershgorin bound of M⁻¹K: ω² ≤ max_i 2 Σ_e k_e / m_i
    k_elem = np.array(link_k)
    ztype = np.array(zone_type, dtype=np.int64)
    kz = np.array([max(types[t].unloading_stiffness, t_kt[t]) for t in zone_type])
    for e, z in enumerate(elem_zone):
        if z >= 0:
            k_elem[e] = kz[z]
    k_node = np.zeros(m_arr.size)
    k_node[:-1] += k_elem
    k_node[1:] += k_elem
    if wall_zone >= 0:
        k_node[0] += kz[wall_zone]
    omega_max = float(np.sqrt(np.max(2.0 * k_node / m_arr)))
    names = [n for n in bodies if n != "obstacle"] + (["obstacle"] if "obstacle" in bodies else [])
    return _Chain(
        m=m_arr,
        v0=np.array(v0),
        mu=np.array(mu),
        link_k=np.array(link_k),
        link_c=np.array(link_c),
        elem_zone=np.array(elem_zone, dtype=np.int64),
        wall_zone=wall_zone,
        zone_type=ztype,
        zone_cc=np.array(zone_cc),
        t_s=t_s,
        t_f=t_f,
        t_n=t_n,
        t_amp=np.array([z.fold_amplitude for z in types]),
        t_lam=np.array([z.fold_wavelength for z in types]),
        t_ku=np.array([z.unloading_stiffness for z in types]),
        t_kt=t_kt,
        t_slack=t_slack,
        t_abs=np.array([z.absorber_stroke for z in types]),
        body_start=np.array([bodies[n][0] for n in names], dtype=np.int64),
        body_end=np.array([bodies[n][1] for n in names], dtype=np.int64),
        body_names=names,
        zone_names=zone_names,
        zone_front=np.array(zone_front, dtype=np.int64),
        zone_back=np.array(zone_back, dtype=np.int64),
        omega_max=omega_max,
    )


@njit(cache=True)
def _chain_forces(
    x, v, dp, m, mu, g, veps, link_k, link_c, elem_zone, zone_type, zone_cc,
    zone_front, zone_back, t_s, t_f, t_n, t_amp, t_lam, t_ku, t_kt, t_slack, t_abs, scale,
    F, fz, fzel, fd, ff, dz,
):  # fmt: skip
    """Nodal forces ``F`` at state (x, v); updates the permanent sets ``dp`` in place.

    ``scale`` (per zone instance) multiplies each zone's envelope up to its type's absorber
    stroke ``t_abs`` (:func:`absorber_zone_force`).

    Also returns per zone instance: conservative force ``fz`` (zone + coupler spring), its
    elastic energy ``fzel``, crush ``dz``; per element: damping force ``fd``; per node: friction
    magnitude along v, ``ff`` (the force is ``−ff``).
    """
    N = x.shape[0]
    for i in range(N):
        ff[i] = mu[i] * m[i] * g * math.tanh(v[i] / veps)
        F[i] = -ff[i]
    for z in range(zone_type.shape[0]):
        t = zone_type[z]
        fr = zone_front[z]
        bk = zone_back[z]
        d = x[bk] - (x[fr] if fr >= 0 else 0.0)
        rate = v[bk] - (v[fr] if fr >= 0 else 0.0)
        dz[z] = d
        f, dp[z] = absorber_zone_force(
            d, dp[z], t_s[t], t_f[t], t_n[t], t_amp[t], t_lam[t], t_ku[t], t_abs[t], scale[z]
        )
        el = 0.5 * f * f / t_ku[t]
        damp = 0.0
        if f == 0.0 and t_kt[t] > 0.0 and d < dp[z] - t_slack[t]:
            ext = d - dp[z] + t_slack[t]
            f = t_kt[t] * ext
            el = 0.5 * t_kt[t] * ext * ext
            damp = zone_cc[z] * rate
        fz[z] = f
        fzel[z] = el
        if fr >= 0:
            F[fr] += f + damp
        F[bk] -= f + damp
        if bk > 0:
            fd[bk - 1] = damp
    for e in range(N - 1):
        if elem_zone[e] >= 0:
            continue
        d = x[e + 1] - x[e]
        fd[e] = link_c[e] * (v[e + 1] - v[e])
        f = link_k[e] * d + fd[e]
        F[e] += f
        F[e + 1] -= f


@njit(cache=True)
def _reference_kernel(
    m, v0, mu, g, veps, link_k, link_c, elem_zone, zone_type, zone_cc, zone_front,
    zone_back, t_s, t_f, t_n, t_amp, t_lam, t_ku, t_kt, t_slack, t_abs, body_start, body_end,
    dt, n_sub, n_samples, stop, v_stop, f_stop,
):  # fmt: skip
    """Velocity-Verlet integration of the chain; samples every ``n_sub`` steps."""
    N = m.shape[0]
    nz = zone_type.shape[0]
    nb = body_start.shape[0]
    x = np.zeros(N)
    v = v0.copy()
    vp = np.empty(N)
    dp = np.zeros(nz)
    F = np.zeros(N)
    fz = np.zeros(nz)
    fzel = np.zeros(nz)
    fd = np.zeros(max(N - 1, 1))
    ff = np.zeros(N)
    dz = np.zeros(nz)
    scale = np.ones(nz)
    fz_o = np.zeros(nz)
    fd_o = np.zeros(max(N - 1, 1))
    ff_o = np.zeros(N)
    dz_o = np.zeros(nz)
    wz = np.zeros(nz)
    w_fric = 0.0
    w_damp = 0.0
    out_xb = np.zeros((n_samples, nb))
    out_vb = np.zeros((n_samples, nb))
    out_ab = np.zeros((n_samples, nb))
    out_dz = np.zeros((n_samples, nz))
    out_fz = np.zeros((n_samples, nz))
    out_dp = np.zeros((n_samples, nz))
    out_e = np.zeros((n_samples, 5))  # kinetic, elastic links, elastic zones, friction, damping
    out_pl = np.zeros((n_samples, nz))

    _chain_forces(x, v, dp, m, mu, g, veps, link_k, link_c, elem_zone, zone_type, zone_cc,
                  zone_front, zone_back, t_s, t_f, t_n, t_amp, t_lam, t_ku, t_kt, t_slack,
                  t_abs, scale, F, fz, fzel, fd, ff, dz)  # fmt: skip
    a = F / m
    dx = np.empty(N)
    n_out = 0
    for k in range(n_samples):
        if k > 0:
            for _ in range(n_sub):
                fz_o[:] = fz
                fd_o[:] = fd
                ff_o[:] = ff
                dz_o[:] = dz
                for i in range(N):
                    dx[i] = v[i] * dt + 0.5 * a[i] * dt * dt
                    x[i] += dx[i]
                    vp[i] = v[i] + a[i] * dt
                _chain_forces(x, vp, dp, m, mu, g, veps, link_k, link_c, elem_zone, zone_type,
                              zone_cc, zone_front, zone_back, t_s, t_f, t_n, t_amp, t_lam,
                              t_ku, t_kt, t_slack, t_abs, scale, F, fz, fzel, fd, ff,
                              dz)  # fmt: skip
                for i in range(N):
                    a_new = F[i] / m[i]
                    v[i] += 0.5 * (a[i] + a_new) * dt
                    a[i] = a_new
                for z in range(nz):
                    wz[z] += 0.5 * (fz_o[z] + fz[z]) * (dz[z] - dz_o[z])
                for e in range(N - 1):
                    w_damp += 0.5 * (fd_o[e] + fd[e]) * (dx[e + 1] - dx[e])
                for i in range(N):
                    w_fric += 0.5 * (ff_o[i] + ff[i]) * dx[i]
        # ---- sample
        ke = 0.0
        for i in range(N):
            ke += 0.5 * m[i] * v[i] * v[i]
        el = 0.0
        for e in range(N - 1):
            if elem_zone[e] < 0:
                d = x[e + 1] - x[e]
                el += 0.5 * link_k[e] * d * d
        elz = 0.0
        for z in range(nz):
            elz += fzel[z]
            out_pl[k, z] = wz[z] - fzel[z]
            out_dz[k, z] = dz[z]
            out_fz[k, z] = fz[z] + (fd[zone_back[z] - 1] if zone_front[z] >= 0 else 0.0)
            out_dp[k, z] = dp[z]
        out_e[k, 0] = ke
        out_e[k, 1] = el
        out_e[k, 2] = elz
        out_e[k, 3] = w_fric
        out_e[k, 4] = w_damp
        for b in range(nb):
            mb = 0.0
            for i in range(body_start[b], body_end[b]):
                mb += m[i]
                out_xb[k, b] += m[i] * x[i]
                out_vb[k, b] += m[i] * v[i]
                out_ab[k, b] += F[i]
            out_xb[k, b] /= mb
            out_vb[k, b] /= mb
            out_ab[k, b] /= mb
        n_out = k + 1
        if stop and k > 0:
            over = True
            for z in range(nz):
                fr = zone_front[z]
                rate = v[zone_back[z]] - (v[fr] if fr >= 0 else 0.0)
                if fz[z] > f_stop or rate > v_stop:
                    over = False
                    break
            if over:
                break
    return out_xb, out_vb, out_ab, out_dz, out_fz, out_dp, out_e, out_pl, n_out


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
        sc = self.scenario
        zones = {"wall": sc.wall, "obstacle": sc.obstacle.zone if sc.obstacle else None}
        out = {}
        for j, name in enumerate(self.zone_names):
            zone = zones.get(name, sc.interface)
            out[name] = max(0.0, float(self.permanent_set[:, j].max()) - zone.absorber_stroke)
        return out


def reference_time_step(
    scenario: CrashScenario, sample_dt: float = 1e-3, safety: float = 0.2
) -> tuple[float, int]:
    """Integration step of the reference model and the number of steps per sample.

    ``dt = safety · 2 / ω_max`` rounded down to ``sample_dt / n_sub``.
    """
    chain = _build_chain(scenario)
    return _steps(sample_dt, safety * 2.0 / chain.omega_max)


def _steps(sample_dt: float, dt_max: float) -> tuple[float, int]:
    n_sub = max(1, math.ceil(sample_dt / dt_max - 1e-9))
    return sample_dt / n_sub, n_sub


def _check_run(duration: float, sample_dt: float) -> None:
    for name, value in (("duration", duration), ("sample_dt", sample_dt)):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive finite number (s), got {value!r}")
    if sample_dt > duration:
        raise ValueError(f"sample_dt ({sample_dt} s) must not exceed duration ({duration} s)")


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
    sc = load_scenario(scenario) if isinstance(scenario, str | Path) else scenario
    sc = sc.with_overrides(n_cars=n_cars, speed=speed)
    _check_run(duration, sample_dt)
    if not 0 < safety <= 1:
        raise ValueError(f"safety must be in (0, 1], got {safety!r}")
    ch = _build_chain(sc)
    dt, n_sub = _steps(sample_dt, safety * 2.0 / ch.omega_max)
    n_samples = int(round(duration / sample_dt)) + 1
    t0 = time.perf_counter()
    xb, vb, ab, dz, fz, dpz, e, pl, n = _reference_kernel(
        ch.m, ch.v0, ch.mu, sc.gravity, V_EPS, ch.link_k, ch.link_c, ch.elem_zone, ch.zone_type,
        ch.zone_cc, ch.zone_front, ch.zone_back, ch.t_s, ch.t_f,
        ch.t_n, ch.t_amp, ch.t_lam, ch.t_ku, ch.t_kt, ch.t_slack, ch.t_abs, ch.body_start,
        ch.body_end,
        dt, n_sub, n_samples, stop_when_over, v_stop, f_stop,
    )  # fmt: skip
    wall = time.perf_counter() - t0
    return CrashResult(
        t=np.arange(n) * sample_dt,
        x=xb[:n],
        v=vb[:n],
        a=ab[:n],
        body_names=ch.body_names,
        zone_names=ch.zone_names,
        crush=dz[:n],
        force=fz[:n],
        permanent_set=dpz[:n],
        energy={
            "kinetic": e[:n, 0],
            "elastic": e[:n, 1] + e[:n, 2],
            "elastic_links": e[:n, 1],
            "elastic_zones": e[:n, 2],
            "plastic": pl[:n],
            "friction": e[:n, 3],
            "damping": e[:n, 4],
        },
        initial_kinetic_energy=float(0.5 * np.sum(ch.m * ch.v0**2)),
        dt=dt,
        wall_time=wall,
        scenario=sc,
        model="reference",
        extra={"omega_max": ch.omega_max, "n_sub": n_sub, "safety": safety},
    )
