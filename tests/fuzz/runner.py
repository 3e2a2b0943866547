"""How one fuzz case is run and judged: a deadline (no hang), the error classes a user may
get, and the check that a refusal names the argument."""

from __future__ import annotations

import os
import signal
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

import numpy as np

from tests.fuzz.values import MUST_REFUSE, Bad

#: seconds one case may take (an env made, reset and stepped; a command parsed and checked)
DEADLINE_S = 30.0
#: the errors ``gym.make``, ``reset`` and the wrappers may raise for a bad argument
CLEAR_ERRORS = (TypeError, ValueError)


class Hang(BaseException):
    """A case ran past its deadline (not an ``Exception``: a command's own ``except
    Exception`` does not turn it into an error line)."""


#: seconds the deadline waits again when it falls inside numba's compiler
COMPILE_GRACE_S = 0.5


def _compiling(frame: FrameType | None) -> bool:
    """Whether ``frame`` or a caller runs numba's compiler: an exception raised there leaves
    its libraries half built for the rest of the process (later calls fail with "no compiled
    object yet"), so the deadline waits for the compilation to end."""
    while frame is not None:
        if f"{os.sep}numba{os.sep}" in frame.f_code.co_filename:
            return True
        frame = frame.f_back
    return False


@contextmanager
def deadline(seconds: float) -> Iterator[None]:
    """Raise :class:`Hang` in the block after ``seconds`` (SIGALRM: the main thread only),
    never inside numba's compiler (it waits for the compilation to end)."""

    def stop(_: int, frame: FrameType | None) -> None:
        if _compiling(frame):
            signal.setitimer(signal.ITIMER_REAL, COMPILE_GRACE_S)
            return
        raise Hang(f"no answer within {seconds:g} s")

    before = signal.signal(signal.SIGALRM, stop)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, before)


def zero_action(space: Any) -> np.ndarray:
    """The action closest to zero inside ``space`` (a Box)."""
    return np.clip(np.zeros(space.shape, space.dtype), space.low, space.high)


def rollout(env: Any, steps: int = 3) -> str | None:
    """Reset ``env`` and take ``steps`` zero actions; what is wrong with the observations
    and rewards (non-finite), or ``None``."""
    obs, _ = env.reset(seed=0)
    for _ in range(steps):
        if not np.all(np.isfinite(obs)):
            return f"non-finite observation {obs}"
        obs, reward, terminated, truncated, _ = env.step(zero_action(env.action_space))
        if not np.isfinite(reward):
            return f"non-finite reward {reward}"
        if terminated or truncated:
            break
    return None if np.all(np.isfinite(obs)) else f"non-finite observation {obs}"


def judge(
    name: str, bad: Bad, run: Callable[[], str | None], accepts: frozenset[str] = frozenset()
) -> str | None:
    """Run one case: ``run`` makes and uses the thing given ``bad`` for the argument
    ``name`` and returns what is wrong with the result. The case's failure in words, or
    ``None`` when it was refused with a clear error naming ``name`` (or the file given) or
    gave a correct result; ``accepts``: the value classes of :data:`MUST_REFUSE` that are
    documented forms of this argument."""
    try:
        with deadline(DEADLINE_S):
            wrong = run()
    except Hang as exc:
        return f"hang: {exc}"
    except CLEAR_ERRORS as exc:
        path = isinstance(bad.value, str) and "/" in bad.value and bad.value in str(exc)
        if name not in str(exc) and not path:
            return f"blames another cause: {type(exc).__name__}: {exc}"
        return None
    except Exception as exc:  # noqa: BLE001  (what the fuzzer looks for)
        return f"deep: {type(exc).__name__}: {exc}"
    if wrong is not None:
        return wrong
    if bad.kind in MUST_REFUSE - accepts:
        return "accepted silently"
    return None
