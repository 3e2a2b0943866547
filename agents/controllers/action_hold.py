"""Decision interval of a trained policy: act every ``hold`` env steps, hold the action between.

The env still steps (and its statistics still sample) at its own ``control_dt``; only the
policy decides less often, so that each decision moves the return by more than the
exploration noise of one short step does (the crash env: 5 ms steps, an absorber whose force
can swing over its range in 30 ms, docs/results.md, *What limits the crash agent*).

* :class:`ActionHold` — the training side: a Gymnasium vector wrapper whose ``step`` repeats
  the action up to ``hold`` env steps and returns the summed reward, the last observation,
  the last ``info`` and the episode ends. A hold stops early at the step where any sub-env's
  episode ends (the others resume with the next decision), and the step after a ``NEXT_STEP``
  episode end (the env's own reset step) is passed through once.
* :class:`HeldPolicy` — the evaluation side: a policy's ``predict`` called once per env step,
  answering with the policy's action every ``hold``-th call and the held action in between.
  Its phase counts from its first call: make one per batch of episodes started together
  (:func:`agents.policies.loading.load_policy`'s factory does, one per call).

``agents.training.train`` configs set it with ``action_hold`` (:mod:`agents.training.train_config`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv, VectorWrapper

from agents._predict import SB3Predict
from railgym import _checks as val

__all__ = ["MAX_HOLD", "ActionHold", "HeldPolicy", "check_hold"]

#: longest hold, env steps
MAX_HOLD = 1000


def check_hold(hold: Any, field: str = "action_hold") -> int:
    """``hold`` as an int in 1 … :data:`MAX_HOLD`; a bad value names ``field``."""
    return val.integer(hold, field, min=1, max=MAX_HOLD)


class ActionHold(VectorWrapper):
    """Repeat each action for up to ``hold`` steps of the wrapped vector env (module docstring).

    Parameters
    ----------
    env : a Gymnasium vector env (``NEXT_STEP`` or ``SAME_STEP`` autoreset).
    hold : env steps per decision (1: every step, the wrapped env unchanged).
    """

    def __init__(self, env: VectorEnv, hold: int) -> None:
        super().__init__(env)
        self.hold = check_hold(hold, "hold")
        mode = env.metadata.get("autoreset_mode", AutoresetMode.NEXT_STEP)
        self._next_step = mode == AutoresetMode.NEXT_STEP
        self._pending = np.zeros(env.num_envs, np.bool_)

    def reset(self, *, seed: Any = None, options: dict[str, Any] | None = None) -> Any:
        """Reset as the wrapped env; a partial reset (``reset_mask``) clears those sub-envs'
        pending autoreset."""
        out = self.env.reset(seed=seed, options=options)
        mask = (options or {}).get("reset_mask")
        if mask is None:
            self._pending[:] = False
        else:
            self._pending &= ~np.asarray(mask, np.bool_)
        return out

    def step(self, actions: Any) -> Any:
        """Up to ``hold`` env steps with ``actions``; rewards summed per sub-env."""
        steps = 1 if self._pending.any() else self.hold
        total = np.zeros(self.num_envs)
        for _ in range(steps):
            obs, reward, terminated, truncated, info = self.env.step(actions)
            total += reward
            ended = np.asarray(terminated | truncated, np.bool_)
            if ended.any():
                break
        self._pending = ended & self._next_step
        return obs, total, terminated, truncated, info


class HeldPolicy(SB3Predict):
    """``policy``'s action every ``hold``-th :meth:`predict` call, the held one in between.

    Parameters
    ----------
    policy : object with stable-baselines3's ``predict(obs, deterministic=True)``.
    hold : env steps per decision.
    """

    def __init__(self, policy: Any, hold: int) -> None:
        self.policy, self.hold = policy, check_hold(hold, "hold")
        self._calls = 0
        self._last: Any = None

    def predict_action(self, observation: Any, episode_start: Any, deterministic: bool) -> Any:
        """The policy's action at calls 0, hold, 2·hold, …, else the held one
        (``episode_start`` is not used: feed-forward policies only)."""
        if self._calls % self.hold == 0:
            self._last, _ = self.policy.predict(observation, deterministic=deterministic)
        self._calls += 1
        return self._last
