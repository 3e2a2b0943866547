"""A user's vehicle description: only the ``vehicle:`` block, other masses, no bump stops.

Nothing of railgym's vehicle may leak into it: the linear model's modes are the user's, no
bump-stop law is assumed, the nonlinear reference refuses it by name, an element that adds
railgym's bump-stop law is refused, the default controller gains follow its modes, and an
FMU without a vehicle description is an error.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
import yaml

import railgym  # noqa: F401  (registers the envs)
from agents.controllers.classical import Groundhook, Skyhook
from agents.controllers.control_base import DEFAULT_C_GND, DEFAULT_C_SKY
from railgym._checks import resolve_yaml
from railgym.vehicles.memory_element import memory_training_data
from railgym.vehicles.vertical.params import linear_model, load_vehicle, vehicle_from_dict
from railgym.vehicles.vertical.simulate import simulate
from tests.fresh_process import run_cli

#: a user's quarter car (not railgym's Manchester coach)
USER = {"m1": 1800.0, "m2": 8000.0, "k1": 2.4e6, "c1": 3.0e4, "k2": 4.3e5, "c2": 1.7e4}


@pytest.fixture
def user_file(tmp_path):
    path = tmp_path / "my_car.yaml"
    path.write_text(yaml.safe_dump({"vehicle": {**USER, "gravity": 9.81}}))
    return path


def test_a_vehicle_block_alone_is_a_complete_description(user_file):
    veh = load_vehicle(user_file)
    assert veh.name == "my_car"
    assert (veh.bump_stop, veh.damper, veh.air_spring, veh.static_spring) == (None,) * 4
    assert veh.travel == (math.inf, math.inf) and veh.known_physics == ()
    p = veh.kernel_params()
    assert (p.m1, p.m2, p.k1, p.c1, p.k2, p.c2) == tuple(USER.values())
    assert p.k_bs == 0.0 and p.k_bs3 == 0.0
    # no bump-stop force anywhere, however far the deflection goes
    from railgym.vehicles.vertical.elements import bump_stop_force

    assert all(bump_stop_force(d, p) == 0.0 for d in (-1.0, -0.07, 0.0, 0.05, 2.0))


def test_the_linear_model_has_the_users_modes(user_file):
    """Undamped eigenfrequencies of the 2-DOF model against the closed form."""
    veh = load_vehicle(user_file)
    a, _, _, _ = linear_model(veh.kernel_params()._replace(c1=0.0, c2=0.0))
    w = np.sort(np.abs(np.linalg.eigvals(a).imag))[::2]
    m1, m2, k1, k2 = USER["m1"], USER["m2"], USER["k1"], USER["k2"]
    # det(K - w² M) = 0: m1 m2 w⁴ - (m1 k2 + m2 (k1 + k2)) w² + k1 k2 = 0
    b = m1 * k2 + m2 * (k1 + k2)
    disc = math.sqrt(b * b - 4 * m1 * m2 * k1 * k2)
    expected = np.sqrt([(b - disc) / (2 * m1 * m2), (b + disc) / (2 * m1 * m2)])
    np.testing.assert_allclose(w, expected, rtol=1e-12)


def test_the_env_runs_the_users_linear_car_without_contacts(user_file):
    env = gym.make("railgym/VerticalSuspension-v1", backend="linear", vehicle=str(user_file))
    base = env.unwrapped
    assert base.vehicle_params.m2 == USER["m2"]
    assert base.cfg.free_travel == 0.04  # the documented deflection scale (no travel given)
    env.reset(seed=1)
    for _ in range(200):
        obs, reward, *_, info = env.step(np.zeros(1, np.float32))
    assert np.all(np.isfinite(obs)) and info["bump_stop_contacts"] == 0


def test_free_travel_of_a_vehicle_without_bump_stops(tmp_path):
    doc = {"vehicle": {**USER, "gravity": 9.81, "free_travel": 0.03}}
    veh = vehicle_from_dict(doc)
    assert veh.travel == (0.03, 0.03) and veh.deflection_scale == 0.03
    assert veh.kernel_params().k_bs == 0.0
    text, _ = resolve_yaml("manchester", "vehicle", "railgym", ("configs", "vehicles"))
    manchester = yaml.safe_load(text)
    manchester["vehicle"]["free_travel"] = 0.03
    with pytest.raises(ValueError, match="vehicle.free_travel.*without bump stops"):
        vehicle_from_dict(manchester)


def test_the_nonlinear_reference_refuses_a_vehicle_without_its_elements(user_file):
    with pytest.raises(ValueError, match="vehicle.*damper section is missing.*dynamic reference"):
        gym.make("railgym/VerticalSuspension-v1", backend="reference", vehicle=str(user_file))
    with pytest.raises(ValueError, match="damper section is missing.*static reference"):
        simulate("static", load_vehicle(user_file), np.zeros(11), np.zeros(11), 1e-3)


def test_railgyms_element_with_its_bump_stop_law_is_refused_for_the_users_car(user_file):
    """The packaged element adds Manchester's bump stops (known physics): not this car's."""
    with pytest.raises(ValueError, match="surrogate.*bump-stop law.*no bump_stop section"):
        gym.make("railgym/VerticalSuspension-v1", vehicle=str(user_file))


def test_known_physics_follow_the_vehicle(user_file):
    t = np.arange(0.0, 0.5, 1e-3)
    d = 0.06 * np.sin(2 * np.pi * 2 * t)  # beyond Manchester's 40 mm free travel
    run = {"t": t, "delta": d, "delta_dot": np.gradient(d, t), "force": 1e5 * d}
    run["rows"] = np.arange(0, t.size, 5)
    data = {"runs": [run]}
    # the user's car: the element is fitted on the force itself
    _, v_user = memory_training_data(data, 8e-3, vehicle=str(user_file))
    np.testing.assert_array_equal(v_user, run["force"][run["rows"]][t[run["rows"]] >= 0.1])
    # Manchester: the bump-stop law is subtracted where the deflection is past the travel
    _, v_man = memory_training_data(data, 8e-3, vehicle="manchester")
    assert np.any(v_man != v_user)
    with pytest.raises(ValueError, match="known_physics.*not part of vehicle 'my_car'"):
        memory_training_data(data, 8e-3, ("bump_stop",), vehicle=str(user_file))


def test_default_gains_follow_the_vehicles_modes(user_file):
    """Skyhook and groundhook keep the damping ratio of the Manchester design."""
    kw = {"backend": "linear"}
    man = gym.make("railgym/VerticalSuspension-v1", **kw)
    user = gym.make("railgym/VerticalSuspension-v1", vehicle=str(user_file), **kw)
    assert Skyhook(man).c_sky == DEFAULT_C_SKY and Groundhook(man).c_gnd == DEFAULT_C_GND
    ratio_man = DEFAULT_C_SKY / (2 * math.sqrt(8.6e5 * 16000.0))
    ratio_user = Skyhook(user).c_sky / (2 * math.sqrt(USER["k2"] * USER["m2"]))
    assert ratio_user == pytest.approx(ratio_man, rel=1e-12)
    crit_man = 2 * math.sqrt((4.88e6 + 8.6e5) * 2615.0)
    crit_user = 2 * math.sqrt((USER["k1"] + USER["k2"]) * USER["m1"])
    assert Groundhook(user).c_gnd / crit_user == pytest.approx(DEFAULT_C_GND / crit_man)


@pytest.fixture(scope="module")
def reference_fmu(tmp_path_factory):
    """The exported reference FMU and its mapping with the ``vehicle:`` line removed."""
    from agents.commands.cli import main

    out = tmp_path_factory.mktemp("ref") / "vehicle.fmu"
    assert main(["export-reference-fmu", "--env", "vertical", "-o", str(out)]) == 0
    mapping = yaml.safe_load(out.with_suffix(".yaml").read_text())
    assert mapping["vehicle"] == "manchester"  # the export names its vehicle
    del mapping["vehicle"]
    bare = out.with_name("bare.yaml")
    bare.write_text(yaml.safe_dump(mapping))
    return out, bare


def test_an_fmu_env_needs_the_vehicle_of_its_model(reference_fmu):
    fmu, bare = reference_fmu
    with pytest.raises(
        ValueError, match="needs its vehicle description.*vehicle=your_vehicle.yaml"
    ):
        gym.make("railgym/VerticalSuspension-v1", backend="fmu", fmu=str(fmu), fmu_map=str(bare))
    env = gym.make(
        "railgym/VerticalSuspension-v1",
        backend="fmu",
        fmu=str(fmu),
        fmu_map=str(bare),
        vehicle="manchester",
    )
    env.close()
    named = fmu.with_suffix(".yaml")
    with pytest.raises(
        ValueError, match="vehicle=x disagrees with the mapping's vehicle: manchester"
    ):
        gym.make("railgym/VerticalSuspension-v1", backend="fmu", fmu_map=str(named), vehicle="x")


def test_collect_from_an_fmu_without_a_vehicle_names_the_flag(reference_fmu, tmp_path):
    fmu, bare = reference_fmu
    args = ["--fmu-map", str(bare), "--fmu", str(fmu), "--out", str(tmp_path / "e.json")]
    res = run_cli("collect", "--features", "static", *args, timeout=300)
    assert res.returncode == 2
    assert "--vehicle" in res.stderr and "never assumed" in res.stderr
    assert not (tmp_path / "e.json").exists()


def test_lqr_and_lqg_are_designed_on_the_users_car(user_file):
    from agents.controllers.classical import LQR
    from agents.controllers.lqg import LQG

    kw = {"backend": "linear", "vehicle": str(user_file)}
    lqr = LQR(gym.make("railgym/VerticalSuspension-v1", observation="full", **kw))
    a, b, _, _ = linear_model(load_vehicle(user_file).kernel_params())
    np.testing.assert_array_equal(lqr.A, a)
    np.testing.assert_array_equal(lqr.B, b)
    assert np.all(lqr.closed_loop_poles().real < 0)
    lqg = LQG(gym.make("railgym/VerticalSuspension-v1", **kw))
    ours = LQG(gym.make("railgym/VerticalSuspension-v1", backend="linear"))
    assert not np.allclose(lqg.K, ours.K)  # another car, another gain
    np.testing.assert_allclose(lqg.K[:, :4], lqr.K, rtol=1e-12)  # the user's LQR gain
    # the Kalman filter's plant: the user's masses (bogie row of the track-driven model)
    assert lqg.kf.phi.shape == (6, 6) and np.isclose(lqg.kf.c[0, 3], a[3, 3])
