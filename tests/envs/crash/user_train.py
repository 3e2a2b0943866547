"""A user's own train for the crash tests, written independently of railgym's models: its
scenario file (other masses, names and crush zones than the packaged ones) and an FE-like
run of it by a lumped-mass model of our own (equal node masses, central differences, a
bilinear crush law with elastic unloading), written as LS-DYNA ``nodout`` and ``rcforc``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import yaml

from surrogates.lsdyna import write_nodout, write_rcforc

#: the user's cars: lead and passenger mass (t), length (m), EA (MN), cab length (m)
LEAD = {"mass_t": 42.0, "length_m": 22.0, "EA_MN": 5000.0, "cab_length_m": 3.0}
PASSENGER = {"mass_t": 38.0, "length_m": 21.0, "EA_MN": 5000.0}
#: crush zones: envelope points (mm, kN), absorber stroke (mm), unloading stiffness (kN/mm)
WALL = {
    "stroke_mm": [10.0, 500.0, 540.0, 1800.0, 1840.0, 3000.0],
    "force_kN": [900.0, 900.0, 2800.0, 2800.0, 3600.0, 3600.0],
    "absorber_stroke_mm": 1800.0,
    "unloading_stiffness_kN_per_mm": 150.0,
}
INTERFACE = {
    "stroke_mm": [12.0, 300.0, 340.0, 1300.0, 1340.0, 2500.0],
    "force_kN": [1100.0, 1100.0, 2000.0, 2000.0, 2800.0, 2800.0],
    "absorber_stroke_mm": 1300.0,
    "unloading_stiffness_kN_per_mm": 120.0,
}
SPEED_KMH = 36.0
FRICTION = 0.05
DAMPING_RATIO = 0.05


def write_train(folder: Path, n_cars: int = 3, name: str = "my_train", **top: Any) -> Path:
    """The user's ``n_cars`` train as a scenario file ``folder/<name>.yaml`` (``top``: more
    or other top-level fields)."""
    car = {"n_nodes": 6, "damping_ratio": DAMPING_RATIO}
    zone = {"fold_amplitude": 0.0}
    doc = {
        "crash": {
            "name": name,
            "description": f"a user's {n_cars}-car train",
            "speed_kmh": SPEED_KMH,
            "friction": FRICTION,
            "n_cars": n_cars,
            "barrier": {"type": "rigid_wall"},
            "cars": {"lead": {**LEAD, **car}, "passenger": {**PASSENGER, **car}},
            "zones": {"wall": {**WALL, **zone}, "interface": {**INTERFACE, **zone}},
            **top,
        }
    }
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def _envelope(zone: dict[str, Any], d: np.ndarray) -> np.ndarray:
    s = np.concatenate(([0.0], zone["stroke_mm"])) * 1e-3
    f = np.concatenate(([0.0], zone["force_kN"])) * 1e3
    return np.interp(d, s, f)


def fe_run(
    n_cars: int = 3, nodes_per_car: int = 20, dt: float = 1e-4, duration: float = 0.8
) -> dict[str, np.ndarray]:
    """The FE-like run of the user's train into a rigid wall at :data:`SPEED_KMH`.

    Each car is ``nodes_per_car`` equal masses joined by links ``EA/ℓ`` with damping ratio
    :data:`DAMPING_RATIO`; each zone joins the front node of a car to the wall or to the rear
    node of the car ahead: force ``min(envelope(δ), k_u (δ − δ_p))``, at least 0, its
    permanent set ``δ_p`` growing on the envelope; friction ``μ m g tanh(v / 0.01 m/s)``.
    Returns per 1 ms sample ``t`` (s), the cars' centre-of-mass ``x``, ``v``, ``a`` (SI) and
    the zone forces ``force`` (N, wall first), ``crush`` (m), and ``ku`` (N/m per zone).
    """
    cars = [LEAD] + [PASSENGER] * (n_cars - 1)
    zones = [WALL] + [INTERFACE] * (n_cars - 1)
    n = nodes_per_car
    m = np.concatenate([np.full(n, 1e3 * c["mass_t"] / n) for c in cars])
    k_link = np.concatenate(
        [np.full(n - 1, 1e6 * c["EA_MN"] * (n - 1) / c["length_m"]) for c in cars]
    )
    first = np.arange(n_cars) * n
    link = np.array([i for i in range(n * n_cars - 1) if (i + 1) % n != 0])  # node i to i + 1
    c_link = 2 * DAMPING_RATIO * np.sqrt(k_link * m[link] / 2)
    ku = np.array([1e6 * z["unloading_stiffness_kN_per_mm"] for z in zones])
    x = np.zeros(m.size)
    v = np.full(m.size, SPEED_KMH / 3.6)
    dp = np.zeros(n_cars)
    every = round(1e-3 / dt)
    rec: dict[str, list[np.ndarray]] = {k: [] for k in ("x", "v", "a", "force", "crush")}

    def forces(x: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        F = -FRICTION * m * 9.81 * np.tanh(v / 0.01)
        e = x[link + 1] - x[link]  # elongation of each link
        fl = k_link * e + c_link * (v[link + 1] - v[link])
        F[link] += fl
        F[link + 1] -= fl
        d = np.array([x[0]] + [x[first[k]] - x[first[k] - 1] for k in range(1, n_cars)])
        fz = np.zeros(n_cars)
        for k, z in enumerate(zones):
            env = _envelope(z, np.array([d[k]]))[0]
            if ku[k] * (d[k] - dp[k]) >= env:
                dp[k] = d[k] - env / ku[k]
            fz[k] = max(0.0, min(env, ku[k] * (d[k] - dp[k])))
        F[first] -= fz
        F[first[1:] - 1] += fz[1:]
        return F, fz, d

    F, fz, d = forces(x, v)
    for step in range(round(duration / dt) + 1):
        if step % every == 0:
            car_m = m.reshape(n_cars, n)
            rec["x"].append((car_m * x.reshape(n_cars, n)).sum(1) / car_m.sum(1))
            rec["v"].append((car_m * v.reshape(n_cars, n)).sum(1) / car_m.sum(1))
            rec["a"].append(F.reshape(n_cars, n).sum(1) / car_m.sum(1))
            rec["force"].append(fz.copy())
            rec["crush"].append(d.copy())
        v = v + 0.5 * dt * F / m
        x = x + dt * v
        F, fz, d = forces(x, v + 0.5 * dt * F / m)
        v = v + 0.5 * dt * F / m
    out = {k: np.array(r) for k, r in rec.items()}
    out["t"] = np.arange(out["x"].shape[0]) * 1e-3
    out["ku"] = ku
    return out


def write_fe_output(folder: Path, run: dict[str, np.ndarray]) -> tuple[Path, Path, list[int]]:
    """``run`` as ``nodout`` (one node per car at its centre of mass, ids 101, 201, …) and
    ``rcforc`` (contact 1 the wall, 2, 3, … the interfaces) in mm-ms-kg-kN, the train
    travelling towards −x; returns the two paths and the node ids."""
    ids = [100 * (k + 1) + 1 for k in range(run["x"].shape[1])]
    nodes = {
        nid: {
            "x_disp": -run["x"][:, k] * 1e3,
            "x_vel": -run["v"][:, k],
            "x_accl": -run["a"][:, k] * 1e-3,
        }
        for k, nid in enumerate(ids)
    }
    f_kn = run["force"] / 1e3
    contacts = {}
    for j in range(f_kn.shape[1]):
        contacts[("master", j + 1)] = {"x_force": f_kn[:, j]}
        contacts[("slave", j + 1)] = {"x_force": -f_kn[:, j]}
    t_ms = run["t"] * 1e3
    nodout = write_nodout(folder / "nodout", t_ms, nodes, legend={n: "CoM" for n in ids})
    rcforc = write_rcforc(folder / "rcforc", t_ms, contacts)
    return nodout, rcforc, ids
