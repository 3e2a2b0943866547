"""``VerticalSuspension-v1`` with ``actuator="semi-active"``: the action is the command of the
controllable damper of :mod:`railgym.vehicles.semi_active`, integrated with the vehicle."""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the environments)
from railgym._checks import FieldError
from railgym.envs.vertical.env import VerticalSuspensionEnv
from railgym.vehicles.semi_active import load_damper, simulate_damper
from railgym.vehicles.vertical.params import load_vehicle
from railgym.vehicles.vertical.simulate import simulate

ENV_ID = "railgym/VerticalSuspension-v1"
SEMI = {"actuator": "semi-active"}
DAMPER = load_damper("mr_secondary")


def _velocity(env: gym.Env) -> float:
    """Damper extension rate ``ẋ1 − ẋ2`` of a single env, m/s."""
    x = env.unwrapped.state
    return float(x[1] - x[3])


@pytest.mark.parametrize("backend", ["linear", "reference", "surrogate"])
def test_make_and_make_vec_agree_step_for_step(backend, semi_active_vector_equals_singles):
    """``gym.make`` and the native vector env of ``gym.make_vec`` give the same observations,
    rewards and damper forces (sub-env ``i`` seeded ``s + i``), the damper command last."""
    kw = {"backend": backend, "duration": 0.3, **SEMI}
    keys = ("damper_force", "damper_command", "actuator_force")
    infos = semi_active_vector_equals_singles(ENV_ID, kw, 1, keys)
    for info_v in infos:
        np.testing.assert_array_equal(info_v["damper_force"], info_v["actuator_force"])
    assert np.abs(infos[-1]["damper_force"]).max() > 10.0  # the damper works


def test_damper_only_dissipates(random_commands):
    """Over an episode of random commands every step's damper power ``F·v`` is ≥ 0 and the
    dissipated energy ``Σ F·v·dt`` is positive."""
    env = gym.make(ENV_ID, backend="reference", duration=4.0, **SEMI)
    powers = np.array(
        [info["damper_force"] * _velocity(env) for _, info in random_commands(env, 1)]
    )
    assert len(powers) == 400 and powers.min() >= 0.0
    energy = powers.sum() * env.unwrapped.cfg.control_dt
    assert energy > 1.0  # J over 4 s


def test_damper_force_matches_simulate_damper_on_the_recorded_velocity():
    """Stepping at the integration rate (``control_dt = dt``), the env's damper force and
    filtered command equal :func:`simulate_damper` driven by the recorded extension rate and
    the same held commands: the command filter exactly, the force within the error of the
    velocity interpolated linearly between samples."""
    dt = 1e-3
    env = gym.make(ENV_ID, backend="linear", duration=1.0, control_dt=dt, dt=dt, **SEMI)
    env.reset(seed=5)
    rng = np.random.default_rng(6)
    commands = np.repeat(rng.uniform(0, 1, 20), 50)  # held 50 ms each
    p = env.unwrapped.vehicle_params
    v, force, u = [0.0], [0.0], [0.0]
    for c in commands:
        _, _, _, _, info = env.step(np.array([c], np.float32))
        x = env.unwrapped.state
        v.append(_velocity(env))
        force.append(info["damper_force"])
        u.append(info["damper_command"])
        # the damper pushes the carbody in the direction of v: m2·ẍ2 = k2·δ + c2·δ̇ + F
        f_s = p.k2 * (x[0] - x[2]) + p.c2 * (x[1] - x[3])
        assert info["carbody_acc"] == pytest.approx((f_s + force[-1]) / p.m2, rel=1e-12)
    held = np.append(commands.astype(np.float32).astype(np.float64), 0.0)
    ref_force, ref_states = simulate_damper(np.array(v), held, dt, DAMPER)
    np.testing.assert_allclose(u, ref_states[:, 0], rtol=0, atol=1e-12)
    scale = np.abs(ref_force).max()
    assert scale > 500.0
    np.testing.assert_allclose(force, ref_force, rtol=0, atol=1e-3 * scale)


def test_command_filter_is_first_order_with_the_damper_bandwidth():
    """A command step from rest: ``u(t) = 1 − exp(−η t)`` (η of the damper file)."""
    env = gym.make(ENV_ID, backend="linear", duration=0.2, **SEMI)
    env.reset(seed=0)
    u = [env.step(np.ones(1, np.float32))[4]["damper_command"] for _ in range(20)]
    t = 0.01 * np.arange(1, 21)
    np.testing.assert_allclose(u, 1.0 - np.exp(-DAMPER.eta * t), rtol=1e-6)


def test_command_changes_the_ride_and_force_mode_is_the_passive_vehicle():
    """Command 1 against 0 on the same class-4 track: several times the damper force, less
    suspension velocity, another carbody acceleration; the force mode with action 0 is the
    passive vehicle of :func:`simulate` bit for bit."""

    def episode(command=0.0, **kwargs):
        env = gym.make(ENV_ID, backend="reference", track_class=4, duration=2.0, **kwargs)
        env.reset(seed=9)
        rec, action = [], np.full(1, command, np.float32)
        for _ in range(200):
            info = env.step(action)[4]
            rec.append((info["carbody_acc"], _velocity(env), info["actuator_force"]))
        return env, np.array(rec).T

    def rms(x):
        return float(np.sqrt(np.mean(x**2)))

    _, soft = episode(actuator="semi-active", command=0.0)
    _, hard = episode(actuator="semi-active", command=1.0)
    passive_env, passive = episode()
    assert rms(hard[2]) > 4.0 * rms(soft[2])
    assert rms(hard[1]) < 0.9 * rms(soft[1])
    assert rms(hard[0] - soft[0]) > 0.2 * rms(soft[0])
    assert not passive[2].any()
    z, zdot = passive_env.unwrapped.track()
    cfg = passive_env.unwrapped.cfg
    rec = simulate("dynamic", load_vehicle("manchester"), z, zdot, cfg.dt, sample_every=cfg.n_sub)
    np.testing.assert_array_equal(passive[0], rec["a2"][1:201])


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"actuator": "foo"}, "actuator"),
        ({"actuator": "semi-active", "damper": "missing"}, "damper"),
        ({"actuator": "semi-active", "damper": "no/such/damper.yaml"}, "damper"),
        ({"actuator": "semi-active", "damper": 3}, "damper"),
        ({"damper": "missing"}, "damper"),  # a damper without the semi-active actuator
    ],
)
def test_bad_arguments_name_the_field(kwargs, field):
    with pytest.raises(FieldError, match=field):
        gym.make(ENV_ID, **kwargs)


def test_damper_yaml_field_errors_name_file_and_field(tmp_path):
    text = (
        "damper:\n  name: x\n  c_a: 2000.0\n  c_b: 8000.0\n  f_a: 200.0\n  f_b: 3000.0\n"
        "  x_y: -0.002\n  sigma: 0.5\n  n: 2.0\n  eta: 50.0\n"
    )
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(FieldError, match="x_y"):
        gym.make(ENV_ID, damper=str(path), **SEMI)


def test_actions_are_clipped_to_the_command_range():
    """Commands outside [0, 1] are clipped (as force actions are to [−1, 1]); NaN raises."""

    def run(value):
        env = VerticalSuspensionEnv(backend="linear", duration=0.2, **SEMI)
        env.reset(seed=1)
        return [env.step(np.array([value]))[0] for _ in range(20)]

    np.testing.assert_array_equal(run(7.0), run(1.0))
    np.testing.assert_array_equal(run(-2.0), run(0.0))
    env = VerticalSuspensionEnv(duration=0.2, **SEMI)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.nan], np.float32))


@pytest.mark.parametrize("observation", ["sensors", "full"])
@pytest.mark.parametrize("actuator", ["force", "semi-active"])
def test_obs_names_name_every_channel(observation, actuator):
    env = gym.make(ENV_ID, backend="linear", observation=observation, actuator=actuator)
    names = env.unwrapped.obs_names
    assert len(names) == env.observation_space.shape[0] == len(env.unwrapped.obs_scale)
    assert ("damper_command" in names) == (actuator == "semi-active")
    if actuator == "semi-active":
        assert names[-1] == "damper_command"
        env.reset(seed=0)
        for _ in range(5):
            obs, _, _, _, info = env.step(np.ones(1, np.float32))
        assert obs[-1] == np.float32(info["damper_command"]) and 0.0 < obs[-1] < 1.0
        assert len(env.unwrapped.state) == 4 + 2  # linear vehicle, then the damper's u, w


def test_copy_and_render_in_semi_active_mode():
    """A deep copy continues bit for bit; the frame draws the damper force on the gauge."""
    env = VerticalSuspensionEnv(render_mode="rgb_array", duration=0.5, **SEMI)
    env.reset(seed=3)
    for _ in range(10):
        env.step(np.full(1, 0.7, np.float32))
    twin = copy.deepcopy(env)
    for _ in range(10):
        a, b = env.step(np.full(1, 0.2, np.float32)), twin.step(np.full(1, 0.2, np.float32))
        np.testing.assert_array_equal(a[0], b[0])
        assert a[4]["damper_force"] == b[4]["damper_force"]
    frame = env.render()
    assert frame.shape == (400, 600, 3) and frame.dtype == np.uint8


def test_reward_force_term_uses_the_damper_force():
    env = gym.make(ENV_ID, backend="linear", duration=0.5, **SEMI)
    env.reset(seed=4)
    for _ in range(20):
        _, _, _, _, info = env.step(np.ones(1, np.float32))
    cfg = env.unwrapped.cfg
    want = -cfg.reward_weights["force"] * (info["damper_force"] / cfg.f_max) ** 2
    assert info["reward_terms"]["force"] == pytest.approx(want, rel=1e-12) and want < 0.0
