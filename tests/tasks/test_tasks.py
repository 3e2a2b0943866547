"""railgym.tasks: every task on the newest version of its env, the normalised score (0 at
passive, 1 at the bound by construction) and the task's fixed arguments."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import railgym  # noqa: F401  (registers the envs)
from railgym import _checks as val
from railgym.registration import env_family
from railgym.tasks import TASKS, case_kwargs, make, normalise, references, score
from railgym.vehicles.vertical.params import load_vehicle


def _newest(env_id: str) -> str:
    family = env_family(env_id)
    versions = [int(k.rsplit("-v", 1)[1]) for k in gym.registry if env_family(k) == family]
    return f"{family}-v{max(versions)}"


@pytest.mark.parametrize("name", list(TASKS))
def test_task_runs_the_newest_version(name):
    env_id = TASKS[name].env_id
    assert env_id == _newest(env_id)


def test_the_required_tasks_exist():
    assert {
        "bogie-active",
        "bogie-semi-active",
        "vehicle-active",
        "vehicle-preview",
        "crash-adaptive",
        "bogie-payload",
    } <= set(TASKS)


@given(
    passive=st.floats(0.01, 100.0),
    gap=st.floats(0.01, 0.99),
    frac=st.floats(-2.0, 2.0),
)
def test_normalise_is_linear_from_passive_to_bound(passive, gap, frac):
    bound = passive * (1.0 - gap)
    value = passive - frac * (passive - bound)
    assert math.isclose(float(normalise(passive, passive, bound)), 0.0, abs_tol=1e-12)
    assert math.isclose(float(normalise(bound, passive, bound)), 1.0, rel_tol=1e-12)
    assert math.isclose(float(normalise(value, passive, bound)), frac, abs_tol=1e-9)


def test_normalise_refuses_a_bound_not_below_passive():
    with pytest.raises(ValueError, match="bound"):
        normalise(0.5, 0.4, 0.4)


@pytest.mark.parametrize("name", list(references()))
def test_score_is_zero_at_passive_and_one_at_the_bound(name):
    refs = references()[name]
    assert set(refs) == set(TASKS[name].case_labels)
    passive = score(name, {c: r["passive"] for c, r in refs.items()})
    bound = score(name, {c: r["bound"] for c, r in refs.items()})
    assert passive == dict.fromkeys(refs, 0.0)
    assert all(math.isclose(v, 1.0, rel_tol=1e-12) for v in bound.values())
    for c, r in refs.items():  # the bound is at least as good as every baseline
        assert all(r["bound"] <= v for v in r["baselines"].values()), c


def test_score_averages_several_runs_and_names_unknown_cases():
    name, refs = "crash-adaptive", references()["crash-adaptive"]
    case = next(iter(refs))
    p, b = refs[case]["passive"], refs[case]["bound"]
    assert math.isclose(score(name, {case: [p, b]})[case], 0.5)
    with pytest.raises(val.FieldError, match="no case"):
        score(name, {"nowhere": 1.0})
    with pytest.raises(val.FieldError, match="unknown task"):
        score("no-task", {})


def test_make_builds_the_case_and_refuses_a_fixed_argument_given_again():
    env = make("bogie-payload", case="m125-v24")
    base = env.unwrapped
    assert base.cfg.f_max == 4000.0 and base.cfg.speed == 24.0
    assert np.isclose(base.vehicle_params.m2, 1.25 * load_vehicle("manchester").m2)
    env.close()
    with pytest.raises(val.FieldError, match="f_max"):
        make("bogie-payload", f_max=8000.0)


def test_nominal_case_keeps_the_packaged_vehicle():
    assert "vehicle" not in case_kwargs("bogie-payload", "m100-v40")
