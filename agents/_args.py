"""argparse value types of the commands (a bad value is a one-line error naming the flag), and
the one-line error of a command that fails (:func:`error_status`)."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from typing import Any

from railgym import _checks as val
from railgym.envs.vertical import LIMITS
from surrogates.checks import bounded_int, seed_number

__all__ = [
    "MAX_EPISODES",
    "VEHICLE_DURATION_S",
    "add_parallel_arguments",
    "bounded_int",
    "bounded_real",
    "check_parallel",
    "check_speed_kmh",
    "duration_s",
    "error_status",
    "episodes",
    "seed_number",
    "speed_kmh",
    "track_class",
    "vehicle_cases",
    "vertical_cases",
]

#: most episodes (sub-envs) of one evaluation case: ``--episodes`` and ``episodes=``
MAX_EPISODES = 1000
#: highest speed accepted by ``--speed``, km/h: a sanity bound above twice the FRA class 6
#: limit of 177 km/h
MAX_SPEED_KMH = 400.0


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
#: ``--track-class``: an FRA track class, 1..6
track_class = bounded_int(1, 6)
#: ``--episodes``: held-out episodes per case, ``1..MAX_EPISODES``
episodes = bounded_int(1, MAX_EPISODES)
#: s, an episode of a whole-vehicle evaluation case when ``--duration`` is not given
VEHICLE_DURATION_S = 20.0


def check_speed_kmh(value: Any, field: str) -> float:
    """:func:`speed_kmh` for a number given to a function: an error naming ``field``."""
    number = val.real(value, field)
    try:
        return speed_kmh(repr(number))
    except argparse.ArgumentTypeError as err:
        raise val.FieldError(field, str(err)) from None


def vertical_cases(args: argparse.Namespace) -> dict[str, Any]:
    """The case keywords of ``evaluate_sweep`` / ``gap_vertical`` from the flags of
    ``railgym evaluate`` (track classes, episodes, seed, trust, workers, address)."""
    return {
        "track_classes": args.track_class,
        "episodes": args.episodes,
        "seed": args.seed,
        "trust": args.trust,
        "workers": args.workers,
        "address": args.address,
    }


def vehicle_cases(args: argparse.Namespace) -> dict[str, Any]:
    """:func:`vertical_cases` and the speeds and duration of ``railgym evaluate --env
    vehicle``: the case keywords of ``evaluate_vehicle`` / ``gap_vehicle``."""
    duration = VEHICLE_DURATION_S if args.duration is None else args.duration
    return {**vertical_cases(args), "speeds_kmh": args.speed or [None], "duration": duration}


def error_status(prog: str, err: Exception, debug: bool = False) -> int:
    """Exit status of the command ``prog`` that raised ``err``, after its one line on stderr:
    ``prog: error: …`` and 2 for a user error (``ValueError``, ``OSError``), else ``prog:
    Type: … (--debug shows the traceback)`` and 1; ``debug`` (``--debug``) re-raises ``err``."""
    if debug:
        raise err
    if isinstance(err, ValueError | OSError):
        print(f"{prog}: error: {err}", file=sys.stderr)
        return 2
    print(f"{prog}: {type(err).__name__}: {err} (--debug shows the traceback)", file=sys.stderr)
    return 1


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
