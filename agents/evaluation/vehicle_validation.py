"""Surrogate against the high-fidelity model: relative RMS error of the carbody acceleration
over unseen tracks, on the newest ``railgym/VerticalVehicle`` (per floor point: front, centre,
rear) or ``railgym/VerticalSuspension`` (``--env vertical``, one bogie), against the reference
backend or the user's FMU (``--backend fmu --fmu-map MAP [--vehicle FILE]``).

    railgym validate --seeds 20 --track-class 3 4 5 6
    railgym validate --element vehicle maxwell --controller modal-skyhook lqr
    railgym validate --env vertical --element my_element.json \
        --backend fmu --fmu-map my_car.yaml --vehicle my_car_vehicle.yaml --seeds 10

For each class, controller and element, a native vector env with the surrogate and one with
the high-fidelity backend run the same ``n_seeds`` tracks (sub-env ``i`` on seed ``seed + i``)
in closed loop, each driven by the controller on its own observation; the score of a track is
``‖a − a_ref‖ / ‖a_ref‖`` of the accelerations recorded at the control rate over the whole
episode. Rows: median, 90th percentile and max over the tracks, per floor point.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from agents.controllers.registry import CONTROLLERS, ENV_ID, VEHICLE_CONTROLLERS, VEHICLE_ID
from railgym import registration

__all__ = [
    "ENVS",
    "FLOOR",
    "floor_errors",
    "record_episodes",
    "whole_track_version",
    "validation_rows",
]

#: floor points of the env's ``carbody_acc`` (front, centre, rear)
FLOOR = ("front", "centre", "rear")
#: per ``--env``: env id, controllers, points of ``carbody_acc``
ENVS: dict[str, tuple[str, dict[str, Any], tuple[str, ...]]] = {
    "vehicle": (VEHICLE_ID, VEHICLE_CONTROLLERS, FLOOR),
    "vertical": (ENV_ID, CONTROLLERS, ("carbody",)),
}
#: first track seed: never used to build an element
SEED = 2000


def whole_track_version(env_id: str) -> str:
    """The newest registered version of the env of ``env_id`` that draws its tracks whole
    (not streamed, ``stream_track``): the FMU backend draws them whole on every version, so a
    comparison against an FMU runs there, both sides on the same tracks of a seed."""
    family = registration.env_family(env_id)
    load = gym.envs.registration.load_env_creator
    whole = [
        e
        for e in registration.ENVS
        if registration.env_family(e) == family
        and not getattr(load(str(gym.spec(e).entry_point)), "stream_track", False)
    ]
    return max(whole, key=lambda e: int(e.rsplit("-v", 1)[1]))


def record_episodes(
    env_name: str,
    controller: str,
    kwargs: Mapping[str, Any],
    n: int,
    seed: int,
    env_id: str | None = None,
) -> dict[str, np.ndarray]:
    """One episode of a native vector env of ``n`` sub-envs of ``env_name`` (``env_id``:
    its version, default the newest; keywords ``kwargs``; sub-env ``i`` on seed ``seed + i``)
    in closed loop with ``controller`` on its own observation: ``acc`` the carbody
    accelerations (steps, n, points) m/s², ``outside`` the steps with
    ``info["outside_element"]`` (n,), ``envelope`` the episodes' ``info["outside_envelope"]``
    (n,) and ``div`` the diverged flags (n,)."""
    default, table, points = ENVS[env_name]
    env_id = env_id or default
    cls, ctl_kwargs, obs_kwargs = table[controller]
    env = gym.make_vec(
        env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs, **obs_kwargs
    )
    policy = cls(env, **ctl_kwargs)
    obs, info = env.reset(seed=seed)
    steps = env.unwrapped.cfg.n_steps
    acc = np.zeros((steps, n, len(points)))
    outside = np.zeros(n, np.int64)
    div = np.zeros(n, bool)
    for k in range(steps):
        action, _ = policy.predict(obs, deterministic=True)
        obs, _, terminated, _, info = env.step(action)
        acc[k] = np.reshape(info["carbody_acc"], (n, len(points)))
        outside += info["outside_element"]
        div |= terminated
    env.close()
    envelope = np.asarray(info["outside_envelope"], bool)
    return {"acc": acc, "outside": outside, "envelope": envelope, "div": div}


def floor_errors(
    element: Any,
    track_class: int,
    n_seeds: int,
    controller: str = "passive",
    duration: float = 20.0,
    seed: int = SEED,
    env_name: str = "vehicle",
    reference: Mapping[str, Any] | None = None,
) -> np.ndarray:
    """Relative RMS error (n_seeds, points) of the carbody accelerations, surrogate
    ``element`` vs the high-fidelity env, per track and point (inf where either run
    diverged). ``reference``: that env's keywords (default ``{"backend": "reference"}``; an
    FMU: ``backend="fmu", fmu_map=…``, with ``vehicle=`` for both envs)."""
    ref = dict(reference or {"backend": "reference"})
    common = {"vehicle": ref["vehicle"]} if "vehicle" in ref else {}
    case = {"track_class": track_class, "duration": duration}
    env_id = ENVS[env_name][0]
    if ref["backend"] == "fmu":
        env_id = whole_track_version(env_id)
    runs = [
        record_episodes(env_name, controller, {**case, **kw}, n_seeds, seed, env_id)
        for kw in ({"backend": "surrogate", "surrogate": element, **common}, ref)
    ]
    (a, div_a), (b, div_b) = ((r["acc"], r["div"]) for r in runs)
    err = np.sqrt(np.sum((a - b) ** 2, axis=0) / np.sum(b**2, axis=0))
    err[div_a | div_b] = np.inf
    return err


def validation_rows(
    elements: Mapping[str, Any],
    classes: Sequence[int] = (3, 4, 5, 6),
    controllers: Sequence[str] = ("passive",),
    n_seeds: int = 20,
    duration: float = 20.0,
    env_name: str = "vehicle",
    reference: Mapping[str, Any] | None = None,
    seed: int = SEED,
) -> list[dict[str, Any]]:
    """One row per element × class × controller: ``median``, ``p90``, ``max`` (points,) in
    % over the tracks where neither run diverged (NaN when none ran through), ``diverged``
    the number of the other tracks, and ``errors`` (n_seeds, points; inf where a run
    diverged); ``env_name``, ``reference`` and ``seed`` as :func:`floor_errors`'s."""
    rows = []
    for name, element in elements.items():
        for c in classes:
            for ctl in controllers:
                e = 100.0 * floor_errors(
                    element, c, n_seeds, ctl, duration, seed, env_name, reference
                )
                ran = np.all(np.isfinite(e), axis=1)
                rows.append(
                    {
                        "element": name,
                        "class": c,
                        "controller": ctl,
                        **_stats(e[ran], e.shape[1]),
                        "diverged": int(np.count_nonzero(~ran)),
                        "errors": e,
                    }
                )
    return rows


def _stats(e: np.ndarray, n_points: int) -> dict[str, np.ndarray]:
    """``median``, ``p90``, ``max`` (n_points,) of the errors ``e`` (tracks, points); NaN
    without a track."""
    if e.shape[0] == 0:
        nan = np.full(n_points, np.nan)
        return {"median": nan, "p90": nan, "max": nan}
    return {"median": np.median(e, axis=0), "p90": np.percentile(e, 90, axis=0), "max": e.max(0)}


#: the line under the table that says what its cells are
LEGEND = (
    "cells: relative RMS error of the carbody acceleration, %, median / 90th percentile / "
    "max over the tracks where neither run diverged; diverged: tracks where the surrogate "
    "or the high-fidelity run diverged (not in the cells), of the tracks run"
)


def format_rows(rows: Sequence[Mapping[str, Any]]) -> str:
    """Markdown table of :func:`validation_rows` (points: those of the rows' env), a
    ``diverged`` column and the :data:`LEGEND` under it."""
    n = len(rows[0]["median"]) if rows else len(FLOOR)
    points = FLOOR if n == len(FLOOR) else ENVS["vertical"][2]
    lines = [
        "| element | class | controller | " + " | ".join(points) + " | diverged |",
        "|---|---|---|" + "---|" * (len(points) + 1),
    ]
    for r in rows:
        cells = [
            "—"
            if np.isnan(r["median"][j])
            else f"{r['median'][j]:.1f} / {r['p90'][j]:.1f} / {r['max'][j]:.1f}"
            for j in range(len(points))
        ]
        diverged = f"{r.get('diverged', 0)} of {len(r['errors'])}"
        row = [str(r["element"]), str(r["class"]), str(r["controller"]), *cells, diverged]
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join([*lines, "", LEGEND])
