"""FMU lifetime with pythonfmu FMUs through ``gym.make``: many make/reset/step/close cycles,
one or two live instances at a time, in a fresh process that must exit 0.

Each fresh copy of a pythonfmu 0.7.0 shared library binds its GNU-unique C++ symbols to the
first copy's; with a folder (and so a library copy) per instance, two live instances corrupted the
heap ("free(): corrupted unsorted chunks", exit status 134) in about one run in five of 40
cycles. Every instance of one FMU file now shares one unpacked folder: one library copy per
process, which the test checks in ``/proc/self/maps`` (the abort itself is too rare for a
short test to catch; ``docs/fmi.md``, *FMU lifetime*, has the 10-run measurement).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from tests.fmu.user_fmu import USER_MAPPING_YAML, USER_VEHICLE_YAML

pytest.importorskip("fmpy", reason="the 'fmi' extra (fmpy) is not installed")


CYCLES = """
import sys
import gymnasium as gym
import numpy as np
import railgym

folder, live, cycles = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
kw = dict(backend="fmu", fmu=f"{folder}/QuarterCar.fmu", fmu_map=f"{folder}/map.yaml",
          vehicle=f"{folder}/car.yaml", duration=0.5, track_class=4)
for i in range(cycles):
    envs = [gym.make("railgym/VerticalSuspension-v2", **kw) for _ in range(live)]
    for env in envs:
        env.reset(seed=i)
    for _ in range(50):
        for env in envs:
            *_, term, trunc, _ = env.step(np.array([0.3], np.float32))
            assert not term
    threads = [env.unwrapped.sim.runners[0]._worker.thread for env in envs]
    for env in envs:
        env.close()
    assert not any(t.is_alive() for t in threads)  # close() returned after the free
maps = open("/proc/self/maps").read().splitlines()
copies = {line.split()[-1] for line in maps if line.endswith("QuarterCar.so")}
print("copies", len(copies))
print("cycles done")
"""


@pytest.mark.parametrize("live", [1, 2])
def test_make_step_close_cycles_exit_cleanly(
    user_py_fmu: Path, tmp_path: Path, live: int, fresh_python: Callable[..., Any]
) -> None:
    (tmp_path / "QuarterCar.fmu").symlink_to(user_py_fmu)
    (tmp_path / "map.yaml").write_text(USER_MAPPING_YAML)
    (tmp_path / "car.yaml").write_text(USER_VEHICLE_YAML)
    done = fresh_python(CYCLES, str(tmp_path), str(live), "8", timeout=600)
    assert "cycles done" in done.stdout, done.stderr[-3000:]
    assert done.returncode == 0, done.stderr[-3000:]
    assert "corrupted" not in done.stderr
    assert "copies 1" in done.stdout  # one library copy for all 8 × live instances
