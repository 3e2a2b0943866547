"""Policy-aware refinement of the whole vehicle's secondary element (``VerticalVehicle-v1``).

The loop of :func:`railgym.vehicles.collect.refine` on the whole vehicle: each round runs the
whole vehicle's dynamic reference under a policy (both actuators, closed loop on the
reference's observation), takes both bogies' element inputs and force errors along those runs,
adds the worst samples to the training set and refits the element; held-out tracks score the
element before the first round and after each (surrogate and reference each driven by the
policy, relative RMS error of the floor accelerations). ``railgym refine POLICY --env vehicle``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from railgym import _checks as val
from railgym.track import fra_profile_with_slope
from railgym.vehicles.memory_element import memory_training_data
from railgym.vehicles.refinement import (
    RefineOptions,
    element_pairs,
    initial_pairs,
    refine_rounds,
)
from railgym.vehicles.vehicle.collect import VEHICLE_DESIGN, collect_vehicle
from railgym.vehicles.vehicle.lanes import hermite
from railgym.vehicles.vehicle.model import (
    DEFAULT_DT,
    N_MECH,
    advance,
    check_variant,
    kernel_params,
    lpr_arrays,
    new_arrays,
    wheelset_offsets,
)
from railgym.vehicles.vehicle.params import load_whole_vehicle
from surrogates.memory import element_form
from surrogates.models import SurrogateModel

__all__ = ["RAW_VEHICLE_OBSERVATION", "refine_vehicle", "run_vehicle_policy"]

#: the physical observation (SI) a refinement policy receives, in order: the 14 mechanical
#: states, the 5 accelerations (floor front/centre/rear, bogies front/rear) and the wheelset
#: inputs (heights, then rates, front to rear)
RAW_VEHICLE_OBSERVATION = (
    *("z_c", "theta_c", "q", "z_b0", "theta_b0", "z_b1", "theta_b1"),
    *("z_c_dot", "theta_c_dot", "q_dot", "z_b0_dot", "theta_b0_dot", "z_b1_dot", "theta_b1_dot"),
    *("acc_front", "acc_centre", "acc_rear", "bogie_acc_front", "bogie_acc_rear"),
    *(f"w{j}" for j in range(4)),
    *(f"w{j}_dot" for j in range(4)),
)


def _policy_forces(policy: Any, observe: Any, f_max: float) -> Any:
    """``raw observation → actuator forces (2,)``, N, of a policy (callable or ``predict``)."""

    def law(raw: np.ndarray) -> np.ndarray:
        obs = raw if observe is None else observe(raw)
        if hasattr(policy, "predict"):
            action = policy.predict(obs, deterministic=True)[0]
        else:
            action = policy(obs)
        a = np.asarray(action, dtype=np.float64).ravel()
        if a.size != 2 or not np.all(np.isfinite(a)):
            raise ValueError(f"policy must return two finite actions, got {action!r}")
        return np.clip(a, -1.0, 1.0) * f_max

    return law


def run_vehicle_policy(
    variant: str,
    vehicle: Any,
    track: tuple[np.ndarray, np.ndarray, np.ndarray],
    law: Any,
    element: Any,
    n_steps: int,
    n_sub: int,
) -> dict[str, Any]:
    """One closed-loop run recorded at every integration step of ``DEFAULT_DT`` (s).

    ``track`` is ``(z, zdot, offsets)`` of
    :class:`~railgym.vehicles.vehicle.model.VehicleArrays`; the law gets the raw observation
    (:data:`RAW_VEHICLE_OBSERVATION`) every ``n_sub`` steps. Returns
    ``t`` (s), per bogie ``delta`` (m), ``delta_dot`` (m/s), ``force`` (F_s, N) as (2, n + 1)
    arrays, ``acc`` (floor points at the control steps, (n // n_sub, 3), m/s²), ``ood`` and
    ``diverged``.
    """
    dt = DEFAULT_DT
    kind = check_variant(variant)
    lpr = lpr_arrays(element if variant == "surrogate" else None, dt)
    z, zdot, off = track
    arrays, out = new_arrays(1, variant, z.size, lpr)
    arrays.z[0], arrays.zdot[0], arrays.off[0] = z, zdot, off
    p, e = kernel_params(vehicle), vehicle.suspension.kernel_params().record()
    rec = np.full((3, 2, n_steps + 1), np.nan)
    rec[:, :, 0] = 0.0
    acc = np.full((n_steps // n_sub, 3), np.nan)
    raw = np.zeros(len(RAW_VEHICLE_OBSERVATION))
    ood = 0
    for k in range(n_steps):
        if k % n_sub == 0:
            raw[:N_MECH] = arrays.state[0, :N_MECH]
            raw[N_MECH : N_MECH + 5] = out.acc[0]
            for j in range(4):
                raw[N_MECH + 5 + j], raw[N_MECH + 9 + j] = hermite(z, zdot, k + off[j], dt)
            arrays.force[0] = law(raw)
        advance(kind, arrays, 1, dt, p, e, lpr, out)
        arrays.k[0] += 1
        ood += int(out.count[0, 1])
        if out.div[0]:
            break
        x = arrays.state[0]
        for b, xb in enumerate((p.a, -p.a)):
            rec[0, b, k + 1] = x[3 + 2 * b] - x[0] - xb * x[1] - p.phi_a * x[2]
            rec[1, b, k + 1] = x[10 + 2 * b] - x[7] - xb * x[8] - p.phi_a * x[9]
            rec[2, b, k + 1] = out.fs[0, b]
        if (k + 1) % n_sub == 0:
            acc[(k + 1) // n_sub - 1] = out.acc[0, :3]
    return {
        "t": np.arange(n_steps + 1) * dt,
        "delta": rec[0],
        "delta_dot": rec[1],
        "force": rec[2],
        "acc": acc,
        "ood": ood,
        "diverged": bool(out.div[0]),
    }


def _vehicle_pairs(model: SurrogateModel, vehicle: str) -> tuple[np.ndarray, np.ndarray]:
    """Training pairs of the whole vehicle's recipe (:data:`VEHICLE_DESIGN`) in the feature
    form of ``model`` (an element with a relaxation law)."""
    form = element_form(getattr(model, "features_", None))
    base = load_whole_vehicle(vehicle).suspension.name
    data = collect_vehicle(VEHICLE_DESIGN, vehicle)
    return memory_training_data(data, form.tau, form.known_physics, base, form.relaxation)


def refine_vehicle(
    model: SurrogateModel,
    policy: Any,
    rounds: int = 3,
    *,
    options: RefineOptions | None = None,
    data: tuple[Any, Any] | None = None,
    observe: Any = None,
    vehicle: str = "manchester_whole",
    log: Any = print,
) -> tuple[SurrogateModel, list[dict[str, Any]]]:
    """:func:`railgym.vehicles.collect.refine` on the whole vehicle (same arguments and
    :class:`~railgym.vehicles.refinement.RefineOptions`; the policy returns two actions and
    ``observe`` maps :data:`RAW_VEHICLE_OBSERVATION`).

    Returns ``(model, history)``; each history row has ``round``, ``error`` (median held-out
    relative RMS error of the worst floor point), ``errors`` (its median per floor point,
    front/centre/rear), ``ood`` and ``n_samples``.
    """
    o = RefineOptions() if options is None else options
    rounds = val.integer(rounds, "rounds", min=0)
    element_form(getattr(model, "features_", None), model.n_features_in_, "model")
    veh = load_whole_vehicle(vehicle)
    base = veh.suspension.name
    dt = DEFAULT_DT
    n_sub, every = o.steps(dt)
    n_steps = round(o.duration / o.control_dt) * n_sub
    law = _policy_forces(policy, observe, o.f_max)
    v0 = o.speed_or_class()
    off = wheelset_offsets(veh, v0, dt)
    m = n_steps + int(np.ceil(off.max())) + 2
    if data is None and element_form(getattr(model, "features_", None)).relaxation is not None:
        data = _vehicle_pairs(model, vehicle)
    elif data is None:
        data = initial_pairs(model, base)

    def track(tag: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s = o.track_seed(tag)
        _, z, slope = fra_profile_with_slope(o.track_class, (m - 1) * v0 * dt, v0 * dt, s)
        return z[:m], v0 * slope[:m], off

    def run(variant: str, tr: tuple[np.ndarray, ...], element: Any) -> dict[str, Any]:
        return run_vehicle_policy(variant, veh, tr, law, element, n_steps, n_sub)

    def pairs(model: SurrogateModel, ref: dict[str, Any]) -> list[tuple[Any, Any]]:
        keys = ("delta", "delta_dot", "force")
        bogies = [{"t": ref["t"], **{k: ref[k][b] for k in keys}} for b in range(2)]
        return [element_pairs(model, bogie, every, base) for bogie in bogies]

    def report(r: int, errors: Any, ood: int, n: int) -> tuple[dict[str, Any], str]:
        row = {"round": r, "error": float(errors.max()), "errors": errors, "ood": ood}
        line = (
            f"round {r}: held-out rel. RMS error of the floor acceleration front / centre / "
            f"rear {' / '.join(f'{100 * e:.2f}' for e in errors)} %, out-of-domain "
            f"evaluations {ood}, samples {n}"
        )
        return {**row, "n_samples": n}, line

    return refine_rounds(
        model,
        data,
        rounds,
        o,
        track,
        lambda tr: run("dynamic", tr, None),
        lambda tr, m: run("surrogate", tr, m),
        pairs,
        "acc",
        report,
        log,
    )
