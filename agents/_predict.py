"""stable-baselines3's ``predict`` signature, written once for every policy of :mod:`agents`
(the controllers, the wrappers of a trained policy, the RLlib policy)."""

from __future__ import annotations

from typing import Any

__all__ = ["SB3Predict"]


class SB3Predict:
    """Base of a feed-forward policy with stable-baselines3's ``predict``.

    A subclass defines :meth:`predict_action`; :meth:`predict` returns its action and no
    recurrent state.
    """

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[Any, None]:
        """``(action, None)`` for ``observation`` (:meth:`predict_action`).

        ``state`` exists for SB3 compatibility: the policies here keep no recurrent state.
        """
        return self.predict_action(observation, episode_start, deterministic), None

    def predict_action(self, observation: Any, episode_start: Any, deterministic: bool) -> Any:
        """The action for ``observation``; ``episode_start`` (bool per sub-env, or ``None``)
        marks the sub-envs whose episode starts with it."""
        raise NotImplementedError
