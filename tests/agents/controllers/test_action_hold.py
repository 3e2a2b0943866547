"""Decision interval (agents.controllers.action_hold): the held env sums the steps it holds, the
held policy acts every ``hold`` steps wherever a trained zip is loaded, and configs check the
field."""

from __future__ import annotations

import numpy as np
import pytest

from agents.controllers.action_hold import ActionHold, HeldPolicy
from agents.training.train_config import load_config
from railgym import _checks as val
from railgym.envs.crash.env import TrainCrashVectorEnv

KW = {"scenario": "envelope", "control_dt": 0.005, "backend": "surrogate"}
#: two crashes of different length (25 and 50 km/h), payloads fixed
OPTIONS = {"speed_kmh": None, "payload_t": [1.0, 4.0]}
ACTION = np.array([[-1.0, 0.5], [0.75, -0.25]], np.float32)


def _episodes(env, hold: int | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return, worst-car peak (info, g) and number of ``step`` calls of each sub-env's first
    episode under the constant ``ACTION``; ``hold`` None: no wrapper (calls = env steps)."""
    venv = env if hold is None else ActionHold(env, hold)
    venv.reset(seed=3)
    for i, kmh in enumerate((25.0, 50.0)):
        mask = np.arange(2) == i
        venv.reset(options={**OPTIONS, "speed_kmh": kmh, "reset_mask": mask})
    ret, calls, peak = np.zeros(2), np.zeros(2, int), np.zeros(2)
    done = np.zeros(2, bool)
    while not done.all():
        _, r, term, trunc, info = venv.step(ACTION)
        live = ~done
        ret[live] += r[live]
        calls[live] += 1
        ended = (term | trunc) & live
        peak[ended] = info["peak_decel_g"][ended].max(axis=1)
        done |= ended
    return ret, peak, calls


def test_hold_sums_the_rewards_of_the_env_steps_it_holds():
    """A constant action gives the same crash whatever the decision interval: the held env's
    summed rewards equal the plain env's return, its peak the same, in about 1/hold calls."""
    kwargs = {**KW, "reward_weights": {"decel": 1.0, "intrusion": 1.0, "peak": 20.0}}
    ret1, peak1, steps = _episodes(TrainCrashVectorEnv(num_envs=2, **kwargs), None)
    ret5, peak5, calls = _episodes(TrainCrashVectorEnv(num_envs=2, **kwargs), 5)
    assert steps[0] < steps[1]  # 25 km/h ends first
    np.testing.assert_allclose(ret5, ret1, rtol=1e-9)
    np.testing.assert_allclose(peak5, peak1, rtol=1e-12)
    assert calls[0] == -(-steps[0] // 5)
    # the 50 km/h crash: one hold cut short where the other crash ended, one pass-through
    # reset step of the finished sub-env, then holds of 5 again
    assert -(-steps[1] // 5) <= calls[1] <= -(-steps[1] // 5) + 2


def test_step_after_a_next_step_episode_end_is_passed_through():
    """When every sub-env ends in the same step, the next call is the env's reset step only:
    it returns the first observation of the new crash and no reward."""
    env = TrainCrashVectorEnv(num_envs=2, **KW)
    venv = ActionHold(env, 7)
    first, _ = venv.reset(seed=0, options={"speed_kmh": 30.0, "payload_t": 0.0})
    done = False
    while not done:
        _, _, term, trunc, _ = venv.step(ACTION[[0, 0]])
        assert term[0] == term[1]
        done = bool(term[0] or trunc[0])
    obs, reward, term, trunc, _ = venv.step(ACTION[[0, 0]])
    np.testing.assert_array_equal(obs, first)
    np.testing.assert_array_equal(reward, 0.0)
    obs, reward, _, _, _ = venv.step(ACTION[[0, 0]])  # then holds again
    assert np.all(reward != 0.0) and not np.array_equal(obs, first)


class _Counter:
    """Policy whose action is the number of its calls so far."""

    def __init__(self) -> None:
        self.calls = 0

    def predict(self, obs, deterministic=True):
        self.calls += 1
        return np.full((1, 2), self.calls - 1.0), None


def test_held_policy_asks_the_policy_every_hold_calls():
    inner = _Counter()
    held = HeldPolicy(inner, 4)
    actions = [held.predict(np.zeros((1, 12)))[0][0, 0] for _ in range(10)]
    assert actions == [0, 0, 0, 0, 1, 1, 1, 1, 2, 2]
    assert inner.calls == 3


@pytest.mark.parametrize("bad", [0, -1, 1001, 2.5, "5", True])
def test_config_rejects_a_bad_action_hold(bad):
    block = {"algo": "ppo", "n_timesteps": 64, "action_hold": bad}
    with pytest.raises(val.FieldError, match="action_hold"):
        load_config({"railgym/TrainCrash-v1": block})


def test_trained_zip_is_evaluated_with_its_hold(tmp_path, tiny_ppo_block):
    """A zip trained with ``action_hold: 3`` loads (by path) as a policy that changes its action
    only every third env step, equal to the network's action there; the FMU export refuses it."""
    pytest.importorskip("stable_baselines3")
    from agents.controllers.crash_baselines import rollout
    from agents.controllers.registry import CRASH_ID
    from agents.policies.loading import load_policy
    from agents.policies.policy_fmu import export_policy
    from agents.training.train import train

    block = tiny_ppo_block(
        n_timesteps=64,
        n_steps=32,
        action_hold=3,
        env_kwargs=KW,
        policy_kwargs={"net_arch": [8], "log_std_init": 0.0},
    )
    out = train({CRASH_ID: block}, tmp_path / "held", progress=False)
    factory, kwargs, _ = load_policy(str(out / "model.zip"), CRASH_ID)
    env = TrainCrashVectorEnv(num_envs=1, **{**kwargs, "backend": "reference"})
    ctrl = factory(env)
    assert isinstance(ctrl, HeldPolicy) and ctrl.hold == 3
    seen: list[tuple[np.ndarray, np.ndarray]] = []

    class Spy:
        def predict(self, obs, deterministic=True):
            action, state = ctrl.predict(obs, deterministic=deterministic)
            seen.append((obs.copy(), np.asarray(action).copy()))
            return action, state

    rollout(env, Spy(), options={"speed_kmh": 40.0, "payload_t": 0.0})
    assert len(seen) > 20
    for k, (obs, action) in enumerate(seen):
        start = seen[k - k % 3]
        np.testing.assert_array_equal(action, start[1])
        if k % 3 == 0:
            np.testing.assert_array_equal(action, ctrl.policy.predict(obs, deterministic=True)[0])
    assert len({a.tobytes() for _, a in seen}) > 1  # the network does act
    with pytest.raises(ValueError, match="action_hold is 3"):
        export_policy(out / "model.zip", tmp_path / "held.fmu")
