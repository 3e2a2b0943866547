"""argparse value types of the commands: a bad value is a one-line error naming the flag."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

__all__ = ["bounded_int", "speed_kmh"]

#: highest speed accepted by ``--speed``, km/h: a sanity bound above twice the FRA class 6
#: limit of 177 km/h
MAX_SPEED_KMH = 400.0


def bounded_int(lo: int, hi: int | None = None) -> Callable[[str], int]:
    """An integer ``lo <= n (<= hi)``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
        if value < lo or (hi is not None and value > hi):
            span = f">= {lo}" if hi is None else f"in {lo}..{hi}"
            raise argparse.ArgumentTypeError(f"must be an integer {span}, got {text}")
        return value

    return parse


def speed_kmh(text: str) -> float:
    """A speed in km/h, ``0 < v <= MAX_SPEED_KMH``."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a speed in km/h, got {text!r}") from None
    if not (math.isfinite(value) and 0 < value <= MAX_SPEED_KMH):
        raise argparse.ArgumentTypeError(
            f"must be a speed in km/h with 0 < v <= {MAX_SPEED_KMH:g}, got {text} km/h"
        )
    return value
