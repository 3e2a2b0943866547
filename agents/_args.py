"""argparse value types of the commands: a bad value is a one-line error naming the flag."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import Any

from railgym import _checks as val
from railgym.envs.vertical import LIMITS

__all__ = [
    "add_parallel_arguments",
    "bounded_int",
    "bounded_real",
    "check_parallel",
    "check_speed_kmh",
    "duration_s",
    "speed_kmh",
]

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


def bounded_real(what: str, unit: str, top: float) -> Callable[[str], float]:
    """A real number ``0 < x <= top`` in ``unit`` (``what``: its name in the message)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be a {what} in {unit}, got {text!r}") from None
        if not (math.isfinite(value) and 0 < value <= top):
            raise argparse.ArgumentTypeError(
                f"must be a {what} in {unit} with 0 < x <= {top:g}, got {text} {unit}"
            )
        return value

    return parse


#: ``--speed``: km/h, ``0 < v <= MAX_SPEED_KMH``
speed_kmh = bounded_real("speed", "km/h", MAX_SPEED_KMH)
#: ``--duration``: s, ``0 < t <= LIMITS["duration"]`` (the envs' limit)
duration_s = bounded_real("duration", "s", LIMITS["duration"])


def check_speed_kmh(value: Any, field: str) -> float:
    """:func:`speed_kmh` for a number given to a function: an error naming ``field``."""
    number = val.real(value, field)
    try:
        return speed_kmh(repr(number))
    except argparse.ArgumentTypeError as err:
        raise val.FieldError(field, str(err)) from None


def add_parallel_arguments(
    parser: argparse.ArgumentParser, scope: str, what: str, result: str
) -> None:
    """``--workers N`` and ``--address ADDR`` (:func:`railgym.parallel.run_tasks`): ``scope``
    prefixes both helps, ``what`` runs on them, ``result`` does not depend on N."""
    parser.add_argument(
        "--workers",
        type=bounded_int(1, 1024),
        default=1,
        help=f"{scope}run {what} on N processes (or a local Ray instance with the ray extra); "
        f"{result} not depend on N",
    )
    parser.add_argument(
        "--address",
        help=f"{scope}join the Ray cluster at HOST:PORT (or 'auto'; needs the ray extra)",
    )


def check_parallel(args: argparse.Namespace) -> None:
    """Refuse ``--workers``/``--address`` that the task runner cannot serve (e.g. an address
    without Ray) before any work, naming the flag."""
    from railgym.parallel import choose_backend

    if args.address is not None and not args.address.strip():
        raise ValueError("--address: empty; give HOST:PORT or 'auto', or leave it out")
    try:
        choose_backend(args.workers, args.address)
    except ValueError as err:
        raise ValueError(f"{'--address' if args.address else '--workers'}: {err}") from None
