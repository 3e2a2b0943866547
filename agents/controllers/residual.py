"""Residual policies: a trained policy's action added to a classical controller's.

The agent learns a correction of a baseline that already works (residual policy learning,
Johannink et al. 2019, Silver et al. 2018): the env receives

    a = clip(a_base + scale·clip(a_agent, −1, 1), low, high)

with ``a_base`` the controller's normalised action on the same observation (the controller
sees what the agent sees; an ``lqg`` base keeps its Kalman estimate from step to step) and
``a_agent`` the policy's. Both clips are part of the definition: ``[low, high]`` is the env's
action space per actuator ([−1, 1] for a force, [0, 1] for a semi-active damper's command).
A policy whose output is 0 is the baseline itself.

* :class:`ResidualVectorEnv` — the training side: a Gymnasium vector wrapper whose ``step``
  takes the agent's action, adds the controller's and steps the wrapped env. The controller's
  state (an LQG's estimate) is put back at rest for every sub-env that starts an episode
  (``NEXT_STEP`` and ``SAME_STEP`` autoreset alike).
* :class:`ResidualPolicy` — the evaluation side: ``predict`` of the sum, for the commands that
  run a policy (:func:`agents.policies.loading.load_policy` applies it to a zip whose config has
  ``residual``).

``agents.training.train`` configs set it with ``residual`` (the controller's ``railgym evaluate``
name) and ``residual_scale`` (:mod:`agents.training.train_config`). The controller is designed once,
for the case of the training config's ``env_kwargs`` (an ``lqg``: its track class and speed, and the
reward weights its gain minimises), and keeps
that design in training, in the training's evaluations and wherever the policy is loaded, so
that the policy always corrects the controller it learnt with (the ``lqg`` baseline of
``railgym evaluate`` is designed for each evaluated case instead).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv, VectorWrapper

from agents._predict import SB3Predict
from railgym import _checks as val

__all__ = ["MAX_SCALE", "ResidualPolicy", "ResidualVectorEnv", "check_scale", "residual_action"]

#: largest ``residual_scale``: the correction may span the whole action range twice over
MAX_SCALE = 2.0


def check_scale(scale: Any, field: str = "residual_scale") -> float:
    """``scale`` as a float in (0, :data:`MAX_SCALE`]; a bad value names ``field``."""
    value = val.positive(scale, field)
    if value > MAX_SCALE:
        raise val.FieldError(field, f"must be at most {MAX_SCALE}, got {scale!r}")
    return float(value)


def residual_action(
    base: np.ndarray, agent: Any, scale: float, low: Any = -1.0, high: Any = 1.0
) -> np.ndarray:
    """``clip(base + scale·clip(agent, −1, 1), low, high)`` as float32 (module docstring)."""
    agent = np.clip(np.asarray(agent, np.float64), -1.0, 1.0)
    total = np.asarray(base, np.float64) + scale * agent
    return np.clip(total, low, high).astype(np.float32)


class ResidualVectorEnv(VectorWrapper):
    """Step ``env`` with the agent's action plus ``controller``'s (module docstring).

    Parameters
    ----------
    env : a Gymnasium vector env of a railgym vertical env.
    controller : object with stable-baselines3's ``predict(obs, episode_start=…)`` built on
        ``env`` (e.g. :class:`agents.controllers.lqg.LQG`).
    scale : weight of the agent's action, in (0, :data:`MAX_SCALE`].
    """

    def __init__(self, env: VectorEnv, controller: Any, scale: float = 1.0) -> None:
        super().__init__(env)
        self.controller, self.scale = controller, check_scale(scale, "scale")
        space = env.single_action_space
        self._bounds = (np.asarray(space.low, np.float64), np.asarray(space.high, np.float64))
        mode = env.metadata.get("autoreset_mode", AutoresetMode.NEXT_STEP)
        self._next_step = mode == AutoresetMode.NEXT_STEP
        self._obs: np.ndarray | None = None
        self._start = np.ones(env.num_envs, np.bool_)
        self._ended = np.zeros(env.num_envs, np.bool_)

    def reset(self, *, seed: Any = None, options: dict[str, Any] | None = None) -> Any:
        """Reset as the wrapped env; the reset sub-envs' controller state starts at rest."""
        obs, info = self.env.reset(seed=seed, options=options)
        mask = (options or {}).get("reset_mask")
        reset = np.ones(self.num_envs, np.bool_) if mask is None else np.asarray(mask, np.bool_)
        self._start |= reset
        self._ended &= ~reset
        self._obs = np.array(obs)
        return obs, info

    def step(self, actions: Any) -> Any:
        """One step of every sub-env with the summed action."""
        if self._obs is None:
            raise RuntimeError("call reset before step")
        base, _ = self.controller.predict(self._obs, episode_start=self._start)
        total = residual_action(
            np.reshape(base, np.shape(actions)), actions, self.scale, *self._bounds
        )
        obs, reward, terminated, truncated, info = self.env.step(total)
        ended = np.asarray(terminated | truncated, np.bool_)
        # a new episode's first observation: this step's (SAME_STEP), or the one of the step
        # after the end (NEXT_STEP: that step only resets)
        self._start = self._ended.copy() if self._next_step else ended
        self._ended = ended
        self._obs = np.array(obs)
        return obs, reward, terminated, truncated, info


class ResidualPolicy(SB3Predict):
    """``policy``'s action added to ``controller``'s (module docstring).

    Parameters
    ----------
    policy, controller : objects with stable-baselines3's ``predict(obs, deterministic=True)``;
        the controller gets ``episode_start`` too.
    scale : weight of the policy's action, in (0, :data:`MAX_SCALE`].
    bounds : the env's action bounds ``(low, high)``.
    """

    def __init__(
        self, policy: Any, controller: Any, scale: float = 1.0, bounds: tuple = (-1.0, 1.0)
    ) -> None:
        self.policy, self.controller = policy, controller
        self.scale = check_scale(scale, "scale")
        self.bounds = bounds

    def predict_action(
        self, observation: Any, episode_start: Any, deterministic: bool
    ) -> np.ndarray:
        """The summed action (feed-forward policies only)."""
        base, _ = self.controller.predict(observation, episode_start=episode_start)
        agent, _ = self.policy.predict(observation, deterministic=deterministic)
        base = np.reshape(base, np.shape(agent))
        return residual_action(base, agent, self.scale, *self.bounds)
