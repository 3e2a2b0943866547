"""Surrogate against reference on ``railgym/VerticalVehicle-v1``: relative RMS error of the
carbody acceleration at each floor point (front, centre, rear) over unseen tracks.

    python -m agents.vehicle_validation --seeds 20 --track-class 3 4 5 6
    python -m agents.vehicle_validation --element vehicle maxwell --controller modal-skyhook lqr

For each class, controller and element, a native vector env with the surrogate and one with
the reference backend run the same ``n_seeds`` tracks (sub-env ``i`` on seed ``seed + i``) in
closed loop, each driven by the controller on its own observation; the score of a track is
``‖a − a_ref‖ / ‖a_ref‖`` of the floor accelerations recorded at the control rate over the
whole episode. Rows: median, 90th percentile and max over the tracks, per floor point.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from agents._args import duration_s, episodes, track_class
from agents.policies import VEHICLE_CONTROLLERS, VEHICLE_ID
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.collect_vehicle import default_vehicle_surrogate

__all__ = ["FLOOR", "floor_errors", "main", "validation_rows"]

#: floor points of the env's ``carbody_acc`` (front, centre, rear)
FLOOR = ("front", "centre", "rear")
#: first track seed: never used to build an element
SEED = 2000


def _record(env: Any, controller: str, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Floor accelerations (n_steps, n, 3) of one episode of every sub-env, and the diverged
    flags (n,)."""
    cls, kwargs, _ = VEHICLE_CONTROLLERS[controller]
    policy = cls(env, **kwargs)
    obs, _ = env.reset(seed=seed)
    n_steps = env.unwrapped.cfg.n_steps if hasattr(env, "unwrapped") else env.cfg.n_steps
    rec = np.zeros((n_steps, env.num_envs, 3))
    div = np.zeros(env.num_envs, bool)
    for k in range(n_steps):
        action, _ = policy.predict(obs, deterministic=True)
        obs, _, terminated, _, info = env.step(action)
        rec[k] = info["carbody_acc"]
        div |= terminated
    return rec, div


def floor_errors(
    element: Any,
    track_class: int,
    n_seeds: int,
    controller: str = "passive",
    duration: float = 20.0,
    seed: int = SEED,
) -> np.ndarray:
    """Relative RMS error (n_seeds, 3) of the floor accelerations, surrogate ``element`` vs
    reference, per track and floor point (inf where either run diverged)."""
    obs_kw = VEHICLE_CONTROLLERS[controller][2]
    runs = []
    for backend, sur in (("surrogate", element), ("reference", None)):
        env = gym.make_vec(
            VEHICLE_ID,
            num_envs=n_seeds,
            vectorization_mode="vector_entry_point",
            backend=backend,
            surrogate=sur,
            track_class=track_class,
            duration=duration,
            **obs_kw,
        )
        runs.append(_record(env, controller, seed))
        env.close()
    (a, div_a), (b, div_b) = runs
    err = np.sqrt(np.sum((a - b) ** 2, axis=0) / np.sum(b**2, axis=0))
    err[div_a | div_b] = np.inf
    return err


def validation_rows(
    elements: Mapping[str, Any],
    classes: Sequence[int] = (3, 4, 5, 6),
    controllers: Sequence[str] = ("passive",),
    n_seeds: int = 20,
    duration: float = 20.0,
) -> list[dict[str, Any]]:
    """One row per element × class × controller: ``median``, ``p90``, ``max`` (3,) per floor
    point, in %, and ``errors`` (n_seeds, 3)."""
    rows = []
    for name, element in elements.items():
        for c in classes:
            for ctl in controllers:
                e = 100.0 * floor_errors(element, c, n_seeds, ctl, duration)
                rows.append(
                    {
                        "element": name,
                        "class": c,
                        "controller": ctl,
                        "median": np.median(e, axis=0),
                        "p90": np.percentile(e, 90, axis=0),
                        "max": e.max(axis=0),
                        "errors": e,
                    }
                )
    return rows


def format_rows(rows: Sequence[Mapping[str, Any]]) -> str:
    """Markdown table of :func:`validation_rows`."""
    lines = [
        "| element | class | controller | " + " | ".join(FLOOR) + " |",
        "|---|---|---|" + "---|" * len(FLOOR),
    ]
    for r in rows:
        cells = [
            f"{r['median'][j]:.1f} / {r['p90'][j]:.1f} / {r['max'][j]:.1f}"
            for j in range(len(FLOOR))
        ]
        lines.append(f"| {r['element']} | {r['class']} | {r['controller']} | " + " | ".join(cells))
    return "\n".join(lines)


def _packaged(name: str) -> Any:
    """A packaged element by name (``vehicle``, ``maxwell``, ``static``), else ``name`` (a path)."""
    if name == "vehicle":
        return default_vehicle_surrogate()
    if name in ("maxwell", "static"):
        return default_vertical_surrogate(name)
    return name


def main(argv: Sequence[str] | None = None) -> int:
    """Print the table (relative RMS error, %, median / 90th percentile / max per floor point)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--element",
        nargs="+",
        default=["vehicle"],
        help="packaged element (vehicle: the env's default; maxwell, static: the one-bogie "
        "elements) or JSON",
    )
    parser.add_argument("--track-class", type=track_class, nargs="+", default=[3, 4, 5, 6])
    parser.add_argument("--controller", nargs="+", default=["passive"])
    parser.add_argument("--seeds", type=episodes, default=20, help="tracks per class")
    parser.add_argument("--duration", type=duration_s, default=20.0, help="s per track")
    args = parser.parse_args(argv)
    for c in args.controller:
        if c not in VEHICLE_CONTROLLERS:
            parser.error(f"--controller must be among {sorted(VEHICLE_CONTROLLERS)}, got {c!r}")
    elements = {e: _packaged(e) for e in args.element}
    rows = validation_rows(elements, args.track_class, args.controller, args.seeds, args.duration)
    print(format_rows(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
