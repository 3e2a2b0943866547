"""railgym/VerticalVehicle-v1: API, vector = singles, seeding, copies, profiles, comfort."""

import copy

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from hypothesis import given, settings
from hypothesis import strategies as st

import railgym  # noqa: F401
from railgym.comfort import a_zp95, sperling_wz, weighted_rms
from railgym.envs.vehicle.env import VerticalVehicleEnv, VerticalVehicleVectorEnv

ID = "railgym/VerticalVehicle-v1"
SHORT = {"backend": "linear", "duration": 0.5}


def run(env, actions, seed):
    out = [(env.reset(seed=seed)[0], None, None, None)]
    for a in actions:
        obs, r, term, trunc, info = env.step(a)
        out.append((obs, r, term, trunc))
        if term or trunc:
            out.append((env.reset()[0], None, None, None))
    return out


def test_registration_and_spaces():
    env = gym.make(ID, backend="linear", n_actuators=2)
    assert isinstance(env.unwrapped, VerticalVehicleEnv)
    assert env.action_space.shape == (2,) and env.observation_space.shape == (11,)
    venv = gym.make_vec(ID, num_envs=2, vectorization_mode="vector_entry_point", **SHORT)
    assert isinstance(venv.unwrapped, VerticalVehicleVectorEnv)
    assert venv.action_space.shape == (2, 2)


@pytest.mark.parametrize("observation", ["sensors", "full"])
def test_gymnasium_and_sb3_checkers(observation):
    from stable_baselines3.common.env_checker import check_env as sb3_check

    env = VerticalVehicleEnv(observation=observation, **SHORT)
    check_env(env, skip_render_check=True)
    sb3_check(VerticalVehicleEnv(observation=observation, **SHORT), warn=True)


def test_vector_env_equals_single_envs_across_autoreset():
    kw = {"backend": "surrogate", "duration": 0.3, "speed": (30.0, 50.0), "sensor_noise": 0.01}
    n, steps = 3, 70
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, (steps, n, 2)).astype(np.float32)
    venv = VerticalVehicleVectorEnv(num_envs=n, **kw)
    obs, _ = venv.reset(seed=7)
    vec = [(obs, None, None, None)]
    speeds = []
    for k in range(steps):
        o, r, te, tr, info = venv.step(acts[k])
        vec.append((o, r, te, tr))
        speeds.append(info["speed"].copy())
    for i in range(n):
        env = VerticalVehicleEnv(**kw)
        o, info = env.reset(seed=7 + i)
        np.testing.assert_array_equal(o, vec[0][0][i])
        assert info["speed"] == speeds[0][i]
        prev_done = False
        for k in range(steps):
            if prev_done:
                o, _ = env.reset()
                r, te, tr = 0.0, False, False
            else:
                o, r, te, tr, _ = env.step(acts[k, i])
            vo, vr, vte, vtr = vec[k + 1]
            np.testing.assert_array_equal(o, vo[i])
            assert (r, te, tr) == (vr[i], vte[i], vtr[i])
            prev_done = te or tr
    assert len({float(s[0]) for s in speeds}) == 3  # a new speed each episode (30 steps)


def test_seeding_reproduces_bit_for_bit_and_copies_continue_alike():
    acts = [np.array([0.3, -0.2], np.float32)] * 40
    a = run(VerticalVehicleEnv(backend="reference", duration=0.3), acts, seed=3)
    b = run(VerticalVehicleEnv(backend="reference", duration=0.3), acts, seed=3)
    c = run(VerticalVehicleEnv(backend="reference", duration=0.3), acts, seed=4)
    for x, y in zip(a[1:], b[1:], strict=True):
        np.testing.assert_array_equal(x[0], y[0])
        assert x[1:] == y[1:]
    assert not np.array_equal(a[5][0], c[5][0])
    env = VerticalVehicleEnv(**SHORT)
    env.reset(seed=1)
    for _ in range(10):
        env.step(np.ones(2, np.float32))
    twin = copy.deepcopy(env)
    for _ in range(10):
        o1, r1, *_ = env.step(np.full(2, -0.5, np.float32))
        o2, r2, *_ = twin.step(np.full(2, -0.5, np.float32))
        np.testing.assert_array_equal(o1, o2)
        assert r1 == r2


def test_info_arrays_are_copies_and_comfort_matches_the_recorded_accelerations():
    env = VerticalVehicleEnv(backend="linear", duration=6.0)
    env.reset(seed=0)
    rec = []
    while True:
        _, _, term, trunc, info = env.step(np.zeros(2, np.float32))
        assert info["carbody_acc"].shape == (3,)
        rec.append(info["carbody_acc"].copy())
        info["carbody_acc"][:] = 99.0  # must not reach the env
        if term or trunc:
            break
    rec = np.array(rec)
    assert np.all(np.abs(rec) < 50)
    c = info["comfort"]
    for j in range(3):
        assert c["a_w"][j] == pytest.approx(weighted_rms(rec[:, j], 100.0, "Wk", lowpass=False))
        assert c["a_ZP95_Wb"][j] == pytest.approx(a_zp95(rec[:, j], 100.0, lowpass=False))
        assert c["Wz"][j] == pytest.approx(sperling_wz(rec[:, j], 100.0))
    np.testing.assert_allclose(info["rms_carbody_acc"], np.sqrt(np.mean(rec**2, axis=0)))
    # the bogie spacing filters the track: the centre rides better than the ends
    assert c["a_w"][1] < min(c["a_w"][0], c["a_w"][2])


_WILD = VerticalVehicleEnv(backend="reference", duration=0.3, f_max=1e9)


@settings(max_examples=15, deadline=None)
@given(st.lists(st.tuples(st.floats(-1e9, 1e9), st.floats(-1e9, 1e9)), min_size=1, max_size=30))
def test_nan_never_leaves_step(actions):
    env = _WILD
    env.reset(seed=0)
    for a in actions:
        obs, r, term, trunc, info = env.step(np.array(a, np.float32))
        assert np.all(np.isfinite(obs)) and np.isfinite(r)
        assert np.all(np.isfinite(info["carbody_acc"]))
        if term or trunc:
            assert all(np.all(np.isfinite(v)) for v in info["comfort"].values())
            break
    with pytest.raises(ValueError, match="finite"):
        env.reset(seed=0)
        env.step(np.array([np.nan, 0.0]))


def test_profile_option_file_and_arrays_agree(tmp_path):
    x = np.arange(0.0, 200.0, 0.25)
    z = 2e-3 * np.sin(2 * np.pi * x / 38.0) + 5e-4 * np.sin(2 * np.pi * x / 7.0)
    path = tmp_path / "track.csv"
    path.write_text(
        "x,z\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(x, z, strict=True))
    )
    kw = {"backend": "linear", "duration": 2.0, "speed": 40.0}
    acts = [np.zeros(2, np.float32)] * 30
    a = run(VerticalVehicleEnv(profile=str(path), **kw), acts, seed=0)
    env = VerticalVehicleEnv(**kw)
    env.reset(seed=0, options={"profile": (x, z)})
    b = [(env.reset(seed=0, options={"hold": True})[0],)] + [env.step(u)[:4] for u in acts]
    for p, q in zip(a[1:], b[1:], strict=True):
        np.testing.assert_array_equal(p[0], q[0])
    flat = VerticalVehicleEnv(**kw)
    flat.reset(seed=0, options={"profile": (x, np.zeros_like(x))})
    obs, r, *_ = flat.step(np.zeros(2, np.float32))
    assert np.all(obs == 0) and r == 0.0  # level track, passive: the vehicle stays at rest
    flat.reset(options={"profile": None})  # back to FRA track
    assert np.any(flat.step(np.zeros(2, np.float32))[0] != 0)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("x,z\n0,0\n1,nan\n2,0\n3,0\n", r"track\.csv.*not finite.*line 3"),
        ("0,0\n1,0\n1,0\n3,0\n", r"strictly increasing.*line 3"),
        ("0,0\n1,0,5\n", r"track\.csv:2: expected 2 columns"),
        ("0,0\n1,a\n", r"track\.csv:2: not a number"),
        ("0,0\n1,0\n2,0\n3,0\n", r"too short"),
    ],
)
def test_profile_file_errors_name_file_line_and_problem(tmp_path, text, match):
    path = tmp_path / "track.csv"
    path.write_text(text)
    env_kw = {"backend": "linear", "duration": 1.0, "profile": str(path)}
    with pytest.raises(ValueError, match=match):
        VerticalVehicleEnv(**env_kw).reset(seed=0)


def test_bad_arguments_name_the_argument():
    for kw, match in [
        ({"backend": "x"}, "backend"),
        ({"n_actuators": 4}, "n_actuators"),
        ({"speed": (50.0, 30.0)}, "v_min"),
        ({"control_dt": 0.05}, "control_dt"),
        ({"acc_weighting": "Wx"}, "acc_weighting"),
        ({"profile": "/no/such.csv"}, "does not exist"),
    ]:
        with pytest.raises(ValueError, match=match):
            VerticalVehicleEnv(**kw)
    env = VerticalVehicleEnv(**SHORT)
    with pytest.raises(ValueError, match="unknown reset option"):
        env.reset(options={"sped": 3})


def test_wk_weighted_reward_and_rendering():
    env = VerticalVehicleEnv(
        backend="linear", duration=1.0, acc_weighting="Wk", render_mode="rgb_array"
    )
    raw = VerticalVehicleEnv(backend="linear", duration=1.0)
    env.reset(seed=2)
    raw.reset(seed=2)
    rs = []
    for _ in range(60):
        o1, r1, *_ = env.step(np.zeros(2, np.float32))
        o2, r2, *_ = raw.step(np.zeros(2, np.float32))
        np.testing.assert_array_equal(o1, o2)  # the weighting changes the reward only
        rs.append((r1, r2))
    assert not np.allclose(*np.array(rs).T)
    frame = env.render()
    assert frame.shape == (400, 800, 3) and frame.dtype == np.uint8
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 5


def test_memory_element_is_the_default_and_static_is_accepted():
    from railgym.vehicles.collect import default_vertical_surrogate
    from railgym.vehicles.vehicle.collect import default_vehicle_surrogate

    env = gym.make("railgym/VerticalVehicle-v1", backend="surrogate", duration=0.2)
    default = default_vehicle_surrogate()
    np.testing.assert_array_equal(env.unwrapped.sim.lpr.coef, default.kernel_arrays()[1])
    law = default.features_["relaxation"]
    np.testing.assert_array_equal(env.unwrapped.sim.lpr.relax_z, law["zeta"])
    np.testing.assert_array_equal(env.unwrapped.sim.lpr.relax_r, law["rate"])
    assert env.unwrapped.sim.lpr.tau > 0 and env.unwrapped.state.shape == (16,)
    one_bogie = default_vertical_surrogate("maxwell")
    env = gym.make("railgym/VerticalVehicle-v1", surrogate=one_bogie, duration=0.2)
    assert env.unwrapped.sim.lpr.relax_z.size == 0 and env.unwrapped.state.shape == (16,)
    static = default_vertical_surrogate("static")
    env = gym.make("railgym/VerticalVehicle-v1", surrogate=static, duration=0.2)
    np.testing.assert_array_equal(env.unwrapped.sim.lpr.coef, static.kernel_arrays()[1])
    assert env.unwrapped.state.shape == (14,)


def test_one_bogie_env_refuses_an_element_with_a_relaxation_law():
    """The whole vehicle's element carries a nonlinear relaxation law that only the whole
    vehicle's kernels integrate: the one-bogie env refuses it, naming the field."""
    from railgym._checks import FieldError
    from railgym.vehicles.vehicle.collect import default_vehicle_surrogate

    with pytest.raises(FieldError, match="surrogate.*relaxation"):
        gym.make("railgym/VerticalSuspension-v1", surrogate=default_vehicle_surrogate())
