"""agents.evaluation.sweeps: controller evaluations as tasks give the numbers of
agents.evaluation.runs.run_policy."""

import functools

import pytest

from agents.controllers.classical import Skyhook
from agents.evaluation.runs import run_policy
from agents.evaluation.sweeps import controller_sweep, evaluate_sweep
from agents.policies.loading import load_policy


def test_evaluate_sweep_on_two_workers_equals_one_and_run_policy():
    kwargs = {"track_classes": (4, 6), "episodes": 2, "seed": 7}
    rows = evaluate_sweep(["passive", "skyhook"], **kwargs, workers=2)
    assert rows == evaluate_sweep(["passive", "skyhook"], **kwargs)  # floats compared exactly
    for r in rows:
        factory, env_kwargs, _ = load_policy(r["policy"])
        env_kwargs = {"backend": "reference", "track_class": r["track_class"], **env_kwargs}
        direct = run_policy(factory, env_kwargs, 2, 7)
        assert {k: r[k] for k in direct} == direct
    assert [r["policy"] for r in rows] == ["passive", "skyhook"] * 2
    assert all(r["a_w_reduction_%"] == 0.0 for r in rows if r["policy"] == "passive")


def test_controller_sweep_keeps_case_order():
    factory = functools.partial(Skyhook, mode="semi-active")
    cases = [{"backend": "reference", "track_class": c} for c in (6, 4)]
    rows = controller_sweep(factory, cases, episodes=2, seed=3, workers=2)
    assert rows == [run_policy(factory, kw, 2, 3) for kw in cases]
    # class 4 track is rougher than class 6: more carbody acceleration
    assert rows[1]["rms_acc"] > rows[0]["rms_acc"]


def test_bad_policy_fails_before_any_task():
    with pytest.raises(ValueError, match="policy must be one of"):
        evaluate_sweep(["nonsense"], workers=2)
    with pytest.raises(ValueError, match="episodes"):
        evaluate_sweep(["passive"], episodes=0)
