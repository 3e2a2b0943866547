"""Do the surrogate's validity flags fire where it is inaccurate? Per episode, the relative RMS
error of the carbody acceleration against the reference, beside ``info["outside_element"]``
(share of steps) and ``info["outside_envelope"]`` (docs/validation.md, *Validity flags*).

    railgym validity                     # both envs, classes 3-6 at 1.0, 1.5, 2.0 x, 5 seeds
    railgym validity --env vertical --track-class 4 --factor 2.0 --controller skyhook

For each env, class, speed factor (× the class's maximum speed) and controller, a native vector
env on the packaged surrogate element and one on the reference backend run the same
``n_seeds`` unseen tracks (sub-env ``i`` on seed ``seed + i``), each in closed loop with the
controller on its own observation (as :mod:`agents.evaluation.vehicle_validation`); the error of an
episode is ``‖a − a_ref‖ / ‖a_ref‖`` over the episode at the control rate, on the whole vehicle
the largest of its three floor points. The target: every episode whose error exceeds
``threshold`` (8 %) has a flag, ``outside_element`` on some step or ``outside_envelope``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

import railgym  # noqa: F401  (registers the environments)
from agents.evaluation.vehicle_validation import ENVS, SEED, record_episodes
from railgym.track import class_speed

__all__ = ["ENVS", "THRESHOLD", "case_episodes", "format_rows", "target_holds", "validity_rows"]

#: relative RMS error above which an episode must be flagged, %
THRESHOLD = 8.0


def _record(env_name: str, controller: str, kwargs: dict[str, Any], n: int, seed: int) -> dict:
    """:func:`~agents.evaluation.vehicle_validation.record_episodes` without the envelope's warning
    (the flag is recorded instead)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*the surrogate element was built for", UserWarning)
        return record_episodes(env_name, controller, kwargs, n, seed)


def case_episodes(
    env_name: str,
    track_class: int,
    factor: float,
    controller: str = "passive",
    n_seeds: int = 5,
    duration: float = 20.0,
    seed: int = SEED,
) -> dict[str, Any]:
    """The episodes of one case (``factor`` × the class's maximum speed): ``error`` (n_seeds,)
    %, the largest over the floor points (inf where either run diverged), ``error_points``
    (n_seeds, points) %, ``outside_element_%`` (n_seeds,) share of the steps flagged,
    ``outside_envelope`` (n_seeds,), ``flagged`` (n_seeds,): either flag."""
    common = {"track_class": track_class, "speed": factor * class_speed(track_class)}
    common["duration"] = duration
    sur = _record(env_name, controller, {"backend": "surrogate", **common}, n_seeds, seed)
    ref = _record(env_name, controller, {"backend": "reference", **common}, n_seeds, seed)
    a, b = sur["acc"], ref["acc"]
    err = 100.0 * np.sqrt(np.sum((a - b) ** 2, axis=0) / np.sum(b**2, axis=0))
    err[sur["div"] | ref["div"]] = np.inf
    share = 100.0 * sur["outside"] / a.shape[0]
    return {
        "env": env_name,
        "class": track_class,
        "factor": factor,
        "speed_kmh": factor * class_speed(track_class) * 3.6,
        "controller": controller,
        "error": err.max(axis=1),
        "error_points": err,
        "outside_element_%": share,
        "outside_envelope": sur["envelope"],
        "flagged": (sur["outside"] > 0) | sur["envelope"],
    }


def validity_rows(
    envs: Sequence[str] = ("vertical", "vehicle"),
    classes: Sequence[int] = (3, 4, 5, 6),
    factors: Sequence[float] = (1.0, 1.5, 2.0),
    controllers: Sequence[str] = ("passive", "skyhook"),
    n_seeds: int = 5,
    duration: float = 20.0,
    seed: int = SEED,
) -> list[dict[str, Any]]:
    """:func:`case_episodes` of every env × controller × class × factor."""
    return [
        case_episodes(e, c, f, ctl, n_seeds, duration, seed)
        for e in envs
        for ctl in controllers
        for c in classes
        for f in factors
    ]


def target_holds(rows: Sequence[dict[str, Any]], threshold: float = THRESHOLD) -> bool:
    """Every episode of ``rows`` whose error exceeds ``threshold`` (%) is flagged."""
    return all(bool(np.all(r["flagged"][r["error"] > threshold])) for r in rows)


def _flags(r: dict[str, Any], k: int) -> str:
    """Episode ``k``'s flags: ``E`` outside the envelope, ``B`` element inputs outside the
    box on some step (with the share of steps, %), ``-`` none."""
    out = "E" if r["outside_envelope"][k] else ""
    if r["outside_element_%"][k] > 0:
        out += f"B{r['outside_element_%'][k]:.2g}"
    return out or "-"


def format_rows(rows: Sequence[dict[str, Any]], threshold: float = THRESHOLD) -> str:
    """Markdown table of :func:`validity_rows`: per case the episodes' errors (%) and flags
    (:func:`_flags`), ``miss`` marking an episode above ``threshold`` without a flag; and a
    closing line whether the target holds."""
    lines = [
        "| env | controller | class | speed | error per seed, % | flags per seed | max error "
        "unflagged, % |",
        "|---|---|---|---|---|---|---|",
    ]
    n_over = n_missed = 0
    for r in rows:
        over = r["error"] > threshold
        missed = over & ~r["flagged"]
        n_over, n_missed = n_over + int(over.sum()), n_missed + int(missed.sum())
        errors = " / ".join(f"{e:.1f}" for e in r["error"])
        flags = " ".join(
            _flags(r, k) + (" (miss)" if missed[k] else "") for k in range(len(r["error"]))
        )
        quiet = r["error"][~r["flagged"]]
        worst = f"{quiet.max():.1f}" if quiet.size else "–"
        lines.append(
            f"| {r['env']} | {r['controller']} | {r['class']} | {r['factor']:g} × "
            f"({r['speed_kmh']:.0f} km/h) | {errors} | {flags} | {worst} |"
        )
    verdict = "holds" if n_missed == 0 else "does not hold"
    lines.append("")
    lines.append(
        f"{n_over} episodes above {threshold:g} %, {n_over - n_missed} of them flagged: the "
        f"target {verdict}."
    )
    return "\n".join(lines)
