"""TrainCrash-v1 declared once: the per-train arrays and ``info`` keys of
``railgym.envs.crash.layout`` and the arguments of ``railgym.envs.crash.params.CrashParams``
are what the env holds, returns, accepts and documents."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import railgym  # noqa: F401
from railgym import _checks as val
from railgym.envs.crash.env import TrainCrashEnv, TrainCrashVectorEnv
from railgym.envs.crash.layout import EPISODE, INFO_FIELDS, REWARD_TERMS, info_layout
from railgym.envs.crash.params import CrashParams
from railgym.envs.params import specs, update_docs

DOCS = Path(__file__).resolve().parents[3] / "docs" / "envs" / "crash.md"
#: keys the env shell adds to the declared ones
SHELL_KEYS = {"reward_terms", "crash_over", "case"}


def _size(size: str, n: int) -> tuple[int, ...]:
    return () if size == "1" else (n,)


def _steps(env: gym.Env, n: int, seed: int = 0) -> dict:
    """``n`` steps of seeded random actions; returns the last info."""
    rng = np.random.default_rng(seed)
    info: dict = {}
    for _ in range(n):
        *_, info = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32))
    return info


@pytest.mark.parametrize("n_cars", [2, 3])
def test_every_declared_info_key_has_its_shape_and_type(n_cars):
    env = gym.make("railgym/TrainCrash-v1", backend="reference", n_cars=n_cars)
    _, first = env.reset(seed=0)
    info = _steps(env, 30)
    for got in (first, info):
        assert set(got) - SHELL_KEYS == {key.name for key in INFO_FIELDS}
        for key in INFO_FIELDS:
            value = got[key.name]
            if key.size == "1":
                assert type(value) is (bool if key.dtype == "bool" else float), key.name
            else:
                assert value.shape == (n_cars,) and value.dtype == np.dtype(key.dtype), key.name
    assert info["time"] == pytest.approx(30 * 1e-3)
    assert set(info["reward_terms"]) == set(REWARD_TERMS)
    env.close()


def test_the_vector_env_returns_every_declared_key_per_sub_env():
    venv = TrainCrashVectorEnv(num_envs=3, backend="reference")
    venv.reset(seed=0)
    _, _, _, _, info = venv.step(np.zeros((3, 2), np.float32))
    for key in INFO_FIELDS:
        value = info[key.name]
        assert value.shape == (3, *_size(key.size, 2)), key.name
        assert value.dtype == np.dtype(key.dtype), key.name
        assert info[f"_{key.name}"].all()


def test_the_batch_holds_every_declared_array_and_clears_it_at_reset():
    env = TrainCrashEnv(backend="reference", n_cars=3)
    env.reset(seed=0)
    _steps(env, 50)
    sim = env.sim
    layout = info_layout(3, 3)
    counts = {"1": None, "cars": 3, "zones": 3, "model_zones": len(sim.model.zone_names)}
    counts.update(terms=len(REWARD_TERMS), obs=len(env.obs_names))
    counts.update(info=max(cols.stop for cols, _ in layout.values()))
    counts["ring"] = (env.cfg.criteria.window_steps + 1) * 3
    for array in EPISODE:
        value = getattr(sim.episode, array.name)
        assert value.dtype == np.dtype(array.dtype), array.name
        assert value.shape == ((1,) if array.size == "1" else (1, counts[array.size])), array.name
    assert sim.episode.peak.max() > 0.0 and sim.episode.steps[0] == 50
    sim.reset_state(0)
    for array in EPISODE:
        if array.clear is not None and array.name != "scale":
            assert np.all(getattr(sim.episode, array.name) == array.clear), array.name
    assert np.all(sim.episode.scale[0, sim.zones] == 1.0)


def _docs_info_rows() -> dict[str, str]:
    """key → shape column of the docs' *Info* table."""
    section = DOCS.read_text(encoding="utf-8").split("## Info\n", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) == 3 and cells[0].startswith("`"):
            for key in re.findall(r"`(\w+)`", cells[0]):
                rows[key] = cells[1]
    return rows


def test_the_docs_info_table_lists_every_declared_key_with_its_shape():
    rows = _docs_info_rows()
    for key in INFO_FIELDS:
        kind = "bool" if key.dtype == "bool" else "float"
        shape = {"1": kind, "cars": "(n_cars,)", "zones": "(n_zones,)"}[key.size]
        if key.size != "1" and key.dtype == "bool":
            shape += " bool"
        assert rows.get(key.name) == shape, key.name
    assert set(rows) - {key.name for key in INFO_FIELDS} == SHELL_KEYS


def test_the_docs_arguments_table_is_the_declaration():
    assert update_docs(DOCS) == [], "run `railgym env-tables` to regenerate it"
    text = DOCS.read_text(encoding="utf-8")
    for name in specs(CrashParams):
        assert f"| `{name}` |" in text


def test_the_env_signature_is_the_declared_arguments():
    names = list(inspect.signature(TrainCrashEnv).parameters)
    assert names == ["render_mode", *specs(CrashParams)]
    vector = list(inspect.signature(TrainCrashVectorEnv).parameters)
    assert vector == ["num_envs", "render_mode", *specs(CrashParams)]


#: the real-valued arguments and their declared limits
REAL = {name: s for name, s in specs(CrashParams).items() if s.kind == "real"}


def _inside(name: str) -> st.SearchStrategy[float]:
    s = REAL[name]
    lo = 1e-3 if name == "max_duration" else s.lo  # at least one control step of 1 ms
    return st.floats(lo, s.hi, exclude_min=s.lo_open and lo == s.lo, exclude_max=s.hi_open)


def _outside(name: str) -> st.SearchStrategy[float]:
    s = REAL[name]
    below = st.floats(max_value=s.lo, exclude_max=not s.lo_open, allow_nan=False)
    above = st.floats(min_value=s.hi, exclude_min=not s.hi_open, allow_nan=False)
    return below | above | st.just(float("nan"))


@settings(max_examples=60, deadline=None)
@given(data=st.data(), name=st.sampled_from(sorted(REAL)))
def test_in_limit_arguments_are_accepted_and_others_refused_naming_the_field(data, name):
    value = data.draw(_inside(name))
    params = CrashParams(**{name: value})
    assert getattr(params, name) == value
    bad = data.draw(_outside(name))
    with pytest.raises(val.FieldError, match=rf"^{name} must be"):
        CrashParams(**{name: bad})


@settings(max_examples=30, deadline=None)
@given(n_cars=st.integers(-5, 60), weight=st.floats(-10.0, 2e6, allow_nan=False))
def test_integer_and_weight_limits(n_cars, weight):
    if 1 <= n_cars <= 50:
        assert CrashParams(n_cars=n_cars).scenario.n_cars == n_cars
    else:
        with pytest.raises(val.FieldError, match=r"^n_cars must be at"):
            CrashParams(n_cars=n_cars)
    if 0.0 <= weight <= 1e6:
        assert CrashParams(reward_weights={"peak": weight}).weights == (1.0, 1.0, weight)
    else:
        with pytest.raises(val.FieldError, match=r"^reward_weights\['peak'\] must be"):
            CrashParams(reward_weights={"peak": weight})
