"""The generated leaderboard page: each learned entry's hyperparameters and budget (residual
entries with their controller), the stored wall time and the projected time of the full set
(:mod:`agents.leaderboard.budget`), on synthetic entries with known sums and on the shipped
ones through ``railgym leaderboard docs -o``."""

from __future__ import annotations

import re

import pytest

from agents.commands.cli import main
from agents.leaderboard.budget import (
    planned_entries,
    projection,
    seeds_for,
    stored_time,
)
from agents.leaderboard.docs import budget_section, learned_section
from agents.leaderboard.results import load_entries, write_entry
from agents.leaderboard.run import ALGOS, RESIDUAL_BASES, training_config
from railgym.tasks import TASKS


def _learned(task: str, algo: str, seeds: int, wall: float, residual: str | None = None):
    t = TASKS[task]
    name = algo if residual is None else f"{algo}-residual-{residual}"
    return {
        "task": task,
        "name": name,
        "kind": "learned",
        "seeds": list(range(seeds)),
        "steps": 1000,
        "metric": {label: [0.3] * seeds for label in t.case_labels},
        "curves": {},
        "provenance": {"config": training_config(t, algo, 1000, 0, residual), "wall_s": wall},
    }


def _baseline(task: str, name: str, wall: float):
    t = TASKS[task]
    return {
        "task": task,
        "name": name,
        "kind": "baseline",
        "seeds": [0],
        "steps": None,
        "metric": {label: [0.3] for label in t.case_labels},
        "curves": {},
        "provenance": {"config": {"policy": name}, "wall_s": wall},
    }


def test_seed_rule_is_ten_up_to_ten_minutes_per_seed():
    assert (seeds_for(1.0), seeds_for(600.0), seeds_for(600.5), seeds_for(5e4)) == (10, 10, 5, 5)


def test_full_set_is_every_task_algorithm_plain_and_residual():
    plan = planned_entries()
    assert len(plan) == len(set(plan)) == len(ALGOS) * (len(TASKS) + len(RESIDUAL_BASES))
    assert ("crash-adaptive", "sac", None) in plan and ("bogie-active", "td3", "lqg") in plan
    assert not any(task == "crash-adaptive" and res for task, _, res in plan)


def test_projection_and_stored_time_of_known_entries():
    ppo = {**_learned("bogie-active", "ppo", 3, 300.0), "eval_wall_s": 30.0}  # 100 + 10 s
    sac = _learned("bogie-active", "sac", 5, 3500.0, "lqg")  # 700 s a seed: 5 seeds
    base = [_baseline("bogie-active", "lqg", 8.0), _baseline("bogie-active", "passive", 4.0)]
    entries = [ppo, sac, *base]
    rows = {(p.task, p.name): p for p in projection(entries)}
    for name in ("ppo", "ppo-residual-lqg"):  # the plain run stands for the residual too
        p = rows["bogie-active", name]
        assert (p.source, p.seeds, p.train_s, p.eval_s) == ("ppo", 10, 100.0, 10.0)
        assert p.total_s == pytest.approx(1100.0)
    for name in ("sac", "sac-residual-lqg"):  # no evaluation time: the baselines' mean, 6 s
        p = rows["bogie-active", name]
        assert (p.source, p.seeds, p.eval_s) == ("sac-residual-lqg", 5, 6.0)
        assert p.total_s == pytest.approx(5 * 706.0)
    assert rows["bogie-active", "td3"].total_s is None
    assert rows["vehicle-active", "ppo"].total_s is None
    stored = stored_time(entries)
    assert (stored.training, stored.evaluation, stored.others) == (3800.0, 30.0, 12.0)
    assert (stored.evaluated, stored.learned, stored.total) == (1, 2, 3842.0)
    text = "\n".join(budget_section(entries))
    assert "Stored: 3,842 s (1.07 h) on one core" in text
    total = 2 * 1100.0 + 2 * 5 * 706.0 + 12.0
    assert f"projected {total:,.0f} s ({total / 3600:.2f} h) on one core" in text
    assert "Not projected (29 of 33" in text and "bogie-active td3-residual-lqg" in text


def test_learned_section_states_residual_controller_hyperparameters_and_budget():
    entry = {**_learned("bogie-payload", "sac", 2, 100.0, "lqg"), "eval_wall_s": 40.0}
    plain = _learned("bogie-payload", "td3", 2, 80.0)
    text = "\n".join(learned_section([entry, plain, _baseline("bogie-payload", "lqg", 9.0)]))
    rows = [line for line in text.splitlines() if line.startswith("| bogie-payload")]
    assert len(rows) == 2
    cells = [c.strip() for c in rows[0].strip("|").split("|")]
    assert cells[:4] == ["bogie-payload", "sac-residual-lqg", "sac", "lqg"]
    assert cells[4:8] == ["2", "1,000", "100", "40"]  # seeds, steps, training s, evaluation s
    assert cells[8] == (
        "batch_size 256, buffer_size 200000, gamma 0.98, learning_rate 0.0003, "
        "learning_starts 2000, n_envs 4, net_arch [64, 64]"
    )
    assert [c.strip() for c in rows[1].strip("|").split("|")][3] == "—"
    assert "10 where one seed trains in ≤ 10 min on one core, else 5" in text


def test_docs_of_the_shipped_entries_state_their_total(tmp_path, capsys):
    """``railgym leaderboard docs -o`` writes the pages of the shipped entries; the stored
    total is the sum of their wall times, and a residual entry added to them (in place of a
    shipped one of its name) is listed."""
    added = _learned("bogie-active", "ppo", 1, 50.0, "lqg")
    kept = [e for e in load_entries() if (e["task"], e["name"]) != (added["task"], added["name"])]
    results = tmp_path / "results"
    for e in [*kept, added]:
        write_entry(e, results)
    out = tmp_path / "docs"
    assert main(["leaderboard", "docs", "--results", str(results), "-o", str(out)]) == 0
    page = (out / "leaderboard.md").read_text()
    total = sum(e["provenance"]["wall_s"] + e.get("eval_wall_s", 0.0) for e in kept) + 50.0
    stored = re.search(r"Stored: ([\d,]+) s", page)
    assert stored and int(stored[1].replace(",", "")) == round(total)
    assert "| bogie-active | ppo-residual-lqg | ppo | lqg | 1 | 1,000 | 50 |" in page
    assert (out / "tasks.md").is_file()
