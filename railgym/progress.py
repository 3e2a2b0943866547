"""Progress bars of the long commands: tqdm on stderr, off when stderr is not a terminal or
inside :func:`quiet` (the commands' ``--quiet``)."""

from __future__ import annotations

import contextvars
import sys
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

from tqdm import tqdm

__all__ = ["bar", "quiet", "stages"]

T = TypeVar("T")
_ENABLED = contextvars.ContextVar("railgym_progress", default=True)


def bar(iterable: Iterable[T] | None = None, *, desc: str, total: int | None = None) -> Any:
    """A tqdm bar on stderr over ``iterable`` (or updated by hand with ``total`` steps);
    disabled when stderr is not a terminal or inside :func:`quiet`."""
    return tqdm(
        iterable,
        desc=desc,
        total=total,
        file=sys.stderr,
        leave=False,
        dynamic_ncols=True,
        disable=None if _ENABLED.get() else True,
    )


def stages() -> Callable[[str, int, int], None]:
    """A :func:`bar` per stage, as the ``progress=callback(stage, i, total)`` of
    :func:`surrogates.build` and the builders of :mod:`railgym.vehicles.collect`."""
    bars: dict[str, Any] = {}

    def update(stage: str, i: int, total: int) -> None:
        if stage not in bars:
            bars[stage] = bar(desc=stage, total=total)
        bars[stage].update(i - bars[stage].n)
        if i >= total:
            bars[stage].close()

    return update


@contextmanager
def quiet(on: bool = True) -> Iterator[None]:
    """No progress bars inside the block when ``on`` (``quiet(False)`` changes nothing)."""
    token = _ENABLED.set(False) if on else None
    try:
        yield
    finally:
        if token is not None:
            _ENABLED.reset(token)
