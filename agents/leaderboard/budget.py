"""The compute budget of the leaderboard: the wall time stored with its entries, and the
projected time of the full set.

The full set (:func:`planned_entries`) is every task × :data:`~agents.leaderboard.run.ALGOS`,
plain and residual on the task's :data:`~agents.leaderboard.run.RESIDUAL_BASES` controller
(where it has one), each over :func:`seeds_for` seeds. A planned entry's time per seed is
its stored training wall time per seed (for a variant not stored: that of the other variant
of the algorithm on the task, the residual's controller costing little beside the env and
the network) plus the evaluation of one seed (the entry's ``eval_wall_s`` per seed where
recorded, else the mean wall time of the task's baseline entries, each one evaluation of
every case), at the stored run's steps; a planned entry whose algorithm has no stored run on
its task is not projected.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from agents.leaderboard.run import ALGOS, RESIDUAL_BASES, entry_name
from railgym.tasks import TASKS

__all__ = [
    "FEW_SEEDS",
    "MANY_SEEDS",
    "SEED_RULE_S",
    "Planned",
    "Stored",
    "planned_entries",
    "projection",
    "seeds_for",
    "stored_time",
]

#: one seed's training on one core taking at most this (s) gets :data:`MANY_SEEDS` seeds
SEED_RULE_S = 600.0
#: seeds of a learned entry whose seed trains in at most :data:`SEED_RULE_S`, and otherwise
MANY_SEEDS, FEW_SEEDS = 10, 5


def seeds_for(train_s_per_seed: float) -> int:
    """Seeds of a learned entry of the full set: 10 where one seed trains in ≤ 10 min on one
    core, else 5."""
    return MANY_SEEDS if train_s_per_seed <= SEED_RULE_S else FEW_SEEDS


class Stored(NamedTuple):
    """Wall time (s, one core) stored with the entries."""

    training: float  #: the learned entries' training (their provenance ``wall_s``)
    evaluation: float  #: the learned entries' held-out evaluation, where recorded
    evaluated: int  #: learned entries that record their evaluation time
    learned: int  #: learned entries
    others: float  #: the baseline and policy entries (each one evaluation)

    @property
    def provenance(self) -> float:
        """The sum of every entry's provenance wall time."""
        return self.training + self.others

    @property
    def total(self) -> float:
        """All of it."""
        return self.training + self.evaluation + self.others


def stored_time(entries: Sequence[Mapping[str, Any]]) -> Stored:
    """The wall time stored with ``entries``."""
    learned = [e for e in entries if e["kind"] == "learned"]
    timed = [e for e in learned if "eval_wall_s" in e]
    return Stored(
        training=sum(e["provenance"]["wall_s"] for e in learned),
        evaluation=sum(e["eval_wall_s"] for e in timed),
        evaluated=len(timed),
        learned=len(learned),
        others=sum(e["provenance"]["wall_s"] for e in entries if e["kind"] != "learned"),
    )


class Planned(NamedTuple):
    """One learned entry of the full set and its projected time (``None``: not projected)."""

    task: str
    name: str
    algo: str
    residual: str | None
    source: str | None  #: the stored entry its time is taken from
    steps: int | None  #: env steps per seed (of that entry)
    train_s: float | None  #: training per seed, s
    eval_s: float | None  #: evaluation per seed, s

    @property
    def seeds(self) -> int | None:
        """Seeds by :func:`seeds_for`."""
        return None if self.train_s is None else seeds_for(self.train_s)

    @property
    def total_s(self) -> float | None:
        """Projected wall time of all its seeds, s."""
        if self.train_s is None or self.eval_s is None:
            return None
        return seeds_for(self.train_s) * (self.train_s + self.eval_s)


def planned_entries() -> list[tuple[str, str, str | None]]:
    """``(task, algo, residual controller or None)`` of every learned entry of the full set."""
    out: list[tuple[str, str, str | None]] = []
    for task in TASKS:
        variants = (None, RESIDUAL_BASES[task]) if task in RESIDUAL_BASES else (None,)
        out += [(task, algo, residual) for algo in ALGOS for residual in variants]
    return out


def _baseline_eval_s(entries: Sequence[Mapping[str, Any]], task: str) -> float | None:
    """Mean wall time of the task's baseline entries (one evaluation of every case each)."""
    times = [
        e["provenance"]["wall_s"] for e in entries if e["task"] == task and e["kind"] == "baseline"
    ]
    return float(np.mean(times)) if times else None


def projection(entries: Sequence[Mapping[str, Any]]) -> list[Planned]:
    """The full set's learned entries with their projected time from the stored ``entries``
    (module docstring)."""
    stored = {(e["task"], e["name"]): e for e in entries if e["kind"] == "learned"}
    out = []
    for task, algo, residual in planned_entries():
        name = entry_name(algo, residual)
        other = entry_name(algo, RESIDUAL_BASES.get(task) if residual is None else None)
        source = stored.get((task, name)) or stored.get((task, other))
        if source is None:
            out.append(Planned(task, name, algo, residual, None, None, None, None))
            continue
        n = len(source["seeds"])
        recorded = source.get("eval_wall_s")
        eval_s = recorded / n if recorded is not None else _baseline_eval_s(entries, task)
        out.append(
            Planned(
                task,
                name,
                algo,
                residual,
                source["name"],
                source["steps"],
                source["provenance"]["wall_s"] / n,
                eval_s,
            )
        )
    return out
