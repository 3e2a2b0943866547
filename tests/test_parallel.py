"""railgym.parallel and railgym.sweeps: results in task order, independent of the worker count."""

import ast
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import railgym.parallel
import railgym.sweeps
from railgym.parallel import choose_backend, ray_available, run_tasks, spawn_seeds
from railgym.sweeps import collect_sweep, vertical_run, vertical_sweep, vertical_tasks
from railgym.track import track_time_input
from railgym.vehicles.collect_design import CollectionDesign, collect_design
from railgym.vehicles.vertical.params import load_vehicle
from railgym.vehicles.vertical.simulate import simulate

#: a short seeded design: 2 classes × 2 seeds, passive and excited
SMALL = CollectionDesign(track_classes=(4, 6), speed_factors=(1.0,), seeds=(0, 3), duration=2.0)


@given(st.integers(0, 2**63), st.integers(0, 20), st.integers(0, 20))
def test_spawned_seeds_are_prefix_stable_and_distinct(root, n, m):
    a, b = spawn_seeds(root, n), spawn_seeds(root, n + m)
    assert b[:n] == a
    assert len(set(b)) == n + m
    assert all(0 <= s < 2**64 for s in b)


def test_spawned_seeds_are_numpy_seed_sequence_children():
    child = np.random.SeedSequence(7).spawn(3)[2]
    assert spawn_seeds(7, 3)[2] == int(child.generate_state(1, np.uint64)[0])


def test_process_pool_keeps_task_order_and_raises_task_errors():
    xs = [float(x) for x in range(12)]
    assert run_tasks(math.sqrt, xs, workers=2, backend="process") == [math.sqrt(x) for x in xs]
    with pytest.raises(ValueError, match="math domain error"):
        run_tasks(math.sqrt, [1.0, -1.0], workers=2, backend="process")


def test_backend_choice_and_bad_arguments():
    assert choose_backend(1) == "serial"
    assert choose_backend(2) == ("ray" if ray_available() else "process")
    assert choose_backend(2, backend="process") == "process"
    with pytest.raises(ValueError, match="workers"):
        run_tasks(abs, [1], workers=0)
    with pytest.raises(ValueError, match="workers"):
        run_tasks(abs, [1], workers=1.5)
    with pytest.raises(ValueError, match="backend"):
        run_tasks(abs, [1], backend="threads")
    with pytest.raises(ValueError, match="address"):
        run_tasks(abs, [1], address="")
    with pytest.raises(ValueError, match="backend must be 'ray'"):
        run_tasks(abs, [1], address="auto", backend="process")


@pytest.mark.skipif(ray_available(), reason="Ray is installed here")
def test_address_without_ray_is_a_clear_error():
    with pytest.raises(ValueError, match=r"address='10.0.0.1:6379' needs Ray.*railgym\[ray\]"):
        run_tasks(abs, [1], address="10.0.0.1:6379")


def test_collect_sweep_equals_collect_design_bit_for_bit_on_two_workers():
    ref = collect_design(SMALL)
    par = collect_sweep(SMALL, workers=2)
    assert par["design"] == ref["design"]
    np.testing.assert_array_equal(par["U"], ref["U"])
    np.testing.assert_array_equal(par["V"], ref["V"])
    assert len(par["runs"]) == len(ref["runs"]) == 8
    for a, b in zip(par["runs"], ref["runs"], strict=True):
        assert a.keys() == b.keys()
        for key in a:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_vertical_sweep_is_independent_of_the_worker_count():
    kwargs = {"track_classes": (4, 6), "n_seeds": 3, "root_seed": 11, "duration": 3.0}
    serial = vertical_sweep(**kwargs, workers=1)
    pooled = vertical_sweep(**kwargs, workers=2)
    assert serial == pooled  # floats compared exactly
    assert [r["seed"] for r in serial] == spawn_seeds(11, 3) * 2
    assert not any(r["diverged"] for r in serial)


def test_vertical_run_matches_a_direct_simulation():
    task = vertical_tasks((5,), n_seeds=1, root_seed=3, duration=3.0)[0]
    _, z, zdot = track_time_input(5, task.speed, 3.0, task.dt, task.seed)
    rec = simulate("dynamic", load_vehicle("manchester"), z, zdot, task.dt)
    row = vertical_run(task)
    assert row["rms_acc"] == float(np.sqrt(np.mean(rec["a2"] ** 2)))
    assert row["max_defl"] == float(np.max(np.abs(rec["x1"] - rec["x2"])))
    # the Wk weighting passes the 1-2 Hz body bounce (gain near 1) and cuts the rest
    assert 0.3 * row["rms_acc"] < row["a_w"] < 1.2 * row["rms_acc"]


@pytest.mark.skipif(not ray_available(), reason="needs the ray extra (pip install 'railgym[ray]')")
def test_ray_backend_equals_serial():
    kwargs = {"track_classes": (4,), "n_seeds": 2, "root_seed": 5, "duration": 2.0}
    tasks = vertical_tasks(**kwargs)
    assert run_tasks(vertical_run, tasks, workers=2, backend="ray") == vertical_sweep(**kwargs)


def test_task_runner_and_sweeps_need_neither_gymnasium_nor_ray_nor_torch():
    for module in (railgym.parallel, railgym.sweeps):
        tree = ast.parse(Path(module.__file__).read_text())
        names = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        names |= {
            n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.level == 0
        }
        top = {name.split(".")[0] for name in names} | {
            n for n in names if n.startswith("railgym.")
        }
        assert not top & {"gymnasium", "torch", "railgym.envs", "agents"}, module.__name__
    code = "import sys, railgym.sweeps; print([m for m in ('ray', 'torch') if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_a_bare_ray_folder_on_the_path_is_not_ray(tmp_path, monkeypatch):
    """A folder called ``ray`` (Ray's session folder under /tmp, say) is a namespace package,
    not the extra: the runner must not pick the Ray backend for it."""
    if ray_available():
        pytest.skip("ray is installed")
    (tmp_path / "ray").mkdir()
    monkeypatch.syspath_prepend(str(tmp_path))
    assert not ray_available()
    assert choose_backend(workers=2) == "process"
