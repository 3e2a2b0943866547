"""Classical controllers on the vertical env: physics of each law, LQR algebra, batching."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from scipy.linalg import expm, solve_continuous_lyapunov

import railgym  # noqa: F401  (registers the envs)
from agents.controllers.classical import LQR, Groundhook, Passive, Skyhook
from railgym.envs.vertical.env import VerticalSuspensionEnv, VerticalSuspensionVectorEnv
from railgym.vehicles.vertical.params import linear_model, load_vehicle
from railgym.vehicles.vertical.simulate import simulate

SEEDS = 4
DURATION = 5.0


def rollout(ctrl_factory, observation: str = "sensors", track_class: int = 5) -> dict:
    """One episode per seed 0..SEEDS-1 in the vector env on the linear backend."""
    env = VerticalSuspensionVectorEnv(
        num_envs=SEEDS,
        backend="linear",
        track_class=track_class,
        duration=DURATION,
        observation=observation,
    )
    ctrl = ctrl_factory(env)
    obs, _ = env.reset(seed=0)
    bogie_sq = np.zeros(SEEDS)
    defl_sq = np.zeros(SEEDS)
    actions, rates = [], []
    for _ in range(env.cfg.n_steps):
        action, state = ctrl.predict(obs, deterministic=True)
        assert state is None
        actions.append(action[:, 0])
        rates.append(env.sim.state[:, 1] - env.sim.state[:, 3])
        obs, _, term, trunc, info = env.step(action)
        assert not term.any()
        bogie_sq += env.sim.acc[:, 0] ** 2
        defl_sq += (env.sim.state[:, 0] - env.sim.state[:, 2]) ** 2
    assert trunc.all()
    n = env.cfg.n_steps
    return {
        "acc": info["rms_carbody_acc"],
        "bogie": np.sqrt(bogie_sq / n),
        "defl": np.sqrt(defl_sq / n),
        "action": np.array(actions),
        "defl_rate": np.array(rates),
    }


@pytest.fixture(scope="module")
def passive() -> dict:
    return rollout(Passive)


def test_passive_is_zero_force(passive):
    assert np.all(passive["action"] == 0.0)
    assert np.all(passive["acc"] > 0.2)  # class 5 at 144 km/h shakes the carbody


def test_skyhook_active_lowers_carbody_acceleration(passive):
    sky = rollout(Skyhook)
    assert np.all(sky["acc"] < 0.9 * passive["acc"]), (sky["acc"], passive["acc"])
    # skyhook damps the body mode, so the suspension travel falls too
    assert np.all(sky["defl"] < passive["defl"])


def test_skyhook_larger_gain_lowers_acceleration_further(passive):
    weak = rollout(lambda e: Skyhook(e, c_sky=1e4))
    strong = rollout(lambda e: Skyhook(e, c_sky=8e4))
    assert np.all(strong["acc"] < weak["acc"])
    assert np.all(weak["acc"] < passive["acc"])
    # zero gain is the passive suspension, step for step
    zero = rollout(lambda e: Skyhook(e, c_sky=0.0))
    np.testing.assert_array_equal(zero["acc"], passive["acc"])


def test_semi_active_skyhook_is_dissipative_and_not_worse(passive):
    semi = rollout(lambda e: Skyhook(e, mode="semi-active"))
    assert np.all(semi["acc"] <= passive["acc"]), (semi["acc"], passive["acc"])
    # a damper pushes the carbody with the sign of δ̇ = ẋ1 − ẋ2: F_a·δ̇ ≥ 0 at every step
    power = semi["action"] * semi["defl_rate"]
    assert power.min() >= 0.0
    on = semi["action"] != 0.0
    assert 0.2 < on.mean() < 0.8  # the clipping is active about half of the time
    # it is never better than the active law with the same gain
    active = rollout(Skyhook)
    assert np.all(active["acc"] < semi["acc"])


def test_groundhook_damps_the_bogie_at_the_carbody_expense(passive):
    gnd = rollout(Groundhook)
    # the bogie gets a damper to ground: its RMS acceleration falls
    assert np.all(gnd["bogie"] < 0.95 * passive["bogie"]), (gnd["bogie"], passive["bogie"])
    # the reaction acts on the carbody: ride comfort gets worse (the classic trade-off)
    assert np.all(gnd["acc"] > passive["acc"])


def test_sensor_and_full_observations_give_the_same_action():
    kw = {"backend": "linear", "duration": 1.0}
    sensors = VerticalSuspensionEnv(observation="sensors", **kw)
    full = VerticalSuspensionEnv(observation="full", **kw)
    for make in (Skyhook, lambda e: Skyhook(e, mode="semi-active"), Groundhook):
        cs, cf = make(sensors), make(full)
        os_, _ = sensors.reset(seed=3)
        of, _ = full.reset(seed=3)
        for _ in range(60):
            a_s, _ = cs.predict(os_)
            a_f, _ = cf.predict(of)
            np.testing.assert_allclose(a_s, a_f, atol=2e-6)
            os_, *_ = sensors.step(a_s)
            of, *_ = full.step(a_s)


def test_linear_model_matches_the_kernel():
    veh = load_vehicle("manchester")
    dt, n = 1e-3, 1500
    x0 = np.array([0.004, -0.05, -0.01, 0.08])
    force = 3000.0
    out = simulate("linear", veh, np.zeros(n + 1), np.zeros(n + 1), dt, force_a=force, x0=x0)
    a, b, c, d = linear_model(veh.kernel_params())
    t = out["t"][-1]
    e = expm(a * t)
    exact = e @ x0 + np.linalg.solve(a, (e - np.eye(4)) @ b[:, 0]) * force
    np.testing.assert_allclose(out["states"][-1], exact, rtol=1e-6, atol=1e-9)
    xe = out["states"][-1]
    assert out["a2"][-1] == pytest.approx(c @ xe + d * force, rel=1e-9)


def lqr_env(**kw) -> VerticalSuspensionEnv:
    return VerticalSuspensionEnv(backend="linear", observation="full", duration=1.0, **kw)


def test_lqr_closed_loop_is_stable_and_optimal():
    ctrl = LQR(lqr_env())
    poles = ctrl.closed_loop_poles()
    assert poles.shape == (4,)
    assert np.all(poles.real < 0)
    assert ctrl.K.shape == (1, 4)
    # cost of a gain K from x0: x0ᵀ·X·x0 with the closed-loop Lyapunov equation, using the
    # true integrand q_a·(Cx + Du)² + q_d·δ² + r·u² (the cross term is part of it)
    a, b, c, d = linear_model(ctrl._base.sim.params)
    c_d = np.array([1.0, 0.0, -1.0, 0.0])

    def cost_matrix(k: np.ndarray) -> np.ndarray:
        acc = c - d * k[0]
        m = ctrl.q_acc * np.outer(acc, acc) + ctrl.q_defl * np.outer(c_d, c_d)
        m += ctrl.r_force * np.outer(k[0], k[0])
        return solve_continuous_lyapunov((a - b @ k).T, -m)

    x_opt = cost_matrix(ctrl.K)
    np.testing.assert_allclose(x_opt, ctrl.P, rtol=1e-6, atol=1e-9 * np.abs(ctrl.P).max())
    rng = np.random.default_rng(0)
    x0s = rng.standard_normal((5, 4)) * [0.01, 0.1, 0.01, 0.1]
    j_opt = np.einsum("ni,ij,nj->n", x0s, x_opt, x0s)
    for _ in range(10):
        dk = ctrl.K * (1 + 0.05 * rng.standard_normal((1, 4)))
        j = np.einsum("ni,ij,nj->n", x0s, cost_matrix(dk), x0s)
        assert np.all(j > j_opt)


def test_lqr_limits():
    env = lqr_env()
    # no state or acceleration weight: the best force is none (the passive plant is stable)
    zero = LQR(env, q_acc=0.0, q_defl=0.0)
    np.testing.assert_allclose(zero.K, 0.0, atol=1e-9)
    passive_poles = np.linalg.eigvals(zero.A)
    np.testing.assert_allclose(
        np.sort_complex(zero.closed_loop_poles()), np.sort_complex(passive_poles)
    )
    # a cheaper force buys more action
    cheap, dear = LQR(env, r_force=1e-9), LQR(env, r_force=1e-7)
    assert np.linalg.norm(cheap.K) > np.linalg.norm(dear.K)


def test_lqr_weights_are_the_env_reward_weights():
    """Without explicit weights the design minimises the env's own reward: its
    ``reward_weights`` scale q_acc, q_defl and r_force; a reward without a force term needs
    ``r_force``."""
    env = lqr_env(reward_weights={"deflection": 2.0})
    default = LQR(lqr_env())
    weighted = LQR(env)
    assert weighted.q_defl == pytest.approx(2.0 * default.q_defl, rel=1e-15)
    assert (weighted.q_acc, weighted.r_force) == (default.q_acc, default.r_force)
    np.testing.assert_array_equal(weighted.K, LQR(lqr_env(), q_defl=weighted.q_defl).K)
    free = lqr_env(reward_weights={"force": 0.0})
    with pytest.raises(ValueError, match="r_force must be positive.*pass r_force"):
        LQR(free)
    assert LQR(free, r_force=default.r_force).r_force == default.r_force


def test_lqr_lowers_carbody_acceleration(passive):
    lqr = rollout(LQR, observation="full")
    assert np.all(lqr["acc"] < 0.8 * passive["acc"]), (lqr["acc"], passive["acc"])


def test_predict_batches_from_make_vec():
    vec = gym.make_vec(
        "railgym/VerticalSuspension-v1",
        num_envs=3,
        vectorization_mode="vector_entry_point",
        backend="linear",
        duration=1.0,
        observation="full",
    )
    single = gym.make(
        "railgym/VerticalSuspension-v1", backend="linear", duration=1.0, observation="full"
    )
    obs, _ = vec.reset(seed=1)
    for _ in range(20):
        obs, *_ = vec.step(np.full((3, 1), 0.3, np.float32))
    for make in (Passive, Skyhook, Groundhook, LQR):
        batch, _ = make(vec).predict(obs)
        assert batch.shape == (3, 1) and batch.dtype == np.float32
        ctrl = make(single)
        for i in range(3):
            one, _ = ctrl.predict(obs[i])
            assert one.shape == (1,) and one.dtype == np.float32
            np.testing.assert_array_equal(one, batch[i])
    # a carbody velocity of 10 m/s asks for 470 kN: the action saturates at −1
    big, _ = Skyhook(vec).predict(np.tile([0, 0, 0, 100.0, 0, 0, 0, 0], (2, 1)))
    np.testing.assert_array_equal(big, -np.ones((2, 1), np.float32))


def test_bad_input_raises():
    sensors = VerticalSuspensionEnv(backend="linear", duration=1.0)
    with pytest.raises(ValueError, match="observation must be 'full'"):
        LQR(sensors)
    with pytest.raises(ValueError, match="observation must be 'full'"):
        LQR(gym.make("railgym/VerticalSuspension-v1", backend="linear"))
    with pytest.raises(ValueError, match="c_sky"):
        Skyhook(sensors, c_sky=-1.0)
    with pytest.raises(ValueError, match="mode"):
        Skyhook(sensors, mode="passive")
    with pytest.raises(ValueError, match="c_gnd"):
        Groundhook(sensors, c_gnd=float("nan"))
    with pytest.raises(ValueError, match="r_force"):
        LQR(lqr_env(), r_force=0.0)
    with pytest.raises(ValueError, match="q_defl"):
        LQR(lqr_env(), q_defl=-1.0)
    with pytest.raises(ValueError, match="observation must have shape"):
        Passive(sensors).predict(np.zeros(8))
    with pytest.raises(ValueError, match="observation has non-finite"):
        Skyhook(sensors).predict(np.full(sensors.observation_space.shape, np.nan))
    with pytest.raises(ValueError, match="env must be a railgym"):
        Passive(gym.make("CartPole-v1"))
