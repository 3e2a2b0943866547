"""The lifetime of an FMU instance in :class:`railgym.fmu.runner.FMURunner`.

Each instance is freed once and in order — ``fmi2Terminate`` → ``fmi2FreeInstance`` → unload
the shared library — on the worker thread that loaded and instantiated it, by ``close()``
(``env.close()``), when its runner is garbage-collected, or at interpreter exit. Left to the
process exit, pythonfmu 0.7.0 FMUs instantiated from such a thread corrupted the heap (exit
status 134, "corrupted double-linked list") once four instances were open: here two vector
envs, a fresh process each.
"""

from __future__ import annotations

import gc
import sys
import threading
import weakref
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the envs)
from railgym.fmu.mapping import FMUError, load_mapping
from railgym.fmu.runner import FMURunner

pytest.importorskip("fmpy", reason="the 'fmi' extra (fmpy) is not installed")

ID = "railgym/VerticalSuspension-v1"

#: plain variable names only, so that it loads with any mapping version; the channels are
#: not the env's physics (deflection := x1), which does not matter for the instance lifetime
SMOKE_MAPPING = """\
version: 1
env: vertical
inputs:
  track:
    - {displacement: zr, rate: zr_dot}
  actuator_force: [Fact]
outputs:
  carbody_acc: a2
  bogie_acc: a2
  deflection: x1
  deflection_rate: v1
  carbody_vel: v2
  carbody_disp: x2
"""
ENV_KW: dict[str, Any] = {"vehicle": "manchester", "duration": 0.5, "track_class": 4}


@pytest.fixture(params=["c", "py"])
def user_fmu(request: pytest.FixtureRequest, tmp_path: Path) -> tuple[Path, Path]:
    """``(fmu, mapping)`` of the user's C or pythonfmu quarter car."""
    fmu = request.getfixturevalue("user_c_fmu" if request.param == "c" else "user_py_fmu")
    mapping = tmp_path / "map.yaml"
    mapping.write_text(SMOKE_MAPPING)
    return fmu, mapping


def _step(runner: FMURunner) -> None:
    runner.reset()
    z = np.zeros((1, 11))
    runner.advance(z, z, np.array([500.0]))


def test_close_frees_in_order_once_on_the_creating_thread(user_fmu: tuple[Path, Path]) -> None:
    fmu, path = user_fmu
    sys_path = list(sys.path)
    runner = FMURunner(load_mapping(path, fmu=fmu), 1e-3, 10)
    _step(runner)
    calls: list[tuple[str, int | None]] = []
    f = runner.fmu
    for name in ("terminate", "fmi2FreeInstance", "freeLibrary"):
        original = getattr(f, name)

        def spy(*args: Any, _name: str = name, _original: Any = original) -> Any:
            calls.append((_name, threading.get_ident()))
            return _original(*args)

        setattr(f, name, spy)
    worker = runner._worker.thread
    unpacked = Path(runner._dir)
    assert worker.is_alive() and unpacked.is_dir()
    runner.close()
    runner.close()
    assert calls == [
        ("terminate", worker.ident),
        ("fmi2FreeInstance", worker.ident),
        ("freeLibrary", worker.ident),
    ]
    worker.join(5.0)
    assert not worker.is_alive()
    assert unpacked.is_dir()  # the FMU file's folder, for its next instance (removed at exit)
    with pytest.raises(FMUError, match="closed"):
        _step(runner)
    again = FMURunner(load_mapping(path, fmu=fmu), 1e-3, 10)
    assert Path(again._dir) == unpacked
    again.close()
    sys.path[:] = sys_path  # a pythonfmu slave puts its resources folder on it


def test_a_runner_not_closed_is_freed_when_collected(user_fmu: tuple[Path, Path]) -> None:
    fmu, path = user_fmu
    sys_path = list(sys.path)
    runner = FMURunner(load_mapping(path, fmu=fmu), 1e-3, 10)
    _step(runner)
    ref, worker, unpacked = weakref.ref(runner), runner._worker.thread, Path(runner._dir)
    del runner
    gc.collect()
    assert ref() is None
    worker.join(5.0)
    assert not worker.is_alive()
    assert unpacked.is_dir()  # shared by the instances of the FMU file, removed at exit
    sys.path[:] = sys_path


def test_env_close_closes_the_runners(user_fmu: tuple[Path, Path]) -> None:
    fmu, path = user_fmu
    sys_path = list(sys.path)
    env = gym.make(ID, backend="fmu", fmu=fmu, fmu_map=path, **ENV_KW)
    venv = gym.make_vec(
        ID,
        num_envs=2,
        vectorization_mode="vector_entry_point",
        backend="fmu",
        fmu=fmu,
        fmu_map=path,
        **ENV_KW,
    )
    env.reset(seed=1)
    env.step(np.array([0.5], np.float32))
    venv.reset(seed=1)
    venv.step(np.full((2, 1), 0.5, np.float32))
    one: Any = env.unwrapped
    base: Any = venv.unwrapped
    runners = [*one.sim.runners, *base.sim.runners, *base.single_env.sim.runners]
    assert len(runners) == 4
    threads = [r._worker.thread for r in runners]
    assert all(t.is_alive() for t in threads)
    env.close()
    venv.close()
    for t in threads:
        t.join(5.0)
    assert not any(t.is_alive() for t in threads)
    sys.path[:] = sys_path


#: two vector envs of one sub-env: four FMU instances (the single env's and the sub-env's)
EXIT_SCRIPT = """
import sys
import gymnasium as gym
import numpy as np
import railgym

fmu, mapping, close = sys.argv[1], sys.argv[2], sys.argv[3] == "close"
kw = dict(backend="fmu", fmu=fmu, fmu_map=mapping, vehicle="manchester", duration=0.5,
          track_class=4)
envs = [gym.make_vec("railgym/VerticalSuspension-v1", num_envs=1,
                     vectorization_mode="vector_entry_point", **kw) for _ in range(2)]
for env in envs:
    env.reset(seed=1)
    for _ in range(20):
        env.step(np.full((1, 1), 0.3, np.float32))
if close:
    for env in envs:
        env.close()
print("stepped")
"""


@pytest.mark.parametrize("close", ["close", "exit"])
def test_the_process_exits_cleanly_with_fmu_envs(
    user_fmu: tuple[Path, Path], close: str, fresh_python: Callable[..., Any]
) -> None:
    fmu, path = user_fmu
    done = fresh_python(EXIT_SCRIPT, str(fmu), str(path), close)
    assert "stepped" in done.stdout, done.stderr[-3000:]
    assert "corrupted" not in done.stderr, done.stderr[-3000:]
    assert done.returncode == 0, done.stderr[-3000:]


#: a runner freed, then an FMU of FMPy's own (default callbacks) that logs: FMPy's logger
#: proxy holds one process-wide pointer to the last Python logger it was given
LOGGER_SCRIPT = """
import gc, sys
import numpy as np
import railgym
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from railgym.fmu.mapping import load_mapping
from railgym.fmu.runner import FMURunner
from surrogates.fmi import export_fmu
from surrogates.models.lpr import LegendreRegression

fmu, mapping, out = sys.argv[1], sys.argv[2], sys.argv[3]
runner = FMURunner(load_mapping(mapping, fmu), 1e-3, 10)
runner.reset()
runner.close()
del runner
gc.collect()
u = np.random.default_rng(0).uniform(-1.0, 1.0, (40, 1))
model = LegendreRegression(degree=1, extrapolation="raise").fit(u, 2.0 * u[:, 0])
export_fmu(model, out)
md = read_model_description(out)
s = FMU2Slave(guid=md.guid, unzipDirectory=extract(out),
              modelIdentifier=md.coSimulation.modelIdentifier, instanceName="fmpy")
s.instantiate()
s.setupExperiment(startTime=0.0)
s.enterInitializationMode()
s.exitInitializationMode()
vr = {v.name: v.valueReference for v in md.modelVariables}
s.setReal([vr["u1"]], [5.0])  # outside the box: the FMU logs an error
try:
    s.getReal([vr["v"]])
except Exception as exc:
    print("refused:", exc)
print("logged")
"""


def test_an_fmu_logging_after_a_runner_is_freed_does_not_crash(
    user_c_fmu: Path, tmp_path: Path, fresh_python: Callable[..., Any]
) -> None:
    mapping = tmp_path / "map.yaml"
    mapping.write_text(SMOKE_MAPPING)
    done = fresh_python(LOGGER_SCRIPT, str(user_c_fmu), str(mapping), str(tmp_path / "e.fmu"))
    assert done.returncode == 0, done.stderr[-3000:]
    assert "logged" in done.stdout and "refused" in done.stdout
    # FMPy's own instance's message reaches FMPy's printer (not a freed runner's logger)
    assert "outside the training domain" in done.stdout
