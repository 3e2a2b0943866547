"""argparse value types of the commands (a bad value is a one-line error naming the flag), the
one-line error of a command that fails (:func:`error_status`, of :mod:`surrogates.cli_flags`)
and its one-line warnings (:func:`one_line_warnings`)."""

from __future__ import annotations

import argparse
import math
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from railgym import _checks as val
from railgym.envs.vertical.env import LIMITS
from railgym.registration import ENVS, env_family
from surrogates.checks import bounded_int, seed_number
from surrogates.cli import UsageError, check_output
from surrogates.cli_flags import error_status

__all__ = [
    "MAX_EPISODES",
    "VEHICLE_DURATION_S",
    "add_env_id",
    "add_parallel_arguments",
    "add_track_classes",
    "bounded_int",
    "bounded_real",
    "check_parallel",
    "check_speed_kmh",
    "duration_s",
    "backend_kwargs",
    "env_id_flag",
    "env_id_of",
    "env_kwargs_of",
    "with_policy_kwargs",
    "error_status",
    "episodes",
    "one_line_warnings",
    "seed_number",
    "speed_kmh",
    "track_class",
    "vehicle_cases",
    "vertical_cases",
]

#: most episodes (sub-envs) of one evaluation case: ``--episodes`` and ``episodes=``
MAX_EPISODES = 1000
#: highest speed accepted by ``--speed-kmh``, km/h: a sanity bound above twice the FRA class 6
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


#: ``--speed-kmh``: km/h, ``0 < v <= MAX_SPEED_KMH``
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


def env_kwargs_of(args: argparse.Namespace) -> dict[str, Any]:
    """The env keywords of ``railgym evaluate``'s model flags (``--fmu``, ``--fmu-map``,
    ``--vehicle``, ``--surrogate``, ``--scenario``), checked against ``--backend``,
    ``--env`` and ``--gap`` (which runs the surrogate beside ``--backend``)."""
    if args.backend != "fmu" and (args.fmu is not None or args.fmu_map is not None):
        raise ValueError("--fmu, --fmu-map: only with --backend fmu")
    if args.backend == "fmu" and args.env == "crash":
        raise ValueError("--backend fmu: only for --env vertical and vehicle, not --env crash")
    if args.vehicle is not None and args.env == "crash":
        raise ValueError("--vehicle: only for --env vertical and vehicle (crash: --scenario)")
    if args.scenario is not None and args.env != "crash":
        raise ValueError("--scenario: only for --env crash (vertical, vehicle: --vehicle)")
    if args.surrogate is not None and args.backend != "surrogate" and not args.gap:
        raise ValueError("--surrogate: the element of --backend surrogate (or of --gap)")
    out: dict[str, Any] = {}
    if args.backend == "fmu":
        out.update(fmu=args.fmu, fmu_map=args.fmu_map)
    if args.vehicle is not None:
        out["vehicle"] = str(args.vehicle)
    if args.backend == "fmu":  # both sides of --gap and every controller design get it
        from railgym.fmu.mapping import fmu_vehicle

        out["vehicle"] = str(fmu_vehicle(args.fmu_map, args.vehicle, "--vehicle "))
    if args.scenario is not None:
        out["scenario"] = str(args.scenario)
    if args.surrogate is not None:
        out["surrogate"] = _element(args.surrogate, args.env)
    return out


def _element(path: Any, env: str) -> Any:
    """The element file of ``--surrogate``: a model JSON path (vertical, vehicle; the env
    loads it) or crash elements (:func:`railgym.vehicles.crash.fe.load_crash_surrogate`)."""
    if env != "crash":
        return str(path)
    from railgym.vehicles.crash.fe import load_crash_surrogate

    return load_crash_surrogate(path)


def with_policy_kwargs(
    policy_kwargs: dict[str, Any], extra: dict[str, Any], policy: str
) -> dict[str, Any]:
    """``policy_kwargs`` (what ``policy`` was trained with) and the command's ``extra``; a key
    in both with another value is an error naming the policy (its training case wins nowhere
    silently)."""
    from railgym.fmu.mapping import same_vehicle

    for key, value in extra.items():
        same = same_vehicle if key == "vehicle" else (lambda a, b: a == b)
        if key in policy_kwargs and not same(policy_kwargs[key], value):
            raise ValueError(
                f"policy {policy}: trained with {key}={policy_kwargs[key]!r}, the command gives "
                f"{value!r}; drop the flag or evaluate a policy trained for it"
            )
    return {**policy_kwargs, **extra}


def backend_kwargs(backend: str, env_kwargs: dict[str, Any] | None) -> dict[str, Any]:
    """``env_kwargs`` of :func:`env_kwargs_of` for ``backend``: the FMU's files only for
    ``"fmu"``, the element only for ``"surrogate"``."""
    only = {"fmu": "fmu", "fmu_map": "fmu", "surrogate": "surrogate"}
    return {k: v for k, v in (env_kwargs or {}).items() if only.get(k, backend) == backend}


def vehicle_cases(args: argparse.Namespace) -> dict[str, Any]:
    """:func:`vertical_cases` and the speeds and duration of ``railgym evaluate --env
    vehicle``: the case keywords of ``evaluate_vehicle`` / ``gap_vehicle``."""
    duration = VEHICLE_DURATION_S if args.duration is None else args.duration
    return {**vertical_cases(args), "speeds_kmh": args.speed or [None], "duration": duration}


@contextmanager
def one_line_warnings(prog: str) -> Iterator[None]:
    """Within the block, a warning shown on stderr is the one line ``prog: warning: message``
    (the category named unless a ``UserWarning``), not Python's ``file:line: Category:
    message`` with the source line of the library code that warned. Warnings recorded by a
    caller (``warnings.catch_warnings(record=True)``, ``pytest.warns``) are left as they are."""

    def one_line(message: Any, category: type[Warning], *_: Any, **__: Any) -> str:
        kind = "" if category is UserWarning else f" ({category.__name__})"
        return f"{prog}: warning{kind}: {message}\n"

    before = warnings.formatwarning
    warnings.formatwarning = one_line
    try:
        yield
    finally:
        warnings.formatwarning = before


def add_track_classes(
    parser: argparse.ArgumentParser, default: list[int], help: str = "FRA track classes 1..6"
) -> None:
    """``--track-class C [C …]``: FRA track classes (1 to 6), ``default`` when not given."""
    parser.add_argument("--track-class", type=track_class, nargs="+", default=default, help=help)


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


def add_env_id(parser: argparse.ArgumentParser, defaults: dict[str, str]) -> None:
    """``--env-id ID`` or ``--env-version N`` (one of them): the registered version of the env
    that ``--env`` names (``defaults``: ``--env`` choice → its env id when neither is given)."""
    shown = ", ".join(f"{env}: {env_id}" for env, env_id in defaults.items())
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--env-id",
        metavar="ID",
        help="the registered id of the version of the env of --env that the episodes run on "
        f"(default: {shown})",
    )
    group.add_argument(
        "--env-version",
        type=bounded_int(0, 99),
        metavar="N",
        help="the version N of the env of --env: its id with -vN (default: as --env-id)",
    )


def env_id_of(args: argparse.Namespace, defaults: dict[str, str]) -> str:
    """The env id of ``--env-id`` / ``--env-version`` for ``args.env`` (``defaults``: as
    :func:`add_env_id`'s, also when neither is given); ValueError naming the flag and the
    registered versions where it is no registered version of that env."""
    default = defaults[args.env]
    family = env_family(default)
    if args.env_id is not None:
        flag, env_id = "--env-id", args.env_id
    elif args.env_version is not None:
        flag, env_id = "--env-version", f"{family}-v{args.env_version}"
    else:
        return default
    if env_id not in ENVS or env_family(env_id) != family:
        versions = ", ".join(e for e in ENVS if env_family(e) == family)
        raise ValueError(
            f"{flag}: {env_id} is no registered version of the env of --env {args.env}; "
            f"registered: {versions}"
        )
    return env_id


def env_id_flag(args: argparse.Namespace) -> str:
    """The flag and value that chose the env id (``--env-id ID`` or ``--env-version N``), for
    an error naming it."""
    if args.env_version is not None:
        return f"--env-version {args.env_version}"
    return f"--env-id {args.env_id}"


def check_out(parser: argparse.ArgumentParser, path: str, overwrite: bool) -> None:
    """``-o/--out`` checked before the work (:func:`surrogates.cli.check_output`): a folder, a
    missing or read-only folder, or an existing file without ``--overwrite`` exits 2 naming it."""
    try:
        check_output(path, "--out", overwrite)
    except UsageError as err:
        parser.error(str(err))
