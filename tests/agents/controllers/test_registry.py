"""One registry of controllers and baselines (agents.controllers.registry): one spelling per
name, every env family's baselines listed and buildable, the commands reading it."""

from __future__ import annotations

import re
import warnings

import pytest

from agents.controllers import registry
from agents.controllers.semi_active_control import SEMI_ACTIVE_CONTROLLERS
from railgym.registration import ENVS, env_family

ONE_SPELLING = re.compile(r"^[a-z0-9]+(-[a-z0-9]+)*$")


def _all_names() -> set[str]:
    tables = [
        *registry.CONTROLLERS_OF.values(),
        registry.CRASH_CONTROLLERS,
        SEMI_ACTIVE_CONTROLLERS,
    ]
    lists = [
        *registry.BASELINES.values(),
        *registry.COMPARISON.values(),
        registry.SEMI_ACTIVE_BASELINES,
        registry.PREVIEW_BASELINES,
    ]
    return {n for t in tables for n in t} | {n for names in lists for n in names}


def test_every_name_has_one_spelling():
    bad = sorted(n for n in _all_names() if not ONE_SPELLING.match(n))
    assert bad == []
    assert "best-constant" in registry.BASELINES[registry.CRASH_ID]


def test_every_env_family_has_its_baselines_and_they_resolve():
    families = {env_family(e) for e in ENVS}
    for table in (registry.BASELINES, registry.COMPARISON):
        assert {env_family(e) for e in table} == families
    for env_id in (registry.ENV_ID, registry.VEHICLE_ID):
        by_name = registry.CONTROLLERS_OF[env_id]
        assert set(registry.BASELINES[env_id]) <= set(by_name)
        assert set(registry.COMPARISON[env_id]) <= set(by_name)
    assert set(registry.SEMI_ACTIVE_BASELINES) <= set(SEMI_ACTIVE_CONTROLLERS)
    assert set(registry.PREVIEW_BASELINES) <= set(registry.VEHICLE_CONTROLLERS)
    crash = registry.BASELINES[registry.CRASH_ID]
    assert tuple(registry.crash_factories(crash)) == crash == tuple(registry.CRASH_CONTROLLERS)
    assert set(registry.COMPARISON[registry.CRASH_ID]) <= set(crash)


def test_crash_baselines_build_on_the_env():
    from railgym.envs.crash.env import TrainCrashVectorEnv

    env = TrainCrashVectorEnv(num_envs=1)
    obs, _ = env.reset(seed=0)
    for name, factory in registry.crash_factories().items():
        action, _ = factory(env).predict(obs)
        assert action.shape == (1, env.single_action_space.shape[0]), name


def test_the_old_spelling_is_read_with_a_deprecation_warning():
    with pytest.warns(DeprecationWarning, match="deprecated, use 'best-constant'"):
        factories = registry.crash_factories(["best constant"])
    assert list(factories) == ["best-constant"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert registry.canonical_name("best-constant") == "best-constant"


def test_the_commands_read_the_one_registry():
    from agents.evaluation import benchmark, evaluate

    assert benchmark.baselines_of is registry.baselines_of
    for name in ("BASELINES", "SEMI_ACTIVE_BASELINES", "PREVIEW_BASELINES"):
        assert not hasattr(benchmark, name)  # no copy of the registry's tables
    doc = " ".join(evaluate.__doc__.split())
    assert "``passive``, ``best-constant``, ``speed-adaptive``" in doc
