"""Baselines of VerticalVehicle-v1: passive, skyhook per bogie, modal skyhook, LQR."""

import numpy as np
import pytest

from agents.controllers.classical import LQR, BogieSkyhook, ModalSkyhook, Passive, VehicleLQR
from railgym.envs.vehicle.env import VerticalVehicleEnv, VerticalVehicleVectorEnv
from railgym.envs.vertical.env import VerticalSuspensionEnv


def test_shapes_single_and_batch_and_v0_unchanged():
    env = VerticalVehicleEnv(backend="linear", duration=1.0)
    obs, _ = env.reset(seed=0)
    for ctrl in (Passive(env), BogieSkyhook(env), ModalSkyhook(env)):
        a, state = ctrl.predict(obs)
        assert a.shape == (2,) and a.dtype == np.float32 and state is None
        assert ctrl.predict(np.stack([obs] * 3))[0].shape == (3, 2)
    venv = VerticalVehicleVectorEnv(num_envs=3, backend="linear", duration=1.0)
    vobs, _ = venv.reset(seed=0)
    assert BogieSkyhook(venv).predict(vobs)[0].shape == (3, 2)
    v0 = VerticalSuspensionEnv(backend="linear")
    o0, _ = v0.reset(seed=0)
    assert Passive(v0).predict(o0)[0].shape == (1,)
    assert LQR(VerticalSuspensionEnv(backend="linear", observation="full")).K.shape == (1, 4)


def test_skyhooks_from_sensors_and_full_state_agree():
    """The two observation modes decode the same carbody velocities over the bogies."""
    kw = {"backend": "linear", "duration": 1.0}
    sens, full = VerticalVehicleEnv(**kw), VerticalVehicleEnv(observation="full", **kw)
    os_, _ = sens.reset(seed=4)
    of, _ = full.reset(seed=4)
    u = np.array([0.2, -0.4], np.float32)
    for _ in range(30):
        os_, *_ = sens.step(u)
        of, *_ = full.step(u)
    for cls in (BogieSkyhook, ModalSkyhook):
        np.testing.assert_allclose(
            cls(sens).force(np.atleast_2d(os_) * sens.obs_scale),
            cls(full).force(np.atleast_2d(of) * full.obs_scale),
            rtol=1e-5,
            atol=1e-3,
        )


def test_modal_skyhook_splits_bounce_and_pitch():
    env = VerticalVehicleEnv(backend="linear", duration=1.0)
    ctrl = ModalSkyhook(env)
    names = list(env.obs_names)
    x = np.zeros((2, len(names)))
    x[0, [names.index("carbody_vel_front"), names.index("carbody_vel_rear")]] = 0.1, 0.1
    x[1, [names.index("carbody_vel_front"), names.index("carbody_vel_rear")]] = 0.1, -0.1
    f = ctrl.force(x)
    assert f[0, 0] == f[0, 1] == pytest.approx(-0.5 * ctrl.c_bounce * 0.1)
    a = env.vehicle.bogie_semi_spacing
    moment = a * (f[1, 0] - f[1, 1])  # J·θ̈ = a·(F_0 − F_1)
    assert f[1, 0] == -f[1, 1]
    assert moment == pytest.approx(-ctrl.c_pitch * 0.2 / (2 * a))
    assert ctrl.c_bounce == pytest.approx(2 * 0.2 * np.sqrt(2 * 8.6e5 * 32000.0))


def test_lqr_is_stabilising_and_beats_passive_and_skyhook_on_the_linear_model(
    controlled_episode,
):
    kw = {"backend": "linear", "duration": 8.0, "observation": "full"}
    env = VerticalVehicleEnv(**kw)
    lqr = VehicleLQR(env)
    assert lqr.K.shape == (2, 14)
    assert np.max(lqr.closed_loop_poles().real) < 0
    rms = {
        name: controlled_episode(env, ctrl, seed=1)[0]
        for name, ctrl in (("passive", Passive(env)), ("skyhook", BogieSkyhook(env)), ("lqr", lqr))
    }
    assert np.mean(rms["skyhook"]) < np.mean(rms["passive"])
    assert np.all(rms["lqr"] < rms["passive"])
    with pytest.raises(ValueError, match="full"):
        VehicleLQR(VerticalVehicleEnv(backend="linear"))
    with pytest.raises(ValueError, match="VerticalVehicle"):
        BogieSkyhook(VerticalSuspensionEnv(backend="linear"))
