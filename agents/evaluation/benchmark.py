"""Benchmark protocol: train a config over several seeds, evaluate every seed on the
**reference** backend over held-out cases beside the classical baselines, and write the
numbers, a learning curve and a table.

    railgym benchmark CONFIG --seeds 3 --workers 2 [--timesteps T] [--episodes E]
                             [-o DIR] [--overwrite] [--seed S] [--address ADDR]

``CONFIG`` is an :mod:`agents.training.train` config (file or packaged name). Each seed ``s`` of
``seed … seed + seeds − 1`` (``--seed``, ``--seeds``) is one task
(:func:`railgym.parallel.run_tasks`: in this process, a process pool or Ray):
``agents.training.train`` with that seed into ``DIR/seed_<s>/``, then the held-out evaluation of its
final ``model.zip`` (:data:`HELD_OUT`; tracks of seeds 1000 + i, never trained on). Every task is
seeded, so the numbers do not depend on the number of workers. Output in ``DIR`` (default
``runs/benchmark_<config stem>/``):

* ``results.csv``: one row per (policy, seed, case, metric): ``value`` and ``unit``; the
  baselines have an empty seed.
* ``learning_curve.png``: the evaluation metric of the training runs (``eval.csv``: reference
  backend, the config's evaluation env) against environment steps, mean and min–max band over
  the seeds, the baselines on the same evaluation episodes as horizontal lines.
* ``table.md``: per case and metric (``a_w`` and the bump-stop contacts beside it), mean ±
  sample standard deviation over the seeds and the 95 % Student-t interval of the mean, beside
  each baseline's value; under it a line for each case where the agent's mean ``a_w`` beats a
  baseline's with more mean contacts (:mod:`agents.evaluation.contacts`).

The baselines (:func:`agents.controllers.registry.baselines_of`): those of the env, and for a
vertical config with ``actuator: semi-active`` the controllers of the damper
(:data:`~agents.controllers.registry.SEMI_ACTIVE_BASELINES`), for a vehicle config with
``preview`` the LQG and the LQ preview (:data:`~agents.controllers.registry.PREVIEW_BASELINES`);
the metrics and their units: :mod:`agents.evaluation.metrics`. They run with the config's actuator
and preview settings (:data:`ACTUATOR_KEYS`, :data:`VEHICLE_KEYS`) as the agent does.
"""

from __future__ import annotations

import csv
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import yaml

from agents.controllers.registry import (
    CRASH_ID,
    ENV_ID,
    VEHICLE_ID,
    baselines_of,
    crash_factories,
)
from agents.evaluation.contacts import Score, contact_note, more_contacts
from agents.evaluation.metrics import ENVELOPE, VEHICLE, VERTICAL, metrics
from agents.evaluation.runs import evaluate_vehicle
from agents.evaluation.sweeps import evaluate_sweep
from agents.policies.loading import load_policy
from agents.training.train_config import MAX_SEED, load_config
from railgym import _checks as val
from railgym.parallel import run_tasks
from railgym.registration import env_family
from railgym.report.output import prepare_output_dir, write_text_atomic

__all__ = ["HELD_OUT", "benchmark"]

#: held-out cases per env: FRA classes at their maximum speed (vertical, vehicle); the crash
#: envelope's speeds × payloads (:data:`agents.evaluation.crash_report.EVAL_SPEEDS_KMH`)
HELD_OUT: dict[str, tuple[int, ...]] = {ENV_ID: (4, 5, 6), VEHICLE_ID: (4, 5), CRASH_ID: ()}
#: vertical env settings of a training config that the baselines share with the agent
ACTUATOR_KEYS = ("actuator", "damper")
#: vehicle env settings of a training config that the baselines share with the agent
VEHICLE_KEYS = ("preview",)
#: learning-curve metric per env: ``eval.csv`` column (``_<j>`` columns reduced), reduction,
#: axis label
CURVES = {
    ENV_ID: ("mean_rms_carbody_acc", "mean", "RMS carbody acceleration (m/s²)"),
    VEHICLE_ID: ("mean_rms_carbody_acc", "mean", "RMS floor acceleration, mean of 3 (m/s²)"),
    CRASH_ID: ("mean_peak_decel_g", "max", "worst-car peak deceleration (g)"),
}
#: seed of the held-out tracks (sub-env i: 1000 + i), as ``railgym evaluate``
EVAL_SEED = 1000
FLOOR = ("front", "centre", "rear")
#: crash env settings of a training config that the baselines share with the agent
CRASH_KEYS = ("scenario", "control_dt", "absorber_range", "absorber_rate", "n_cars")


def _key(env_id: str) -> str:
    """The key of the env of ``env_id`` (any version of it) in this module's tables."""
    family = env_family(env_id)
    return next((e for e in (ENV_ID, VEHICLE_ID, CRASH_ID) if env_family(e) == family), env_id)


def _baseline_kwargs(env_id: str, env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """The settings of ``env_kwargs`` the baselines share with the agent: :data:`CRASH_KEYS`
    (crash), :data:`ACTUATOR_KEYS` (vertical), :data:`VEHICLE_KEYS` (vehicle)."""
    keys = {CRASH_ID: CRASH_KEYS, ENV_ID: ACTUATOR_KEYS, VEHICLE_ID: VEHICLE_KEYS}.get(
        _key(env_id), ()
    )
    return {k: v for k, v in env_kwargs.items() if k in keys}


class SeedTask(NamedTuple):
    """One training seed and its held-out evaluation."""

    config: dict[str, Any]
    out: str
    seed: int
    timesteps: int | None
    episodes: int


def _vertical_rows(rows: list[dict[str, Any]], seed: int | None) -> list[dict[str, Any]]:
    out = []
    for r in rows:
        case = f"class {r['track_class']}"
        for m in metrics(VERTICAL, "a_w", "rms_acc", "contacts"):
            out.append(_row(r["policy"], seed, case, m.key, m.value(r), m.unit))
    return out


def _vehicle_rows(rows: list[dict[str, Any]], seed: int | None) -> list[dict[str, Any]]:
    a_w, contacts = metrics(VEHICLE, "a_w", "contacts")
    out = []
    for r in rows:
        case = f"class {r['track_class']}, {r['speed_kmh']:.0f} km/h"
        for j, point in enumerate(FLOOR):
            out.append(_row(r["policy"], seed, case, f"{a_w.key}_{point}", r[a_w.key][j], a_w.unit))
        out.append(_row(r["policy"], seed, case, contacts.key, r[contacts.key], contacts.unit))
    return out


def _crash_rows(rows: list[dict[str, Any]], seed: int | None) -> list[dict[str, Any]]:
    from agents.evaluation.crash_report import envelope_summary

    out = []
    for name, s in envelope_summary(rows).items():
        if seed is not None and name == "passive":
            continue
        for m in metrics(ENVELOPE, "peak_g", "excess_over_passive_m", "passed"):
            out.append(_row(name, seed, "envelope", m.key, m.value(s), m.unit))
    return out


def _row(policy: str, seed: int | None, case: str, metric: str, value: Any, unit: str) -> dict:
    return {
        "policy": policy,
        "seed": "" if seed is None else seed,
        "case": case,
        "metric": metric,
        "value": float(value),
        "unit": unit,
    }


def held_out(
    env_id: str,
    policies: Sequence[str],
    episodes: int,
    seed: int | None,
    label: str | None = None,
    env_kwargs: dict[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """Held-out rows (:func:`_row` form) of ``policies`` (names or a ``.zip``) on the reference
    backend; ``label`` renames the zip's rows (``seed``: the training seed, ``None`` for
    baselines); ``env_kwargs``: env settings of the crash and vertical baselines
    (:func:`_baseline_kwargs`; a zip's own come from its config)."""
    key = _key(env_id)
    if key == ENV_ID:
        rows = _vertical_rows(
            evaluate_sweep(
                policies,
                "reference",
                HELD_OUT[key],
                episodes,
                env_kwargs=env_kwargs,
                env_id=env_id,
            ),
            seed,
        )
    elif key == VEHICLE_ID:
        rows = _vehicle_rows(
            evaluate_vehicle(
                policies,
                "reference",
                HELD_OUT[key],
                (None,),
                episodes,
                env_kwargs=env_kwargs,
                env_id=env_id,
            ),
            seed,
        )
    else:
        from agents.evaluation import crash_report

        factories = crash_factories(["passive"])
        for p in policies:
            if baseline := crash_factories([p]):
                factories.update(baseline)
            else:
                factory, env_kwargs, _ = load_policy(p, CRASH_ID)
                factories[label or p] = factory
        rows = _crash_rows(crash_report.envelope_rows(factories, env_kwargs), seed)
    if label is not None:
        zips = {p for p in policies if p.endswith(".zip")}
        names = {Path(p).parent.name for p in zips}
        for r in rows:
            if r["policy"] in names:
                r["policy"] = label
    return rows


def _run_seed(task: SeedTask) -> list[dict[str, Any]]:
    """Train one seed, then its held-out rows."""
    import torch

    from agents.training.train import train

    torch.set_num_threads(1)
    out = train(task.config, task.out, task.timesteps, False, task.seed, overwrite=True)
    env_id = next(iter(task.config))
    algo = load_config(task.config).algo
    model = str(out / "model.zip")
    rows = held_out(env_id, [model], task.episodes, task.seed, label=algo)
    return [r for r in rows if r["policy"] == algo]


def _curve(path: Path, column: str, how: str) -> tuple[np.ndarray, np.ndarray]:
    """``(timesteps, metric)`` of one ``eval.csv`` (``column`` or its ``_<j>`` columns)."""
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    steps = np.array([float(r["timesteps"]) for r in rows])
    keys = [k for k in rows[0] if k == column or k.removeprefix(f"{column}_").isdigit()]
    vals = np.array([[float(r[k]) for k in keys] for r in rows])
    return steps, (vals.max(axis=1) if how == "max" else vals.mean(axis=1))


def _baseline_curve_values(cfg: Any) -> dict[str, float]:
    """Each baseline's curve metric on the config's evaluation episodes (the same tracks)."""
    from agents.training.train import evaluate as run_eval
    from agents.training.train import make_vec

    column, how, _ = CURVES[_key(cfg.env_id)]
    out = {}
    for name in baselines_of(cfg.env_id, cfg.env_kwargs):
        extra: dict[str, Any] = {}
        if cfg.env_id == CRASH_ID:
            factory = crash_factories([name])[name]
        else:
            factory, extra, _ = load_policy(name, cfg.env_id)
        kwargs = {**cfg.env_kwargs, **cfg.eval_env_kwargs, **extra}
        venv = make_vec(cfg.env_id, cfg.n_eval_episodes, kwargs)
        stats = run_eval(factory(venv), venv, cfg.eval_seed)
        venv.close()
        keys = [k for k in stats if k == column or k.removeprefix(f"{column}_").isdigit()]
        vals = [stats[k] for k in keys]
        out[name] = float(np.max(vals) if how == "max" else np.mean(vals))
    return out


def curve_figure(out: Path, cfg: Any, seeds: Sequence[int], baselines: dict[str, float]) -> Any:
    """The matplotlib figure of ``learning_curve.png``: mean and min–max band over the seeds,
    baselines as lines; the x axis counts env steps (decisions × ``action_hold``). The mean
    carries markers, so that a run with a single evaluation (``eval_freq`` at least
    ``n_timesteps``) shows its point; its band is then an error bar."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    column, how, label = CURVES[_key(cfg.env_id)]
    curves = [_curve(out / f"seed_{s}" / "eval.csv", column, how) for s in seeds]
    n = min(len(c[0]) for c in curves)
    steps = curves[0][0][:n] * cfg.action_hold  # eval.csv counts decisions
    vals = np.array([c[1][:n] for c in curves])
    mean, low, high = vals.mean(axis=0), vals.min(axis=0), vals.max(axis=0)
    fig, ax = plt.subplots(figsize=(7.6, 4.0), dpi=120)
    ax.plot(
        steps,
        mean,
        color="C0",
        marker="o",
        markersize=4 if n > 1 else 6,
        label=f"{cfg.algo} (mean of {len(seeds)} seeds)",
    )
    if n > 1:
        ax.fill_between(steps, low, high, color="C0", alpha=0.25)
    else:  # one point: the band of the seeds as an error bar
        ax.errorbar(steps, mean, yerr=[mean - low, high - mean], fmt="none", ecolor="C0", capsize=4)
        ax.set_xlim(0.0, 2.0 * float(steps[0]) if steps[0] > 0 else 1.0)
    for i, (name, value) in enumerate(baselines.items()):
        ax.axhline(value, color=f"C{i + 1}", linestyle="--", label=name)
    ax.set_xlabel("environment steps (–)")
    ax.set_ylabel(label)
    ax.set_title(f"{cfg.env_id}: evaluation on the reference backend", fontsize=9)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))  # beside the curves
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def plot_curves(out: Path, cfg: Any, seeds: Sequence[int], baselines: dict[str, float]) -> Path:
    """``learning_curve.png`` of :func:`curve_figure` in ``out``; returns its path."""
    import matplotlib.pyplot as plt

    fig = curve_figure(out, cfg, seeds, baselines)
    path = out / "learning_curve.png"
    fig.savefig(path)
    plt.close(fig)
    return path


def contact_lines(rows: list[dict[str, Any]], algo: str) -> list[str]:
    """Markdown lines, one per case where the agent's ``a_w`` (mean over the seeds, and over
    the floor points of a vehicle's ``a_w_<point>``) beats a baseline's with more bump-stop
    contacts (mean over the seeds) than it; none without such a case."""
    values: dict[tuple[str, str], dict[str, list[float]]] = {}
    for r in rows:
        kind = "contacts" if r["metric"] == "contacts" else "a_w"
        if kind == "a_w" and not r["metric"].startswith("a_w"):
            continue
        policy = algo if r["seed"] != "" else r["policy"]
        values.setdefault((r["case"], policy), {"a_w": [], "contacts": []})[kind].append(r["value"])
    scores = [
        Score(case, policy, float(np.mean(v["a_w"])), float(np.mean(v["contacts"])))
        for (case, policy), v in values.items()
        if v["a_w"] and v["contacts"]
    ]
    bases = {r["policy"] for r in rows if r["seed"] == ""}
    return [
        f"- {s.case}: {algo} has a lower a_w with {contact_note(names)} (bump-stop substeps)"
        for s, names in zip(scores, more_contacts(scores, bases), strict=True)
        if names and s.policy == algo
    ]


def summary_table(rows: list[dict[str, Any]], algo: str) -> str:
    """Markdown: per (case, metric), the agent's mean ± std over seeds with the 95 % Student-t
    interval of the mean, and each baseline's value; then the :func:`contact_lines`."""
    from scipy import stats

    keys = list(dict.fromkeys((r["case"], r["metric"], r["unit"]) for r in rows))
    bases = list(dict.fromkeys(r["policy"] for r in rows if r["seed"] == ""))
    head = f"| case | metric | {algo} mean ± std (95 % interval) | " + " | ".join(bases) + " |"
    lines = [head, "|" + "---|" * (3 + len(bases))]
    for case, metric, unit in keys:
        mine = np.array(
            [
                r["value"]
                for r in rows
                if (r["case"], r["metric"]) == (case, metric) and r["seed"] != ""
            ]
        )
        if mine.size > 1:
            sd = float(mine.std(ddof=1))
            half = float(stats.t.ppf(0.975, mine.size - 1)) * sd / math.sqrt(mine.size)
            cell = (
                f"{mine.mean():.4g} ± {sd:.2g} ({mine.mean() - half:.4g}…{mine.mean() + half:.4g})"
            )
        elif mine.size == 1:
            cell = f"{mine[0]:.4g} (one seed)"
        else:
            cell = "–"
        base = {
            r["policy"]: r["value"]
            for r in rows
            if (r["case"], r["metric"]) == (case, metric) and r["seed"] == ""
        }
        cells = " | ".join(f"{base[b]:.4g}" if b in base else "–" for b in bases)
        lines.append(f"| {case} | {metric} ({unit}) | {cell} | {cells} |")
    notes = contact_lines(rows, algo)
    return "\n".join(lines + ([""] + notes if notes else [])) + "\n"


def benchmark(
    config: str | Path,
    seeds: int = 3,
    workers: int = 1,
    timesteps: int | None = None,
    episodes: int = 10,
    out: str | Path | None = None,
    overwrite: bool = False,
    first_seed: int | None = None,
    address: str | None = None,
) -> Path:
    """Run the protocol (module docstring); returns the output folder. ``first_seed``
    ``None``: the config's ``seed`` (a value the file gives is not replaced by a default)."""
    cfg = load_config(config)
    seeds = val.integer(seeds, "seeds", min=1, max=1000)
    first_seed = cfg.seed if first_seed is None else first_seed
    first_seed = val.integer(first_seed, "first_seed", min=0, max=MAX_SEED - seeds)
    episodes = val.integer(episodes, "episodes", min=1, max=1000)
    if timesteps is not None:
        timesteps = val.integer(timesteps, "timesteps", min=1)
    out = Path("runs") / f"benchmark_{Path(str(config)).stem}" if out is None else Path(out)
    out = prepare_output_dir(out, overwrite)
    block = cfg.to_yaml_dict()
    seed_list = list(range(first_seed, first_seed + seeds))
    tasks = [SeedTask(block, str(out / f"seed_{s}"), s, timesteps, episodes) for s in seed_list]
    print(
        f"training {seeds} seeds of {cfg.env_id} ({cfg.algo}): {first_seed} … "
        f"{first_seed + seeds - 1} …",
        file=sys.stderr,
    )
    rows: list[dict[str, Any]] = []
    for part in run_tasks(_run_seed, tasks, workers, address):
        rows.extend(part)
    print("held-out evaluation of the baselines …", file=sys.stderr)
    names = list(baselines_of(cfg.env_id, cfg.env_kwargs))
    shared = _baseline_kwargs(cfg.env_id, cfg.env_kwargs)
    rows.extend(held_out(cfg.env_id, names, episodes, None, None, shared))
    with (out / "results.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, ["policy", "seed", "case", "metric", "value", "unit"])
        writer.writeheader()
        writer.writerows(rows)
    plot_curves(out, cfg, seed_list, _baseline_curve_values(cfg))
    settings = {
        "config": str(config),
        "seeds": seed_list,
        "timesteps": timesteps,
        "episodes": episodes,
    }
    text = (
        f"# Benchmark of {cfg.env_id}, {cfg.algo}\n\n```yaml\n{yaml.safe_dump(settings)}```\n\n"
        f"Held-out cases on the reference backend ({episodes} episodes each, tracks of seeds "
        f"{EVAL_SEED}+i); agent: mean ± sample std over {seeds} seeds (95 % Student-t "
        "interval of the mean); baselines: one deterministic run.\n\n"
        + summary_table(rows, cfg.algo)
    )
    write_text_atomic(out / "table.md", text)
    return out
