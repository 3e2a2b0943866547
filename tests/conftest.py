"""Fixtures shared by several test files: env copies (and their rollouts), seeded actions,
rollout comparison, a small fitted LPR of the linear suspension, the bad-input error check and
the example scripts as modules."""

from __future__ import annotations

import copy
import importlib.util
import pickle
import re
from collections.abc import Callable
from importlib.resources import files
from pathlib import Path
from types import ModuleType
from typing import Any

import cloudpickle
import numpy as np
import pytest
import yaml
from hypothesis import settings

from railgym.vehicles.vertical.params import load_vehicle
from surrogates import LegendreRegression

# Tests assert results, never timings: no per-example deadline, so that a loaded CPU (CI, or
# numba compiling on the first call) does not fail a property.
settings.register_profile("railgym", deadline=None)
settings.load_profile("railgym")

COPIES: dict[str, Callable[[Any], Any]] = {
    "pickle": lambda e: pickle.loads(pickle.dumps(e)),
    "cloudpickle": lambda e: cloudpickle.loads(cloudpickle.dumps(e)),
    "deepcopy": copy.deepcopy,
}


@pytest.fixture(params=list(COPIES))
def copy_env(request: pytest.FixtureRequest) -> Callable[[Any], Any]:
    """Each way an env is copied (pickle, cloudpickle, deepcopy), one test each."""
    return COPIES[request.param]


@pytest.fixture
def random_actions() -> Callable[..., list[np.ndarray]]:
    """``make(n, shape, seed=0)``: ``n`` seeded float32 actions uniform in [-1.2, 1.2] (a little
    outside the action box, so that clipping is exercised)."""

    def make(n: int, shape: tuple[int, ...], seed: int = 0) -> list[np.ndarray]:
        rng = np.random.default_rng(seed)
        return [rng.uniform(-1.2, 1.2, shape).astype(np.float32) for _ in range(n)]

    return make


@pytest.fixture
def assert_same_rollouts() -> Callable[[list, list], None]:
    """``check(a, b)``: two rollouts (lists of rows of arrays) are bit identical."""

    def check(a: list, b: list) -> None:
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            for u, v in zip(x, y, strict=True):
                np.testing.assert_array_equal(u, v)

    return check


def _step_rows(*keys: str) -> Callable[[Any, Any], list[list[Any]]]:
    """``run(env, actions)``: one row per action of ``env.step``'s observation, reward, flags,
    the info ``keys`` and (where the info has them) the comfort figures."""

    def run(env: Any, actions: Any) -> list[list[Any]]:
        out = []
        for a in actions:
            obs, r, term, trunc, info = env.step(a)
            row = [obs.copy(), np.copy(r), np.copy(term), np.copy(trunc)]
            row += [info[k] for k in keys]
            if "comfort" in info:
                row += list(info["comfort"].values())
            out.append(row)
        return out

    return run


@pytest.fixture
def step_rows() -> Callable[..., Callable[[Any, Any], list[list[Any]]]]:
    """``step_rows(*keys)``: a ``run(env, actions)`` for :func:`continue_copies` (see
    :func:`_step_rows`)."""
    return _step_rows


@pytest.fixture
def continue_copies(copy_env: Callable[[Any], Any]) -> Callable[..., tuple[list, list, Any]]:
    """``run_both(env, run, seed, before, after)``: ``env.reset(seed=seed)``, ``run(env,
    before)``, then a copy of ``env`` (each way of :func:`copy_env`) and ``run(env, after)``,
    ``run(copy, after)``; returns the two rollouts and the copy. ``run(env, actions)`` steps
    ``env`` with each action and returns the rows to compare."""

    def run_both(
        env: Any, run: Callable[[Any, list], list], seed: int, before: list, after: list
    ) -> tuple[list, list, Any]:
        env.reset(seed=seed)
        run(env, before)
        twin = copy_env(env)
        return run(env, after), run(twin, after), twin

    return run_both


@pytest.fixture(scope="session")
def load_example() -> Callable[[str], ModuleType]:
    """``load(name)``: the script ``examples/<name>.py`` imported as a module (not run)."""

    def load(name: str) -> ModuleType:
        path = Path(__file__).resolve().parents[1] / "examples" / f"{name}.py"
        spec = importlib.util.spec_from_file_location(name, path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module

    return load


@pytest.fixture
def box_lpr() -> Callable[[str], LegendreRegression]:
    """``fit(extrapolation)``: LPR (degree 1) of the linear suspension of the packaged vehicle,
    fitted on a small box (±5 mm, ±0.05 m/s), so that a run leaves its domain."""
    veh = load_vehicle()
    g = np.meshgrid(np.linspace(-0.005, 0.005, 9), np.linspace(-0.05, 0.05, 9))
    u = np.c_[g[0].ravel(), g[1].ravel()]
    f = veh.k2 * u[:, 0] + veh.c2 * u[:, 1]

    def fit(extrapolation: str) -> LegendreRegression:
        return LegendreRegression(degree=1, extrapolation=extrapolation).fit(u, f)

    return fit


@pytest.fixture
def assert_names_the_field(tmp_path: Path) -> Callable[[Callable, type, str], None]:
    """``check(call, error, field)``: ``call(tmp_path)`` raises ``error`` (also a ValueError)
    with a message naming ``field`` and no leaked numpy/Python internals."""

    def check(call: Callable[[Path], Any], error: type[Exception], field: str) -> None:
        with pytest.raises(error, match=field) as info:
            call(tmp_path)
        assert isinstance(info.value, ValueError)  # every project error is also a ValueError
        assert not re.search(r"ufunc|object has no attribute|could not convert", str(info.value))

    return check


class NextStepAutoreset:
    """Single envs stepped the way a gymnasium vector env with next-step autoreset steps its
    sub-envs: a sub-env that ended is reset on the following step, which then reports reward
    0, not terminated and not truncated (with the reset's observation and info).

    Parameters
    ----------
    envs : the single envs, already reset.
    """

    def __init__(self, envs: list[Any]) -> None:
        self.envs = envs
        self.done = np.zeros(len(envs), bool)

    def step(self, actions: np.ndarray) -> list[tuple[Any, float, bool, bool, dict, bool]]:
        """``(obs, reward, terminated, truncated, info, was_reset)`` of each env."""
        out = []
        for i, env in enumerate(self.envs):
            was_reset = bool(self.done[i])
            if was_reset:
                (o, info), r, te, tr = env.reset(), 0.0, False, False
            else:
                o, r, te, tr, info = env.step(actions[i])
            self.done[i] = te or tr
            out.append((o, r, te, tr, info, was_reset))
        return out


@pytest.fixture
def next_step_autoreset() -> type[NextStepAutoreset]:
    """:class:`NextStepAutoreset`: single envs stepped as the vector env steps its sub-envs."""
    return NextStepAutoreset


@pytest.fixture(scope="session")
def crash_raw() -> Callable[..., dict]:
    """``raw(name="paper")``: a fresh copy of the raw ``crash`` mapping of a packaged crash
    scenario file (``railgym/configs/crash/<name>.yaml``), to edit and parse."""

    def raw(name: str = "paper") -> dict:
        text = files("railgym").joinpath("configs", "crash", f"{name}.yaml").read_text("utf-8")
        return copy.deepcopy(yaml.safe_load(text)["crash"])

    return raw


@pytest.fixture(scope="session")
def set_field() -> Callable[[dict, str, Any], dict]:
    """``set(raw, "cars.lead.mass_t", value)``: set a dotted field of a raw mapping in place
    and return the mapping."""

    def set_(raw: dict, dotted: str, value: Any) -> dict:
        *head, last = dotted.split(".")
        node = raw
        for key in head:
            node = node[key]
        node[last] = value
        return raw

    return set_
