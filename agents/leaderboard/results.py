"""The stored entries of the leaderboard and its table.

An entry is one JSON file ``<results>/<task>/<name>.json``: the task, the entry's name and
kind (``baseline``, ``learned``, ``policy``), the metric of every seed on every evaluation
case (``metric``: case → one value per seed), the seeds, the training steps and wall time, and
its provenance (railgym version, git commit, hash of the configuration, machine). The table
scores each entry per task by :func:`railgym.tasks.normalise` against the passive and bound
values of :func:`railgym.tasks.references`: interquartile mean over seeds × cases with its 95 %
stratified bootstrap interval (strata: the cases), and over the tasks (strata: the tasks) for
the entries every shown task has.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import platform
import subprocess
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents.leaderboard.stats import Interval, iqm_interval
from railgym import _checks as val
from railgym.tasks import TASKS, normalise, references

__all__ = [
    "FORMATS",
    "RESULTS_DIR",
    "config_hash",
    "format_table",
    "load_entries",
    "provenance",
    "scores",
    "table_rows",
    "write_entry",
]

#: the shipped entries (``docs/leaderboard.md`` is generated from them)
RESULTS_DIR = Path(__file__).resolve().parent / "results"
#: output formats of the table
FORMATS = ("md", "csv", "json")
ROOT = Path(__file__).resolve().parents[2]


def config_hash(config: Mapping[str, Any]) -> str:
    """First 16 hex digits of the SHA-256 of ``config`` as canonical JSON."""
    text = json.dumps(config, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _commit() -> str:
    """The git commit of the source tree (``+dirty`` with uncommitted changes), or
    ``unknown`` outside a git checkout."""
    try:
        head = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True
        )
        dirty = subprocess.run(
            ["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
        )
    except OSError:
        return "unknown"
    if head.returncode:
        return "unknown"
    return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")


def provenance(config: Mapping[str, Any], wall_s: float) -> dict[str, Any]:
    """railgym version, git commit, configuration hash, wall time (s) and machine."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        release = version("railgym")
    except PackageNotFoundError:
        release = "unknown"
    return {
        "railgym": release,
        "commit": _commit(),
        "config_hash": config_hash(config),
        "config": dict(config),
        "wall_s": round(float(wall_s), 1),
        "machine": f"{platform.machine()} {platform.processor() or ''} "
        f"{os.cpu_count()} cpus, {platform.system()} {platform.release()}, "
        f"python {platform.python_version()}".replace("  ", " "),
    }


def write_entry(entry: Mapping[str, Any], results: Path = RESULTS_DIR) -> Path:
    """Write ``entry`` to ``results/<task>/<name>.json`` (replacing an older one)."""
    path = Path(results) / entry["task"] / f"{entry['name']}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(entry, indent=1, sort_keys=True) + "\n")
    return path


def load_entries(results: Path = RESULTS_DIR, tasks: Sequence[str] | None = None) -> list[dict]:
    """The entries stored under ``results`` (of ``tasks``, default all), by task then name."""
    results = Path(results)
    if not results.is_dir():
        raise val.FieldError("results", f"no results folder {results}")
    out = []
    for name in tasks or TASKS:
        for path in sorted((results / name).glob("*.json")):
            try:
                entry = json.loads(path.read_text())
            except json.JSONDecodeError as err:
                raise val.FieldError("results", f"{path}: not JSON ({err})") from None
            if entry.get("task") != name or set(entry.get("metric", {})) != set(
                TASKS[name].case_labels
            ):
                raise val.FieldError("results", f"{path}: not an entry of every case of {name}")
            out.append(entry)
    return out


def scores(entry: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """Normalised score of each seed per case of ``entry`` (0 passive, 1 the bound)."""
    refs = references()[entry["task"]]
    return {
        case: normalise(values, refs[case]["passive"], refs[case]["bound"])
        for case, values in entry["metric"].items()
    }


def _row(entry: Mapping[str, Any]) -> dict[str, Any]:
    s = scores(entry)
    ci: Interval = iqm_interval(list(s.values()))
    metric = np.concatenate([np.atleast_1d(v) for v in entry["metric"].values()])
    return {
        "task": entry["task"],
        "entry": entry["name"],
        "kind": entry["kind"],
        "seeds": len(entry["seeds"]),
        "steps": entry.get("steps"),
        "wall_s": entry["provenance"]["wall_s"],
        "metric_mean": float(np.mean(metric)),
        "iqm": ci.iqm,
        "ci_low": ci.low,
        "ci_high": ci.high,
    }


def table_rows(entries: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One row per entry (task, IQM score and CI, mean metric, seeds, steps, wall time), the
    rows of a task by IQM, best first; then one ``task="all"`` row per entry name that every
    task of ``entries`` has (IQM over tasks × cases × seeds, strata: the tasks)."""
    rows = [_row(e) for e in entries]
    rows.sort(key=lambda r: (list(TASKS).index(r["task"]), -r["iqm"]))
    tasks = list(dict.fromkeys(e["task"] for e in entries))
    names = [n for n in dict.fromkeys(e["name"] for e in entries)]
    for name in names:
        mine = [e for e in entries if e["name"] == name]
        if len(tasks) < 2 or {e["task"] for e in mine} != set(tasks):
            continue
        strata = [np.concatenate([np.ravel(v) for v in scores(e).values()]) for e in mine]
        ci = iqm_interval(strata)
        rows.append(
            {
                "task": "all",
                "entry": name,
                "kind": mine[0]["kind"],
                "seeds": min(len(e["seeds"]) for e in mine),
                "steps": None,
                "wall_s": sum(e["provenance"]["wall_s"] for e in mine),
                "metric_mean": float("nan"),
                "iqm": ci.iqm,
                "ci_low": ci.low,
                "ci_high": ci.high,
            }
        )
    return rows


def format_table(rows: Sequence[Mapping[str, Any]], fmt: str = "md") -> str:
    """``rows`` of :func:`table_rows` as a markdown table, CSV or JSON."""
    if fmt == "json":
        return json.dumps(list(rows), indent=1)
    keys = ("task", "entry", "kind", "iqm", "ci_low", "ci_high", "metric_mean", "seeds")
    keys += ("steps", "wall_s")
    if fmt == "csv":
        buf = io.StringIO()
        writer = csv.DictWriter(buf, keys, extrasaction="ignore", lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        return buf.getvalue()
    if fmt != "md":
        raise val.FieldError("format", f"must be one of {FORMATS}, got {fmt!r}")
    lines = [
        "| task | entry | kind | score IQM | 95 % CI | mean metric | seeds | steps | wall s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        unit = TASKS[r["task"]].unit if r["task"] in TASKS else ""
        metric = "" if np.isnan(r["metric_mean"]) else f"{r['metric_mean']:.4g} {unit}"
        steps = "" if r["steps"] is None else f"{r['steps']:,}"
        lines.append(
            f"| {r['task']} | {r['entry']} | {r['kind']} | {r['iqm']:.3f} | "
            f"[{r['ci_low']:.3f}, {r['ci_high']:.3f}] | {metric} | {r['seeds']} | {steps} | "
            f"{r['wall_s']:.0f} |"
        )
    return "\n".join(lines)
