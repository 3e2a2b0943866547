"""VerticalVehicle-v1 on the shared env shell: copies, reward terms, accessors, info masks,
fresh single-env info arrays, and the cached compiled step in a new process."""

from __future__ import annotations

import os

import numpy as np
import pytest

from railgym.envs.vehicle.env import (
    ACC_REF,
    INFO_KEYS,
    REWARD_TERMS,
    VerticalVehicleEnv,
    VerticalVehicleVectorEnv,
)
from railgym.envs.vertical.env import VerticalSuspensionEnv
from tests.fresh_process import ROOT, run_python


@pytest.mark.parametrize("mid", [0, 17])
def test_single_env_copy_continues_bit_identically(
    continue_copies, mid, random_actions, assert_same_rollouts, step_rows
):
    run = step_rows("carbody_acc", "rms_carbody_acc", "actuator_force")
    env = VerticalVehicleEnv(backend="reference", duration=0.3, sensor_noise=0.05)
    before = random_actions(mid, (2,), seed=1)
    acts = random_actions(30 - mid, (2,), seed=2)  # to the end of the episode (comfort figures)
    a, b, twin = continue_copies(env, run, 4, before, acts)
    assert a[-1][3] and len(a[-1]) == 10  # truncated: the last step carries the comfort figures
    assert_same_rollouts(a, b)
    assert twin.sim.arrays.z is not env.sim.arrays.z and twin.sim.reward is twin.sim.book.rew
    assert_same_rollouts(run(env, []), run(twin, []))
    np.testing.assert_array_equal(env.reset(seed=5)[0], twin.reset(seed=5)[0])


@pytest.mark.parametrize("mid", [0, 12])
def test_vector_env_copy_continues_bit_identically(
    continue_copies, mid, random_actions, assert_same_rollouts, step_rows
):
    run = step_rows("carbody_acc", "rms_carbody_acc", "actuator_force")
    kw = {"backend": "surrogate", "duration": 0.2, "sensor_noise": 0.05, "speed": (30.0, 50.0)}
    venv = VerticalVehicleVectorEnv(num_envs=3, **kw)
    before = random_actions(mid, (3, 2), seed=3)
    acts = random_actions(45, (3, 2), seed=4)  # crosses two autoresets
    a, b, _ = continue_copies(venv, run, 9, before, acts)
    assert_same_rollouts(a, b)


def test_reward_terms_sum_to_the_reward_and_follow_the_definition(random_actions):
    w = {"acceleration": 1.5, "deflection": 0.5, "force": 0.2}
    env = VerticalVehicleEnv(backend="reference", duration=0.5, reward_weights=w)
    env.reset(seed=0)
    free, f_max = env.cfg.free_travel, env.cfg.f_max
    p = env.vehicle_params
    for u in random_actions(50, (2,)):
        _, r, *_, info = env.step(u)
        t = info["reward_terms"]
        assert tuple(t) == REWARD_TERMS
        assert t["acceleration"] + t["deflection"] + t["force"] + t["divergence"] == r
        acc = info["carbody_acc"]
        assert env.carbody_acceleration.tolist() == acc.tolist()
        assert t["acceleration"] == pytest.approx(-1.5 * np.mean((acc / ACC_REF) ** 2))
        x = env.state
        defl = [x[3 + 2 * b] - x[0] - s * p.a * x[1] - p.phi_a * x[2] for b, s in ((0, 1), (1, -1))]
        assert t["deflection"] == pytest.approx(-0.5 * np.mean((np.array(defl) / free) ** 2))
        force = np.clip(u.astype(float), -1, 1) * f_max
        np.testing.assert_array_equal(env.actuator_force, force)
        np.testing.assert_array_equal(info["actuator_force"], force)
        assert t["force"] == pytest.approx(-0.2 * np.mean((force / f_max) ** 2))
        assert t["divergence"] == 0.0
        assert env.out_of_domain == info["out_of_domain"] == 0


def test_divergence_has_its_own_term_and_ends_the_episode():
    env = VerticalVehicleEnv(backend="linear", duration=0.5, f_max=1e9)
    env.reset(seed=0)
    for _ in range(50):
        _, r, term, trunc, info = env.step(np.array([1.0, -1.0], np.float32))
        if term:
            break
    assert term and not trunc and info["diverged"] is True
    t = info["reward_terms"]
    assert r == t["divergence"] == -100.0 and t["acceleration"] == t["force"] == 0.0
    assert set(info["comfort"]) == {"a_w", "a_ZP95_Wb", "Wz"}
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(2, np.float32))


def test_vector_info_masks_and_accessors():
    venv = VerticalVehicleVectorEnv(num_envs=2, backend="linear", duration=0.05)
    _, info = venv.reset(seed=0)
    assert "reward_terms" not in info and info["_time"].all()
    acts = np.array([[0.5, -0.5], [-2.0, 0.25]], np.float32)
    for _ in range(5):
        _, r, term, trunc, info = venv.step(acts)
    assert trunc.all() and not term.any()
    assert info["_comfort"].all() and info["comfort"]["a_w"].shape == (2, 3)
    terms = info["reward_terms"]
    assert info["_reward_terms"].all() and all(terms[f"_{k}"].all() for k in REWARD_TERMS)
    np.testing.assert_array_equal(sum(terms[k] for k in REWARD_TERMS), r)
    assert not info["diverged"].any() and info["_diverged"].all()
    np.testing.assert_array_equal(venv.actuator_force, np.clip(acts, -1, 1) * 8000.0)
    np.testing.assert_array_equal(venv.carbody_acceleration, info["carbody_acc"])
    assert venv.state.shape == (2, 14) and venv.out_of_domain.tolist() == [0, 0]
    _, _, term, trunc, info = venv.step(acts)  # the autoreset step
    assert not (term | trunc).any() and "comfort" not in info
    assert info["time"].tolist() == [0.0, 0.0]


def test_raise_policy_terminates_with_a_flag_and_linear_does_not(box_lpr):
    runs = {}
    for policy in ("raise", "linear"):
        env = VerticalVehicleEnv(surrogate=box_lpr(policy), track_class=4, duration=2.0)
        env.reset(seed=0)
        for k in range(200):  # noqa: B007 (k is read after the loop)
            _, r, term, trunc, info = env.step(np.ones(2, np.float32))
            if term or trunc:
                break
        runs[policy] = (k, term, r, info)
    k, term, r, info = runs["raise"]
    assert term and info["extrapolated"] and info["out_of_domain"] > 0 and k < 199
    assert r == sum(info["reward_terms"].values()) and info["reward_terms"]["divergence"] == 0
    k, term, r, info = runs["linear"]
    assert not term and "extrapolated" not in info and info["out_of_domain"] > 0


def test_single_env_info_arrays_are_fresh_and_match_the_vector_env(random_actions):
    env = VerticalVehicleEnv(backend="reference", duration=0.1)
    venv = VerticalVehicleVectorEnv(num_envs=1, backend="reference", duration=0.1)
    env.reset(seed=2)
    venv.reset(seed=2)
    arrays = ("carbody_acc", "bogie_acc", "rms_carbody_acc", "actuator_force")
    for a in random_actions(10, (2,), seed=5):
        *_, info = env.step(a)
        *_, vinfo = venv.step(a[None])
        assert tuple(info)[: len(INFO_KEYS)] == INFO_KEYS
        for key in INFO_KEYS:
            np.testing.assert_array_equal(info[key], vinfo[key][0])
        for key in arrays:
            assert info[key].dtype == np.float64 and info[key].shape == vinfo[key][0].shape
            info[key][:] = np.nan  # the caller's arrays: the env and other entries unchanged
        assert np.isfinite(env.carbody_acceleration).all()
        assert np.isfinite(env.actuator_force).all() and info["speed"] == env.speeds[0]


_FRESH = """
import numpy as np
from numba.core.runtime import rtsys
from railgym.envs.vehicle.env import VerticalVehicleEnv
from railgym.envs.vertical.env import VerticalSuspensionEnv
for env, m in ((VerticalVehicleEnv(duration=0.1), 2), (VerticalSuspensionEnv(duration=0.1), 1)):
    env.reset(seed=1)
    before = rtsys.get_allocation_stats()
    for _ in range(10):
        obs = env.step(np.full(m, 0.5, np.float32))[0]
    after = rtsys.get_allocation_stats()
    print(obs.tobytes().hex(), after.alloc - before.alloc, after.free - before.free)
"""


def test_a_fresh_process_loads_the_cached_steps_reproduces_them_and_frees_their_scratch():
    """The compiled steps (the whole-vehicle one links numba's parallel scheduler) loaded from
    numba's cache in a new process run, give the same bits, and free every array the kernels
    allocate (they run without the runtime's reference counting)."""
    expected = []
    for env, m in ((VerticalVehicleEnv(duration=0.1), 2), (VerticalSuspensionEnv(duration=0.1), 1)):
        env.reset(seed=1)
        for _ in range(10):
            obs = env.step(np.full(m, 0.5, np.float32))[0]
        expected.append(obs.tobytes().hex())
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_NRT_STATS": "1"}
    run = run_python("-c", _FRESH, cwd=ROOT, env=env)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.strip().split("\n")
    assert len(lines) == len(expected)
    for line, obs in zip(lines, expected, strict=True):
        got, alloc, free = line.split()
        assert got == obs and int(alloc) == int(free)  # the kernels may allocate nothing
