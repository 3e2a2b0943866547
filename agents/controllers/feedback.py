"""Plumbing shared by the observation-feedback baselines of every env (:mod:`agents.controllers`,
:mod:`agents.controllers.crash_baselines`): the env check, the physical observation (obs ×
``obs_scale``, SI) and stable-baselines3's ``predict`` shape rules."""

from __future__ import annotations

from typing import Any

import numpy as np

from agents._predict import SB3Predict

__all__ = ["ObservationController"]


class ObservationController(SB3Predict):
    """Plumbing of every observation-feedback baseline (vertical and crash): the env check, the
    physical observation and stable-baselines3's ``predict`` shape rules.

    A subclass sets ``env_name`` (the env named in the error) and defines :meth:`action`.
    """

    #: the env named in the error, e.g. ``"VerticalSuspension"``
    env_name: str

    def __init__(self, env: Any) -> None:
        base = getattr(env, "unwrapped", env)
        for attr in ("obs_names", "obs_scale", "cfg"):
            if not hasattr(base, attr):
                raise ValueError(
                    f"env must be a railgym {self.env_name} env (no attribute {attr!r}), "
                    f"got {type(base).__name__}"
                )
        self.obs_names: tuple[str, ...] = tuple(base.obs_names)
        self.obs_scale = np.asarray(base.obs_scale, dtype=np.float64)
        self._base = base

    def action(self, x: np.ndarray) -> np.ndarray:
        """Normalised action (n, n_act), before clipping, from the physical observation
        (n, n_obs)."""
        raise NotImplementedError

    def predict_action(
        self, observation: Any, episode_start: Any, deterministic: bool
    ) -> np.ndarray:
        """Action clipped to [−1, 1], float32: (n_act,) for one obs, (n, n_act) for a batch.

        ``episode_start`` and ``deterministic`` exist for SB3 compatibility; the controllers
        are memoryless and deterministic.
        """
        obs = np.asarray(observation, dtype=np.float64)
        n_obs = len(self.obs_names)
        if obs.ndim not in (1, 2) or obs.shape[-1] != n_obs:
            raise ValueError(
                f"observation must have shape ({n_obs},) or (n, {n_obs}), got {obs.shape}"
            )
        if not np.all(np.isfinite(obs)):
            raise ValueError("observation has non-finite values (NaN or inf)")
        u = np.clip(self.action(np.atleast_2d(obs) * self.obs_scale), -1.0, 1.0)
        u = u.astype(np.float32)
        return u[0] if obs.ndim == 1 else u
