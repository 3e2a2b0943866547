"""The bounds of the tasks: the crash search against a brute-force search, replays equal to
the closed loop, the semi-active search on the task's own tracks, and the stored bound at
least as good as every stored entry on every case."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from agents.evaluation.semi_active_bound import CommandProblem, closed_loop
from agents.leaderboard.bounds import replay, search_commands
from agents.leaderboard.cases import policy_factory, run_case, run_task
from agents.leaderboard.results import load_entries
from railgym.tasks import TASKS, references

CRASH = TASKS["crash-adaptive"]


def test_crash_search_finds_the_brute_force_optimum_of_a_small_case():
    """Two pieces of 20 steps, two zones, levels −1, 0, 1: 81 sequences."""
    label, levels = "35kmh-loaded", (-1.0, 0.0, 1.0)
    found = search_commands(CRASH, label, levels=levels, segment=20, segments=2, sweeps=2)
    seqs = []
    for a, b, c, d in itertools.product(levels, repeat=4):
        u = np.zeros((40, 2))
        u[:20], u[20:] = (a, b), (c, d)
        seqs.append(u)
    brute = replay(CRASH, label, np.array(seqs))
    assert found.cost == pytest.approx(float(brute.min()), rel=1e-12)
    assert found.cost <= found.start_cost


def test_replayed_baseline_commands_reproduce_the_closed_loop():
    label = "45kmh-empty"
    found = search_commands(
        CRASH, label, levels=(0.0,), segment=10, segments=1, sweeps=0, baselines=CRASH.baselines
    )
    closed = {b: run_task(CRASH.name, b, cases=(label,))[label] for b in CRASH.baselines}
    assert found.baselines == pytest.approx(closed, rel=1e-12)


def test_semi_active_search_runs_on_the_tasks_tracks():
    """The search's closed loop and open-loop replay run the task's env version (-v3: the
    streamed track generated whole for the search), to the last bit."""
    task = TASKS["bogie-semi-active"]
    factory, needs = policy_factory(task, "passive")
    mine = run_case(task, "class5", factory, needs)
    duration = task.env_kwargs["duration"]
    runs = [
        closed_loop("clipped-lqg", 5, task.seed + i, duration, env_id=task.env_id) for i in range(2)
    ]
    theirs = [
        closed_loop("passive", 5, task.seed + i, duration, env_id=task.env_id)["a_w"]
        for i in range(2)
    ]
    assert mine == pytest.approx(theirs, rel=1e-12)
    for i, run in enumerate(runs):
        prob = CommandProblem(5, task.seed + i, duration, env_id=task.env_id)
        assert prob.simulate(run["u"])["a_w"] == run["a_w"]
    other = CommandProblem(5, task.seed, duration, env_id="railgym/VerticalSuspension-v2")
    assert other.simulate(runs[0]["u"])["a_w"] != runs[0]["a_w"]  # another track


@pytest.mark.parametrize("entry", load_entries(), ids=lambda e: f"{e['task']}-{e['name']}")
def test_bound_is_at_least_as_good_as_every_stored_entry(entry):
    refs = references()[entry["task"]]
    for case, values in entry["metric"].items():
        assert np.all(np.asarray(values) >= refs[case]["bound"] - 1e-12), case


def test_linear_clairvoyant_bound_against_brute_force():
    """Six control steps (0.06 s) of the linear model: the convex optimum is below every
    sequence of a grid of the box, and a local search from the grid's best finds no lower."""
    import gymnasium as gym
    from scipy import optimize

    from agents.leaderboard.linear_bound import clairvoyant, weighted_response

    env_id = TASKS["bogie-payload"].env_id
    env = gym.make(env_id, backend="linear", duration=0.06, f_max=4000.0)
    best, u = clairvoyant(env, seed=7, discard=0.0)

    def a_w(v):
        return float(np.sqrt(np.mean(weighted_response(env, 7, v) ** 2)))

    assert best == pytest.approx(a_w(u), rel=1e-9)  # the optimum replayed on the env
    grid = [np.array(g) for g in itertools.product((-1.0, 0.0, 1.0), repeat=6)]
    values = [a_w(g) for g in grid]
    assert best <= min(values) + 1e-12
    start = grid[int(np.argmin(values))]
    local = optimize.minimize(a_w, start, bounds=[(-1.0, 1.0)] * 6, method="L-BFGS-B")
    assert best <= local.fun + 1e-9
    assert best == pytest.approx(local.fun, rel=1e-3)
