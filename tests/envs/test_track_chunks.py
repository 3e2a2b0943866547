"""Chunked track mode (issue 32, item 5): a vector env whose whole-episode tracks do not fit
holds a window of each track and draws the next window again from the episode's seed, bit for
bit the values of the whole arrays; memory per sub-env does not grow with the episode."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from types import SimpleNamespace
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import railgym.envs.batch_base as batch_base
import railgym.envs.track_shell as track_shell
import railgym.envs.vehicle.batch as vehicle_batch
import railgym.envs.vertical.batch as vertical_batch
from railgym.envs.track_shell import TRACK_BYTES, WINDOW_SHARE
from railgym.track import (
    fra_profile_window,
    fra_profile_with_slope,
    track_time_input,
    track_time_window,
)
from tests.fmu.user_fmu import user_c_fmu  # noqa: F401, F811  (fixture)
from tests.markers import needs_cc


def _arrays(obj: Any, seen: set[int], depth: int = 0) -> Iterator[np.ndarray]:
    """The numpy arrays ``obj`` holds (attributes, tuples, lists, dicts), each owner once."""
    if isinstance(obj, np.ndarray):
        owner = obj
        while isinstance(owner.base, np.ndarray):
            owner = owner.base
        if id(owner) not in seen:
            seen.add(id(owner))
            yield owner
        return
    if depth > 4:
        return
    if isinstance(obj, dict):
        items = list(obj.values())
    elif isinstance(obj, tuple | list):
        items = list(obj)
    elif type(obj).__module__.startswith("railgym") and hasattr(obj, "__dict__"):
        items = list(vars(obj).values())
    else:
        return
    for item in items:
        yield from _arrays(item, seen, depth + 1)


def batch_bytes(sim: Any) -> int:
    """Bytes of all the numpy arrays a batch holds."""
    return sum(a.nbytes for a in _arrays(sim, set()))


def test_track_time_window_matches_whole_track() -> None:
    _, z, zdot = track_time_input(5, 70.0, 2.0, 1e-3, 3, wheelbase=2.5)
    for start, count in ((0, 10), (500, 1501), (1990, 11)):
        wz, wzd = track_time_window(5, 70.0, 2.0, 1e-3, 3, start, count, wheelbase=2.5)
        np.testing.assert_array_equal(wz, z[start : start + count])
        np.testing.assert_array_equal(wzd, zdot[start : start + count])
    with pytest.raises(ValueError, match="outside the samples"):
        track_time_window(5, 70.0, 2.0, 1e-3, 3, 1990, 12)
    _, z, slope = fra_profile_with_slope(4, 300.0, 0.05, 8)
    wz, ws = fra_profile_window(4, 300.0, 0.05, 8, 2345, 2000)
    np.testing.assert_array_equal(wz, z[2345:4345])
    np.testing.assert_array_equal(ws, slope[2345:4345])


COMFORT_KEYS = ("a_w", "a_ZP95_Wb", "Wz")


def _rollout(env_id: str, n: int, steps: int, kw: dict[str, Any]) -> tuple[list, list, Any]:
    """Observations, rewards, flags, the carbody acceleration, time and the ended episodes'
    mask of ``steps`` seeded random steps of ``n`` sub-envs; the end-of-episode comfort
    figures of those steps (``COMFORT_KEYS``, in order); the batch."""
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    obs, _ = venv.reset(seed=11)
    out, comfort = [obs], []
    rng = np.random.default_rng(2)
    low, high = venv.single_action_space.low, venv.single_action_space.high
    for _ in range(steps):
        act = rng.uniform(low, high, (n, low.size)).astype(np.float32)
        obs, rew, term, trunc, info = venv.step(act)
        out += [obs, rew, term, trunc, info["carbody_acc"], info["time"]]
        if "comfort" in info:
            out.append(info["_comfort"])
            comfort += [info["comfort"][k] for k in COMFORT_KEYS]
    return out, comfort, venv.unwrapped.sim


VERTICAL_CASES = [
    ("railgym/VerticalSuspension-v2", {}),
    ("railgym/VerticalSuspension-v2", {"backend": "reference", "speed": 30.0}),
    ("railgym/VerticalSuspension-v1", {"backend": "linear", "observation": "full"}),
    ("railgym/VerticalSuspension-v2", {"actuator": "semi-active"}),
    (
        "railgym/VerticalSuspension-v2",
        {"profile": (np.linspace(0.0, 80.0, 801), 1e-3 * np.sin(np.linspace(0.0, 40.0, 801)))},
    ),
]


@pytest.mark.filterwarnings("ignore:VerticalSuspension. the surrogate element")
@pytest.mark.parametrize(("env_id", "kw"), VERTICAL_CASES)
def test_vertical_chunked_equals_whole(
    monkeypatch: pytest.MonkeyPatch, env_id: str, kw: dict[str, Any]
) -> None:
    """Windows of 37 samples (3 control steps of 10 substeps) reproduce the whole tracks bit
    for bit over 2.5 episodes of 1 s, autoreset included."""
    kw = {"duration": 1.0, **kw}
    whole, comfort, sim = _rollout(env_id, 3, 250, kw)
    assert sim.window is None
    monkeypatch.setattr(vertical_batch, "_FORCED_WINDOW", 37)
    chunked, comfort_c, sim_c = _rollout(env_id, 3, 250, kw)
    assert sim_c.window == 37 and sim_c.z.shape == (3, 37)
    assert len(whole) == len(chunked)
    for a, b in zip(whole + comfort, chunked + comfort_c, strict=True):
        np.testing.assert_array_equal(a, b)
    for i in range(3):
        z, zdot = sim.track_arrays(i)
        zc, zdotc = sim_c.track_arrays(i)
        np.testing.assert_array_equal(z, zc)
        np.testing.assert_array_equal(zdot, zdotc)
        at = int(sim_c.base[i])
        np.testing.assert_array_equal(sim_c.z[i], z[at : at + 37])
        assert int(sim_c.base[i] + sim_c.k[i]) == int(sim.k[i])
        state, state_c = sim.render_state(i), sim_c.render_state(i)
        np.testing.assert_array_equal(state["track_z"], state_c["track_z"])
        assert state["z"] == state_c["z"]


def test_vertical_chunked_runs_past_the_end_as_whole(monkeypatch: pytest.MonkeyPatch) -> None:
    """The last window ends at the episode's last sample: stepping the batch past the end
    raises as it does with whole tracks."""
    monkeypatch.setattr(vertical_batch, "_FORCED_WINDOW", 25)
    venv = gym.make_vec(
        "railgym/VerticalSuspension-v2",
        num_envs=2,
        vectorization_mode="vector_entry_point",
        duration=0.2,
    )
    venv.reset(seed=0)
    sim = venv.unwrapped.sim
    for _ in range(20):
        sim.advance()
    assert int(sim.base[0]) + sim.z.shape[1] == sim.n_samples
    with pytest.raises(ValueError, match="track index out of range"):
        sim.advance()


@pytest.mark.parametrize(
    "env_id", ["railgym/VerticalSuspension-v1", "railgym/VerticalSuspension-v2"]
)
def test_vertical_16384_envs_fit(env_id: str) -> None:
    """16384 sub-envs of 20-s episodes hold at most 1 GiB of arrays, the tracks in windows."""
    venv = gym.make_vec(env_id, num_envs=16384, vectorization_mode="vector_entry_point")
    sim = venv.unwrapped.sim
    assert sim.window is not None and sim.window < sim.n_samples
    assert batch_bytes(sim) <= TRACK_BYTES


PROFILE = (np.linspace(0.0, 120.0, 1201), 1e-3 * np.sin(np.linspace(0.0, 60.0, 1201)))
VEHICLE_CASES = [
    ("railgym/VerticalVehicle-v2", 3, {"speed": (10.0, 25.0)}),
    ("railgym/VerticalVehicle-v2", 8, {"speed": (10.0, 40.0), "preview": 21.56}),
    ("railgym/VerticalVehicle-v2", 3, {"backend": "reference", "speed": 12.0}),
    ("railgym/VerticalVehicle-v1", 3, {"observation": "full", "speed": (10.0, 20.0)}),
    ("railgym/VerticalVehicle-v2", 3, {"actuator": "semi-active", "speed": (10.0, 25.0)}),
    ("railgym/VerticalVehicle-v2", 3, {"profile": PROFILE, "speed": 10.0}),
]


@pytest.mark.filterwarnings("ignore:VerticalVehicle. the surrogate element")
@pytest.mark.parametrize(("env_id", "n", "kw"), VEHICLE_CASES)
def test_vehicle_chunked_equals_whole(
    monkeypatch: pytest.MonkeyPatch, env_id: str, n: int, kw: dict[str, Any]
) -> None:
    """The shortest windows (one control step plus the front wheelset's reach at 10 m/s)
    reproduce the whole tracks bit for bit over 2.5 episodes of 1 s, autoreset and preview
    included; the windows move (at 10 m/s every step). The end-of-episode comfort figures
    come from the float32 record of chunked mode, computed in float64: each sample is rounded
    by at most 2⁻²⁴ (6e-8) relative, and the figures (r.m.s. of linearly filtered samples, the
    95th percentile of windowed r.m.s., Sperling's Wz, a root of weighted spectral sums) move
    by at most that order relative; rtol 1e-6 leaves room for the rounding
    of the filters' and spectra's sums to add up over the 100 samples, while a wrong or stale
    sample would not pass."""
    kw = {"duration": 1.0, **kw}
    whole, comfort, sim = _rollout(env_id, n, 250, kw)
    assert sim.window is None and sim.book.rec.dtype == np.float64
    monkeypatch.setattr(vehicle_batch, "_FORCED_WINDOW", 1)
    chunked, comfort_c, sim_c = _rollout(env_id, n, 250, kw)
    held = sim_c.window
    assert held is not None and held < sim_c.n_samples and sim_c.arrays.z.shape == (n, held)
    assert sim_c.book.rec.dtype == np.float32
    for a, b in zip(whole, chunked, strict=True):
        np.testing.assert_array_equal(a, b)
    assert len(comfort) == len(comfort_c) > 0
    for a, b in zip(comfort, comfort_c, strict=True):
        assert np.any(a > 0)
        np.testing.assert_allclose(b, a, rtol=1e-6, atol=0.0)
    assert np.any(sim_c.arrays.start > 0)
    for i in range(n):
        z, zdot = sim.track_arrays(i)
        zc, zdotc = sim_c.track_arrays(i)
        np.testing.assert_array_equal(z, zc)
        np.testing.assert_array_equal(zdot, zdotc)
        at = int(sim_c.arrays.start[i])
        np.testing.assert_array_equal(sim_c.arrays.z[i], z[at : at + held])
        np.testing.assert_array_equal(sim_c.arrays.k[i], sim.arrays.k[i])
    state, state_c = sim.render_state(0), sim_c.render_state(0)
    for key in ("track_z", "wheel_z"):
        np.testing.assert_array_equal(state[key], state_c[key])


@pytest.mark.parametrize("env_id", ["railgym/VerticalVehicle-v1", "railgym/VerticalVehicle-v2"])
def test_vehicle_chunked_memory(env_id: str) -> None:
    """16384 sub-envs of 20-s episodes fit in 1 GiB: chunked, the floor-acceleration record
    of the comfort figures is float32 (12 bytes per control step, 0.37 GiB there), and
    windows, record and the other per-vehicle arrays take at most 0.75 GiB."""
    venv = gym.make_vec(env_id, num_envs=16384, vectorization_mode="vector_entry_point")
    sim = venv.unwrapped.sim
    assert sim.window is not None and sim.window < sim.n_samples
    assert sim.book.rec.dtype == np.float32 and sim.book.rec.shape == (16384, 2000, 3)
    assert batch_bytes(sim) <= WINDOW_SHARE * TRACK_BYTES


def test_vehicle_float32_record_only_chunked(monkeypatch: pytest.MonkeyPatch) -> None:
    """With the limit set to 4 whole tracks and float64 records, 4 sub-envs hold whole
    tracks and keep the float64 record (results at sizes allowed before unchanged); 5 are
    chunked and record float32."""
    kw = {"vectorization_mode": "vector_entry_point", "duration": 4.0}
    sim = gym.make_vec("railgym/VerticalVehicle-v2", num_envs=1, **kw).unwrapped.sim
    assert sim.window is None and sim.book.rec.dtype == np.float64
    per_env = 16 * sim.n_samples + 24 * sim.cfg.n_steps
    monkeypatch.setattr(track_shell, "TRACK_BYTES", 4 * per_env)
    sim = gym.make_vec("railgym/VerticalVehicle-v2", num_envs=4, **kw).unwrapped.sim
    assert sim.window is None and sim.book.rec.dtype == np.float64
    sim = gym.make_vec("railgym/VerticalVehicle-v2", num_envs=5, **kw).unwrapped.sim
    assert sim.window is not None and sim.book.rec.dtype == np.float32
    assert batch_bytes(sim) <= 4 * per_env


@needs_cc
@pytest.mark.parametrize(
    ("env", "env_id", "module", "forced"),
    [
        ("vertical", "railgym/VerticalSuspension-v1", vertical_batch, 37),
        ("vehicle", "railgym/VerticalVehicle-v1", vehicle_batch, 1),
    ],
)
def test_fmu_backend_chunked_equals_whole(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Any, env: str, env_id: str, module: Any, forced: int
) -> None:
    """``backend="fmu"`` (the exported reference, co-simulation) reads the same windows."""
    pytest.importorskip("fmpy", reason="the 'fmi' extra (fmpy) is not installed")
    from railgym.fmu.reference import export_reference_fmu

    fmu, mapping = export_reference_fmu(tmp_path / f"{env}.fmu", env)
    kw = {"backend": "fmu", "fmu": fmu, "fmu_map": mapping, "duration": 0.3}
    if env == "vehicle":
        kw["speed"] = 10.0
    whole, comfort, _ = _rollout(env_id, 2, 40, kw)
    monkeypatch.setattr(module, "_FORCED_WINDOW", forced)
    chunked, comfort_c, sim_c = _rollout(env_id, 2, 40, kw)
    assert sim_c.window is not None and type(sim_c).__name__.startswith("FMU")
    for a, b in zip(whole, chunked, strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(comfort, comfort_c, strict=True):  # the float32 record (vehicle)
        np.testing.assert_allclose(b, a, rtol=1e-6, atol=0.0)


def test_draw_tracks_runs_concurrently() -> None:
    """With two threads, two moves run at once (each waits for the other at a barrier; run
    one after the other they would time out), and every row is moved exactly once."""
    barrier, moved = threading.Barrier(2, timeout=10.0), []

    def move(i: int) -> None:
        if i < 2:
            barrier.wait()
        moved.append(i)

    fake = SimpleNamespace(get_num_threads=lambda: 2)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(batch_base, "numba", fake)
        batch_base.draw_tracks(np.arange(7), move)
    assert sorted(moved) == list(range(7))


@pytest.mark.filterwarnings("ignore:Vertical.*the surrogate element")
@pytest.mark.parametrize(
    ("env_id", "module", "window"),
    [
        ("railgym/VerticalSuspension-v2", vertical_batch, 37),
        ("railgym/VerticalVehicle-v2", vehicle_batch, 1),
        ("railgym/VerticalSuspension-v2", vertical_batch, None),
        ("railgym/VerticalVehicle-v2", vehicle_batch, None),
    ],
)
def test_tracks_on_threads_equal_serial(
    monkeypatch: pytest.MonkeyPatch, env_id: str, module: Any, window: int | None
) -> None:
    """Tracks synthesised on 4 threads (the resets' whole tracks or first windows, the
    windows' moves) give the rollout of one after another bit for bit."""
    monkeypatch.setattr(module, "_FORCED_WINDOW", window)
    runs = []
    for threads in (1, 4):
        monkeypatch.setattr(
            batch_base, "numba", SimpleNamespace(get_num_threads=lambda t=threads: t)
        )
        runs.append(_rollout(env_id, 6, 150, {"duration": 1.0}))
    (serial, comfort, _), (threaded, comfort_t, _) = runs
    for a, b in zip(serial + comfort, threaded + comfort_t, strict=True):
        np.testing.assert_array_equal(a, b)


def test_users_fmu_chunked_equals_whole(
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Any,
    user_c_fmu: Any,  # noqa: F811
) -> None:
    """The user's own FMU (the hand-written C quarter car of ``tests/fmu/user_fmu.py``: other
    masses, variable names and outputs) behind ``backend="fmu"`` reads the same windows."""
    import yaml

    from tests.fmu.user_fmu import USER_MAPPING_YAML, USER_VEHICLE_YAML

    (tmp_path / "my_car.yaml").write_text(USER_VEHICLE_YAML)
    mapping = {**yaml.safe_load(USER_MAPPING_YAML), "fmu": str(user_c_fmu)}
    (tmp_path / "map.yaml").write_text(yaml.safe_dump({**mapping, "vehicle": "my_car.yaml"}))
    kw = {"backend": "fmu", "fmu_map": str(tmp_path / "map.yaml"), "duration": 0.3}
    whole, _, _ = _rollout("railgym/VerticalSuspension-v1", 2, 40, kw)
    monkeypatch.setattr(vertical_batch, "_FORCED_WINDOW", 11)
    chunked, _, sim_c = _rollout("railgym/VerticalSuspension-v1", 2, 40, kw)
    assert sim_c.window == 11 and np.any(sim_c.base > 0)
    for a, b in zip(whole, chunked, strict=True):
        np.testing.assert_array_equal(a, b)
