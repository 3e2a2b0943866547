"""The fuzzer of the env arguments, generated from the declarations: every declared argument
of every registered env and every wrapper parameter gets the values users get wrong
(:mod:`tests.fuzz.values`) through ``gym.make`` (the user's door); each is refused with a
``TypeError``/``ValueError`` naming the argument, or the env runs a few steps with finite
observations and rewards. A new declaration is fuzzed without new test code."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym
import pytest

from railgym.envs.params import Spec
from railgym.registration import env_family
from tests.fuzz.declarations import env_arguments, wrapper_arguments
from tests.fuzz.runner import judge, rollout
from tests.fuzz.values import Bad, Files, generic, integers, numbers


def spec_values(spec: Spec, default: Any, files: Files) -> list[Bad]:
    """The fuzz values of a declared argument of kind ``spec.kind``."""
    if spec.kind == "real":
        return numbers(default)
    if spec.kind == "int":
        return integers()
    if spec.kind == "bool":
        return [Bad("wrong type", "yes"), Bad("wrong type", 1), Bad("nan", float("nan"))]
    if spec.kind == "interval":
        return [
            Bad("wrong type", "x"),
            Bad("reversed", (2.0, 1.0)),
            Bad("nan", (float("nan"), 1.0)),
            Bad("inf", (1.0, float("inf"))),
            Bad("list for scalar", [1.0]),
        ]
    if spec.kind == "weights":
        key = spec.values[0]
        return [
            Bad("wrong type", "x"),
            Bad("list for scalar", [1.0]),
            Bad("unknown key", {"no_such_term": 1.0}),
            Bad("negative", {key: -1.0}),
            Bad("nan", {key: float("nan")}),
            Bad("int for float", {key: 2}),
        ]
    if spec.kind == "choice":
        return [Bad("wrong type", "no-such-choice"), Bad("empty string", ""), Bad("wrong type", 3)]
    if spec.check is not None and spec.optional:  # a number checked by a function (speed)
        return [*numbers(None), *generic(files)[-7:]]
    return generic(files)


def _cases() -> list[tuple[str, str, Bad]]:
    """(env id, argument, value) of every declared argument; file values as placeholders
    resolved in the test (their folder is the test's)."""
    placeholder = Files(*(Path(f"<{n}>") for n in Files._fields))
    return [
        (a.env_id, a.name, bad)
        for a in env_arguments()
        for bad in spec_values(a.spec, a.default, placeholder)
    ]


CASES = _cases()


def _real_value(value: Any, files: Files) -> Any:
    """``value`` with a placeholder path replaced by the test's file."""
    if isinstance(value, str) and value.startswith("<") and value.endswith(">"):
        return str(getattr(files, value[1:-1]))
    return value


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> Files:
    """The file-like values, in a folder of this module."""
    return Files.make(tmp_path_factory.mktemp("fuzz_files"))


#: value classes of :data:`~tests.fuzz.values.MUST_REFUSE` that are documented forms of an
#: argument: (env id family, argument) → classes
DOCUMENTED = {("railgym/VerticalVehicle", "speed"): frozenset({"list for scalar"})}


def test_env_arguments(files: Files) -> None:
    """Every case clear or correct; the failures listed together."""
    failures = []
    for env_id, name, bad in CASES:
        value = _real_value(bad.value, files)

        def run(env_id: str = env_id, name: str = name, value: Any = value) -> str | None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                env = gym.make(env_id, **{name: value})
                return rollout(env)

        accepts = DOCUMENTED.get((env_family(env_id), name), frozenset())
        wrong = judge(name, Bad(bad.kind, value), run, accepts)
        if wrong is not None:
            failures.append(f"{env_id} {name}={value!r} ({bad.kind}): {wrong}")
    assert not failures, "\n".join(failures)


def _wrapper_values(default: Any, files: Files) -> list[Bad]:
    """The fuzz values of a wrapper parameter, by its default's type."""
    if isinstance(default, float):
        return numbers(default)
    if isinstance(default, bool):
        return [Bad("wrong type", "yes"), Bad("nan", float("nan"))]
    if isinstance(default, int):
        return integers()
    return [*numbers(None), *generic(files)]


def _wrapped_env(wrapper: type) -> str:
    """The first registered env id (newest first) the wrapper runs with its defaults."""
    from railgym.registration import ENVS

    for env_id in reversed(list(ENVS)):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if rollout(wrapper(gym.make(env_id)), steps=2) is not None:
                    continue
        except (TypeError, ValueError):
            continue
        return env_id
    raise AssertionError(f"{wrapper.__name__} takes no registered env with its defaults")


def test_wrapper_arguments(files: Files) -> None:
    """Every parameter of every wrapper, through the wrapper around ``gym.make``."""
    failures = []
    envs = {}
    for arg in wrapper_arguments():
        if arg.wrapper not in envs:
            envs[arg.wrapper] = _wrapped_env(arg.wrapper)
        env_id = envs[arg.wrapper]
        for bad in _wrapper_values(arg.default, files):

            def run(arg: Any = arg, value: Any = bad.value, env_id: str = env_id) -> str | None:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    return rollout(arg.wrapper(gym.make(env_id), **{arg.name: value}), steps=5)

            wrong = judge(arg.name, bad, run)
            if wrong is not None:
                name = arg.wrapper.__name__
                failures.append(f"{name}({env_id}) {arg.name}={bad.value!r} ({bad.kind}): {wrong}")
    assert not failures, "\n".join(failures)


#: ``reset(options=...)`` of the wrong shape: each refused naming ``options`` (or the option)
RESET_OPTIONS = [
    Bad("list for scalar", ["hold"]),
    Bad("wrong type", "hold"),
    Bad("wrong type", 3),
    Bad("wrong type", {1: True}),
    Bad("wrong type", {"hold": "maybe"}),
    Bad("wrong type", {"no_such_option": 1.0}),
]


@pytest.mark.parametrize("env_id", sorted({a.env_id for a in env_arguments()}))
def test_reset_options(env_id: str) -> None:
    """The shape of ``reset(options=...)`` checked before anything is reset."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gym.make(env_id)
    failures = []
    for bad in RESET_OPTIONS:
        wrong = judge("options", bad, lambda v=bad.value: env.reset(seed=0, options=v))
        if wrong is not None:
            failures.append(f"options={bad.value!r}: {wrong}")
    assert not failures, "\n".join(failures)
