"""Validation matrix of the vertical surrogate elements: do they hold across the envelope?

Every element is run in closed loop against the dynamic reference model on FRA classes
3, 4, 5, 6 at each class's maximum speed, over track seeds not used in training (seed ``k``
of the matrix is ``default_rng(SEED_BASE + k).integers(2**63 − 1)``, the same draw as the
env's episode seeds; the packaged elements train on track seed 0), under three force laws:

* ``passive``: no actuator force;
* ``skyhook``: ``F_a = −c_sky·ẋ2`` with the skyhook gain of
  ``agents.controllers.classical.Skyhook``;
* ``LQR``: ``F_a = −K·x`` on the linearised vehicle with the env's reward weights in SI
  (the design of ``agents.controllers.classical.LQR``).

Each law acts on the state of the model it drives (as a controller trained on the surrogate
then runs on the reference), at the env's control step, clipped to ``±f_max``. The scores are
the relative RMS error of the carbody acceleration ``‖ẍ2 − ẍ2_ref‖ / ‖ẍ2_ref‖`` (median,
90th percentile, max over the seeds) and the paper's eq. 9 average absolute errors of the
carbody displacement, velocity and acceleration (medians). The paper's table 8 (eq. 9,
trained on class 5, run on 3, 4, 6) is returned beside them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

import numpy as np
from scipy.linalg import solve_continuous_are

from railgym.parallel import run_tasks
from railgym.report.published import PAPER
from railgym.track import class_speed, track_time_input
from railgym.vehicles.vertical.kernels import (
    DEFAULT_DT,
    KERNELS,
    initial_state,
    step_outputs,
    surrogate_arrays,
)
from railgym.vehicles.vertical.params import VerticalVehicle, linear_model, load_vehicle
from railgym.vehicles.vertical.simulate import simulate
from surrogates.metrics import average_absolute_error

__all__ = [
    "CLASSES",
    "TARGETS",
    "check_targets",
    "lqr_law",
    "seed_of",
    "skyhook_law",
    "validation_matrix",
]

CLASSES = (3, 4, 5, 6)
#: seed base of the unseen tracks
SEED_BASE = 2000
#: skyhook gain, N·s/m (``agents.controllers.control_base.DEFAULT_C_SKY``)
C_SKY = 4.7e4
#: acceleration scale of the env's reward, m/s² (``railgym.envs.vertical.env.ACC_REF``)
ACC_REF = 0.75

#: issue-10 targets: (class, controller, statistic, bound as a fraction)
TARGETS = (
    (5, "passive", "median", 0.03),
    (3, "passive", "p90", 0.10),
    (3, "passive", "max", 0.20),
    (4, "passive", "p90", 0.10),
    (4, "passive", "max", 0.20),
    (6, "passive", "median", 0.05),
    (5, "skyhook", "median", 0.05),
    (5, "LQR", "median", 0.05),
)

ForceLaw = Callable[[np.ndarray], float]


def seed_of(k: int) -> int:
    """Track seed of the ``k``-th unseen track."""
    return int(np.random.default_rng(SEED_BASE + k).integers(2**63 - 1))


class _Skyhook(NamedTuple):
    """Skyhook force law (a named tuple, so that it pickles to worker processes)."""

    c_sky: float

    def __call__(self, x: np.ndarray) -> float:
        return -self.c_sky * float(x[3])


class _StateFeedback(NamedTuple):
    """Linear state feedback ``F_a = −gain·x[:4]`` (pickles to worker processes)."""

    gain: np.ndarray

    def __call__(self, x: np.ndarray) -> float:
        return -float(self.gain @ x[:4])


def skyhook_law(c_sky: float = C_SKY) -> ForceLaw:
    """``F_a = −c_sky·ẋ2`` (N) from the state ``[x1, v1, x2, v2, …]``."""
    return _Skyhook(c_sky)


def lqr_law(vehicle: VerticalVehicle, f_max: float = 8000.0) -> ForceLaw:
    """LQR state feedback ``F_a = −K·x`` (N) on the linear model ``k2, c2`` of ``vehicle``.

    Minimises ``∫ (ẍ2²/ACC_REF² + δ²/free_travel² + 0.1·F_a²/f_max²) dt``, with
    ``ẍ2 = C·x + F_a/m2`` (cross term in the Riccati equation).
    """
    a, b, c, d = linear_model(vehicle.kernel_params())
    q_acc = 1.0 / ACC_REF**2
    c_d = np.array([1.0, 0.0, -1.0, 0.0])
    q = q_acc * np.outer(c, c) + np.outer(c_d, c_d) / vehicle.bump_stop.free_travel_compression**2
    r = np.array([[0.1 / f_max**2 + q_acc * d * d]])
    n = q_acc * d * c[:, None]
    gain = np.linalg.solve(r, b.T @ solve_continuous_are(a, b, q, r, s=n) + n.T)[0]
    return _StateFeedback(gain)


def _closed_loop(
    variant: str,
    vehicle: VerticalVehicle,
    z: np.ndarray,
    zdot: np.ndarray,
    law: ForceLaw,
    element: Any,
    n_sub: int,
    dt: float,
    f_max: float,
) -> dict[str, np.ndarray]:
    """Carbody ``x2, v2, a2`` after every control step of ``law`` driving ``variant``."""
    n_steps = (z.size - 1) // n_sub
    kernel = KERNELS[variant]
    lpr = surrogate_arrays(element if variant == "surrogate" else None, dt, kriging=True)
    p = vehicle.kernel_params().record()
    state = initial_state(variant, lpr=lpr)
    out = step_outputs(1)
    k0 = np.zeros(1, np.int64)
    fa = np.zeros(1)
    rec = np.full((n_steps, 3), np.nan)
    z2, zd2 = z[None, :], zdot[None, :]
    for m in range(n_steps):
        fa[0] = min(max(law(state[0]), -f_max), f_max)
        k0[0] = m * n_sub
        kernel(state, z2, zd2, k0, n_sub, dt, fa, p, lpr, out)
        if out.div[0]:
            break
        rec[m] = state[0, 2], state[0, 3], out.acc[0, 1]
    return {"x2": rec[:, 0], "v2": rec[:, 1], "a2": rec[:, 2]}


def _passive(variant: str, vehicle: VerticalVehicle, z, zdot, element, n_sub, dt):
    """Passive run recorded at the control step (one compiled loop)."""
    rec = simulate(
        variant,
        vehicle,
        z,
        zdot,
        dt,
        surrogate=element if variant == "surrogate" else None,
        sample_every=n_sub,
    )
    n = (z.size - 1) // n_sub
    out = {k: np.full(n, np.nan) for k in ("x2", "v2", "a2")}
    m = min(n, rec["t"].size - 1)
    for k in out:
        out[k][:m] = rec[k][1 : m + 1]
    return out


def _errors(sur: dict[str, np.ndarray], ref: dict[str, np.ndarray]) -> tuple[float, ...]:
    """(relative RMS error of ẍ2, eq. 9 errors of x2, v2, ẍ2); inf where it diverged."""
    if not np.all(np.isfinite(sur["a2"])):
        return (np.inf,) * 4
    rel = np.sqrt(np.mean((sur["a2"] - ref["a2"]) ** 2) / np.mean(ref["a2"] ** 2))
    return (float(rel), *(average_absolute_error(sur[k], ref[k]) for k in ("x2", "v2", "a2")))


class _Cell(NamedTuple):
    """One track of :func:`validation_matrix`: every controller and element on it."""

    cls: int
    seed: int
    elements: Mapping[str, Any]
    controllers: Mapping[str, ForceLaw | None]
    vehicle: VerticalVehicle
    duration: float
    n_sub: int
    f_max: float


def _cell(c: _Cell) -> list[tuple[str, str, tuple[float, ...]]]:
    """``(element, controller, errors)`` of one track (:func:`_errors`)."""
    dt = DEFAULT_DT["dynamic"]
    veh, n_sub = c.vehicle, c.n_sub
    _, z, zdot = track_time_input(c.cls, class_speed(c.cls), c.duration, dt, c.seed)

    def run(variant: str, law: ForceLaw | None, element: Any) -> Any:
        if law is None:
            return _passive(variant, veh, z, zdot, element, n_sub, dt)
        return _closed_loop(variant, veh, z, zdot, law, element, n_sub, dt, c.f_max)

    rows = []
    for cname, law in c.controllers.items():
        ref = run("dynamic", law, None)
        for ename, element in c.elements.items():
            rows.append((ename, cname, _errors(run("surrogate", law, element), ref)))
    return rows


def _row(element: str, cls: int, controller: str, e: np.ndarray) -> dict[str, Any]:
    """One row of the matrix from the per-seed errors ``e`` (seeds × [relative RMS
    acceleration error, x2, v2, ẍ2 errors]); a diverged seed has a non-finite error."""
    rel = e[:, 0]
    finite = np.isfinite(rel)
    return {
        "element": element,
        "class": cls,
        "controller": controller,
        "median": float(np.median(rel)),
        "p90": float(np.percentile(rel, 90)),
        "max": float(np.max(rel)),
        "eq9": tuple(float(np.median(e[finite, j])) for j in (1, 2, 3))
        if finite.any()
        else (np.inf,) * 3,
        "diverged": int(np.sum(~finite)),
        "errors": rel.tolist(),
    }


def validation_matrix(
    elements: Mapping[str, Any],
    classes: tuple[int, ...] = CLASSES,
    n_seeds: int = 20,
    controllers: Mapping[str, ForceLaw | None] | None = None,
    duration: float = 20.0,
    control_dt: float = 0.01,
    f_max: float = 8000.0,
    vehicle: str = "manchester",
    progress: Callable[[str], None] | None = None,
    workers: int = 1,
    address: str | None = None,
) -> dict[str, Any]:
    """Errors of each surrogate element against the reference across classes, seeds, laws.

    Parameters
    ----------
    elements : name → fitted LPR or Kriging element (static or memory form).
    classes : FRA classes, each run at its maximum speed.
    n_seeds : unseen tracks per class (:func:`seed_of`).
    controllers : name → force law ``x → F_a`` (N) on the state ``[x1, v1, x2, v2, …]``
        (``None``: passive); default passive, skyhook and LQR. With ``workers > 1`` or an
        ``address`` they must pickle (module-level functions or objects).
    duration, control_dt : s. f_max : actuator limit, N.
    progress : optional callback with a label after each class.
    workers, address : the tracks of a class run as tasks of
        :func:`railgym.parallel.run_tasks` (processes, a local Ray instance or the Ray
        cluster at ``address``); the result does not depend on them.

    Returns
    -------
    dict with ``rows`` (one per element × class × controller: ``median``, ``p90``, ``max``
    of the relative RMS acceleration error, ``eq9`` medians of the x2, v2, ẍ2 errors in
    m, m/s, m/s², ``diverged`` seed count, ``errors`` per seed), ``published`` (paper table
    8), ``seeds`` and the settings.
    """
    if not isinstance(n_seeds, int) or isinstance(n_seeds, bool) or n_seeds < 1:
        raise ValueError(f"n_seeds must be a positive integer, got {n_seeds!r}")
    if not elements:
        raise ValueError("elements is empty: give at least one surrogate element")
    veh = load_vehicle(vehicle)
    if controllers is None:
        controllers = {"passive": None, "skyhook": skyhook_law(), "LQR": lqr_law(veh, f_max)}
    dt = DEFAULT_DT["dynamic"]
    n_sub = round(control_dt / dt)
    if n_sub < 1 or abs(n_sub * dt - control_dt) > 1e-9:
        raise ValueError(f"control_dt must be a whole multiple of {dt} s, got {control_dt!r}")
    seeds = [seed_of(k) for k in range(n_seeds)]
    errs: dict[tuple[str, int, str], list[tuple[float, ...]]] = {}
    for cls in classes:
        cells = [
            _Cell(cls, seed, dict(elements), dict(controllers), veh, duration, n_sub, f_max)
            for seed in seeds
        ]
        for rows in run_tasks(_cell, cells, workers, address):
            for ename, cname, e in rows:
                errs.setdefault((ename, cls, cname), []).append(e)
        if progress is not None:
            progress(f"validation class {cls}")
    rows = [_row(ename, cls, cname, np.array(e)) for (ename, cls, cname), e in errs.items()]
    return {
        "rows": rows,
        "published": PAPER["table8"],
        "seeds": seeds,
        "settings": {
            "classes": list(classes),
            "n_seeds": n_seeds,
            "duration": duration,
            "control_dt": control_dt,
            "f_max": f_max,
            "vehicle": vehicle,
        },
    }


def check_targets(matrix: dict[str, Any], element: str) -> list[dict[str, Any]]:
    """Each :data:`TARGETS` entry measured for ``element``: ``class, controller, statistic,
    bound, measured, met`` (targets whose class or controller was not run are skipped)."""
    index = {(r["class"], r["controller"]): r for r in matrix["rows"] if r["element"] == element}
    out = []
    for cls, ctrl, stat, bound in TARGETS:
        row = index.get((cls, ctrl))
        if row is not None:
            out.append(
                {
                    "class": cls,
                    "controller": ctrl,
                    "statistic": stat,
                    "bound": bound,
                    "measured": row[stat],
                    "met": bool(row[stat] <= bound),
                }
            )
    return out
