"""The clairvoyant bound of the semi-active damper (:mod:`agents.evaluation.semi_active_bound`):
its open loop is the env's step, its gradient the simulation's, its search never worse than
its start."""

from __future__ import annotations

import numpy as np
import pytest

from agents.evaluation.runs import run_policy
from agents.evaluation.semi_active_bound import (
    ENV_KWARGS,
    CommandProblem,
    closed_loop,
    format_results,
    optimise_track,
)
from agents.policies.loading import load_policy

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


def test_the_open_loop_replays_clipped_lqg_exactly_as_railgym_evaluate_rates_it():
    """``clipped-lqg``'s commands replayed open loop give the a_w of its closed loop, which is
    ``run_policy``'s (what ``railgym evaluate`` and the benchmark report), to the last bit."""
    factory, needs, _ = load_policy("clipped-lqg")
    kwargs = {**ENV_KWARGS, **needs, "track_class": 5, "duration": 2.5}
    expected = run_policy(factory, kwargs, 1, 1000)["a_w"]
    run = closed_loop("clipped-lqg", 5, 1000, 2.5)
    assert run["u"].max() > 0.0  # it commands the damper
    assert run["a_w"] == expected
    assert CommandProblem(5, 1000, 2.5).a_w(run["u"]) == expected


def test_the_gradient_is_the_simulations_derivative():
    """The lane Jacobian times a direction is the change of the simulated acceleration along
    it, and the gradient of a_w its directional derivative (central difference)."""
    prob = CommandProblem(4, 1001, 1.0, discard=0.5)
    rng = np.random.default_rng(0)
    u = rng.uniform(0.1, 0.9, prob.n)
    d = rng.standard_normal(prob.n)
    eps = 1e-5
    change = prob.simulate(u + eps * d)["acc"] - prob.simulate(u)["acc"]
    linear = prob.acc_jacobian(u) @ (eps * d)
    assert np.linalg.norm(change - linear) < 1e-3 * np.linalg.norm(change)
    central = (prob.a_w(u + eps * d) - prob.a_w(u - eps * d)) / (2 * eps)
    assert prob.gradient(u) @ d == pytest.approx(central, rel=1e-3)


def test_the_best_found_is_below_every_start_and_the_baselines():
    """On a short track the best commands are admissible, below every start's a_w (the
    closed-loop records and the constants) and so below passive, skyhook and clipped-lqg."""
    r = optimise_track(5, 1000, 2.5, screen_eval=3, max_eval=6)
    assert set(r.starts) == {"clipped-lqg", "skyhook", "0.0", "0.5", "1.0"}
    assert r.a_w["best"] == min(r.starts.values())
    for name in ("passive", "clipped-lqg", "skyhook"):
        assert r.a_w["best"] < r.a_w[name]
    assert r.margin < 0.0
    assert "| 5 | 1000 |" in format_results([r])


def test_a_search_stays_in_the_box_and_lowers_a_w():
    prob = CommandProblem(6, 1000, 1.0, discard=0.5)
    u0 = np.full(prob.n, 0.5)
    u = prob.optimise(u0, 5)
    assert u.shape == u0.shape
    assert np.all((u >= 0.0) & (u <= 1.0))
    assert prob.a_w(u) < prob.a_w(u0)
