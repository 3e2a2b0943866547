"""Training over an operating envelope: a track class and a running speed drawn for every
episode of every sub-env, so that an agent learns the cases it is judged on.

In an :mod:`agents.training.train` config the envelope is a block beside ``env_kwargs``::

    envelope:
      track_class: [4, 5, 6]     # FRA classes, one drawn uniformly per episode
      speed_kmh: [100.0, 180.0]  # km/h, drawn uniformly per episode; absent: the class's
                                 # maximum passenger speed

It applies to ``railgym/VerticalSuspension-v1`` and ``railgym/VerticalVehicle-v1`` (their
native vector envs), through the reset options ``track_class`` and ``speed`` of one sub-env at
a time (gymnasium's partial reset, ``reset_mask``). ``railgym/TrainCrash-v1`` has its envelope
in the crash scenario itself (``scenario: envelope``: speed and payloads drawn at each reset).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv, VectorWrapper

from agents.commands.flags import MAX_SPEED_KMH
from railgym import _checks as val

__all__ = ["ENVELOPE_ENVS", "Envelope", "EnvelopeVectorEnv", "check_envelope"]

#: envs (every registered version) whose reset options take ``track_class`` and ``speed``
ENVELOPE_ENVS = ("railgym/VerticalSuspension", "railgym/VerticalVehicle")
#: key of the envelope's generator stream beside the training seed
_STREAM = 0xE17E


class Envelope(NamedTuple):
    """Track classes (drawn uniformly) and a speed range in km/h (``None``: each class's
    maximum passenger speed)."""

    track_class: tuple[int, ...]
    speed_kmh: tuple[float, float] | None

    def draw(self, rng: np.random.Generator) -> dict[str, Any]:
        """Reset options of one episode: ``track_class`` and ``speed`` (m/s, or ``None``)."""
        tc = int(self.track_class[int(rng.integers(len(self.track_class)))])
        if self.speed_kmh is None:
            return {"track_class": tc, "speed": None}
        lo, hi = self.speed_kmh
        return {"track_class": tc, "speed": float(rng.uniform(lo, hi)) / 3.6}

    def to_dict(self) -> dict[str, Any]:
        """The config-file form."""
        out: dict[str, Any] = {"track_class": list(self.track_class)}
        if self.speed_kmh is not None:
            out["speed_kmh"] = list(self.speed_kmh)
        return out


def check_envelope(value: Any, field: str = "envelope") -> Envelope:
    """An envelope block checked; errors name ``envelope.track_class`` or
    ``envelope.speed_kmh``."""
    f = val.Fields(value, field)
    raw = f.get("track_class")
    classes = tuple(
        val.integer(c, f"{field}.track_class", min=1, max=6)
        for c in val.sequence([raw] if isinstance(raw, int) else raw, f"{field}.track_class")
    )
    if not classes:
        raise val.FieldError(f"{field}.track_class", "must list at least one FRA class (1..6)")
    speed = f.get("speed_kmh", None)
    if speed is not None:
        lo, hi = (
            val.in_range(v, f"{field}.speed_kmh", 0.0, MAX_SPEED_KMH)
            for v in val.sequence(speed, f"{field}.speed_kmh", 2)
        )
        if not 0 < lo <= hi:
            raise val.FieldError(
                f"{field}.speed_kmh", f"must be [min, max] km/h with 0 < min <= max, got {speed!r}"
            )
        speed = (lo, hi)
    f.done()
    return Envelope(classes, speed)


class EnvelopeVectorEnv(VectorWrapper):
    """A native (``NEXT_STEP``) railgym vector env whose sub-envs start every episode on a
    drawn track class and speed (:meth:`Envelope.draw`).

    A finished sub-env is reset in the same step with its own draw (partial reset), so the
    wrapper is a ``SAME_STEP`` vector env: ``info["final_obs"]`` and ``info["final_info"]``
    hold the end of the old episode. The draws come from a generator seeded by
    :meth:`reset`'s ``seed`` (its own stream), so seeded runs repeat.
    """

    def __init__(self, env: VectorEnv, envelope: Envelope, seed: int | None = None) -> None:
        super().__init__(env)
        mode = env.metadata.get("autoreset_mode", AutoresetMode.NEXT_STEP)
        if mode != AutoresetMode.NEXT_STEP:
            raise ValueError(f"the envelope needs a native NEXT_STEP vector env, got {mode}")
        self.envelope = envelope
        self.metadata = {**env.metadata, "autoreset_mode": AutoresetMode.SAME_STEP}
        self._rng = np.random.default_rng(None if seed is None else [seed, _STREAM])

    def _reset_one(self, i: int) -> np.ndarray:
        mask = np.zeros(self.num_envs, np.bool_)
        mask[i] = True
        obs, _ = self.env.reset(options={"reset_mask": mask, **self.envelope.draw(self._rng)})
        return obs[i]

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every sub-env (``seed``: as the wrapped env), then draw each one's case."""
        if seed is not None:
            first = seed if isinstance(seed, int | np.integer) else seed[0]
            self._rng = np.random.default_rng([int(first), _STREAM])
        # the held case of the previous draws is replaced below: no warning for it
        obs, info = self.env.reset(seed=seed, options=options or {"hold": True})
        obs = np.array(obs)
        for i in range(self.num_envs):
            obs[i] = self._reset_one(i)
        return obs, info

    def step(self, actions: Any) -> tuple[np.ndarray, Any, Any, Any, dict[str, Any]]:
        """Step; sub-envs that finished start their next episode at once."""
        obs, reward, terminated, truncated, infos = self.env.step(actions)
        done = np.asarray(terminated | truncated)
        if done.any():
            final = np.array(obs)
            obs = np.array(obs)
            infos = {
                **infos,
                "final_obs": final,
                "_final_obs": done,
                "final_info": infos,
                "_final_info": done,
            }
            for i in np.flatnonzero(done):
                obs[i] = self._reset_one(i)
        return obs, reward, terminated, truncated, infos
