"""What the fuzzer reads: every declared argument of every registered env (the fields of its
``params_class``), of every wrapper (its constructor's parameters), and every flag of every
``railgym`` and ``surrogates`` subcommand (the rows of the generated flag table)."""

from __future__ import annotations

import inspect
from importlib import import_module
from typing import Any, NamedTuple

from railgym.envs.params import Spec, default, specs
from railgym.registration import ENVS


class EnvArgument(NamedTuple):
    """One declared env argument: the first registered env id that takes it, its name, its
    declaration and its default."""

    env_id: str
    name: str
    spec: Spec
    default: Any


def entry_class(env_id: str) -> type:
    """The single-env class of ``env_id``."""
    module, name = ENVS[env_id][0].split(":")
    return getattr(import_module(module), name)


def params_classes() -> dict[type, str]:
    """The declaration class of each registered env → the newest env id made with it."""
    out: dict[type, str] = {}
    for env_id in ENVS:
        out[entry_class(env_id).params_class] = env_id  # type: ignore[attr-defined]
    return out


def env_arguments() -> list[EnvArgument]:
    """Every declared argument of every registered env's declaration class."""
    out = []
    for cls, env_id in params_classes().items():
        by_name = {f.name: f for f in cls.__dataclass_fields__.values()}
        for name, spec in specs(cls).items():
            out.append(EnvArgument(env_id, name, spec, default(by_name[name])))
    return out


class WrapperArgument(NamedTuple):
    """One constructor parameter of a wrapper of :mod:`railgym.wrappers`."""

    wrapper: type
    name: str
    default: Any


def wrapper_arguments() -> list[WrapperArgument]:
    """Every parameter (but ``env``) of every wrapper that :mod:`railgym.wrappers` exports."""
    wrappers = import_module("railgym.wrappers")
    out = []
    for name in wrappers.__all__:
        cls = getattr(wrappers, name)
        for p in list(inspect.signature(cls).parameters.values())[1:]:
            out.append(WrapperArgument(cls, p.name, p.default))
    return out
