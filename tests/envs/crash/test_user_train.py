"""The user's train through ``gym.make``: a scenario file's cars (number, masses, zones) and
speed are the env's, and elements fitted on an FE run of that train (``railgym crash-fe``)
reproduce the run in the env."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the environments)
from agents.commands.crash_fe import main
from railgym.vehicles.crash.fe import (
    crash_result_from_fe,
    crash_surrogate_from_fe,
    load_crash_surrogate,
)
from surrogates import io
from tests.envs.crash.user_train import (
    INTERFACE,
    LEAD,
    PASSENGER,
    SPEED_KMH,
    WALL,
    fe_run,
    write_fe_output,
    write_train,
)

ENV_ID = "railgym/TrainCrash-v1"


@pytest.mark.parametrize("n_cars", [2, 3, 4])
def test_the_env_has_the_scenario_files_cars_and_speed(tmp_path, n_cars):
    path = write_train(tmp_path, n_cars, name=f"train{n_cars}")
    env = gym.make(ENV_ID, scenario=str(path), backend="reference")
    masses = 1e3 * np.array([LEAD["mass_t"]] + [PASSENGER["mass_t"]] * (n_cars - 1))
    assert env.action_space.shape == (n_cars,)  # one absorber per zone: wall + interfaces
    assert env.observation_space.shape == (6 * n_cars,)
    cfg = env.unwrapped.cfg
    assert cfg.scenario.name == f"train{n_cars}" and cfg.scenario.n_cars == n_cars
    absorbers = [WALL["absorber_stroke_mm"]] + [INTERFACE["absorber_stroke_mm"]] * (n_cars - 1)
    np.testing.assert_array_equal(env.unwrapped.absorber_stroke, 1e-3 * np.array(absorbers))
    _, info = env.reset(seed=0)
    np.testing.assert_array_equal(env.unwrapped.car_masses, masses)
    assert env.unwrapped.initial_speed == pytest.approx(SPEED_KMH / 3.6)
    _, _, _, _, info = env.step(np.zeros(n_cars, np.float32))
    assert info["peak_decel_g"].shape == (n_cars,) and info["max_crush_m"].shape == (n_cars,)
    # the same cars in the vector env
    venv = gym.make_vec(
        ENV_ID,
        num_envs=2,
        vectorization_mode="vector_entry_point",
        scenario=str(path),
        backend="reference",
    )
    assert venv.single_action_space.shape == (n_cars,)


def test_the_packaged_trainset_has_its_four_cars_and_an_explicit_value_wins(tmp_path):
    env = gym.make(ENV_ID, scenario="trainset", backend="reference")
    assert env.action_space.shape == (4,)
    assert env.unwrapped.cfg.scenario.speed == pytest.approx(25.0 / 3.6)
    env = gym.make(ENV_ID, scenario="trainset", backend="reference", n_cars=3, speed=10.0)
    assert env.action_space.shape == (3,)
    env.reset(seed=0)
    assert env.unwrapped.initial_speed == pytest.approx(10.0)
    assert env.unwrapped.car_masses.shape == (3,)


@pytest.fixture(scope="module")
def fe_case(tmp_path_factory):
    """The user's 3-car train, its FE-like run (20 masses per car, our own integrator and crush
    law) and that run as nodout/rcforc."""
    folder = tmp_path_factory.mktemp("user_train")
    scenario = write_train(folder)
    run = fe_run()
    nodout, rcforc, ids = write_fe_output(folder, run)
    return scenario, run, nodout, rcforc, ids


def _fe_kwargs(case):
    scenario, _, nodout, rcforc, ids = case
    return {
        "units": "mm-ms-kg-kN",
        "car_nodes": ids,
        "wall_contact": 1,
        "interface_contacts": [2, 3],
        "scenario": scenario,
        "direction": -1.0,
    }


def test_zone_crush_from_centre_of_mass_nodes(fe_case):
    """The zones' own crush recovered from one node per car (at its centre of mass) and the
    contact forces, with the file's carbodies: RMS 0.66 / 0.71 / 0.15 mm from the run's crush
    between the car ends, against 4.0 / 5.8 / 2.9 mm for the centre-of-mass distances."""
    _, run, nodout, rcforc, _ = fe_case
    kw = _fe_kwargs(fe_case)
    units = kw.pop("units")
    res = crash_result_from_fe(
        io.read_nodout(nodout, units=units), io.read_rcforc(rcforc, units=units), **kw
    )
    true = run["crush"][: res.t.size]
    com = np.column_stack([res.x[:, 0], res.x[:, 1] - res.x[:, 0], res.x[:, 2] - res.x[:, 1]])
    rms, rms_com = (np.sqrt(np.mean((c - true) ** 2, axis=0)) for c in (res.crush, com))
    assert np.all(rms < 1e-3) and np.all(rms < 0.2 * rms_com)


def test_elements_from_the_fe_run_reproduce_it_in_the_env(fe_case):
    """Measured: crush 0.9 / 0.7 / 1.9 % and peak deceleration −2.6 / −7.3 / +1.3 % off the
    FE run; the zones' own unloading stiffness −0.04 % (interface) and −2.0 % (wall; −13.5 %
    with the force fitted on the crush, whose reconstruction error, the file's carbody of 6
    row-sum masses against the run's 20 equal masses, diluted the slope)."""
    scenario, run, nodout, rcforc, _ = fe_case
    elements = crash_surrogate_from_fe(nodout, rcforc, **_fe_kwargs(fe_case))
    assert elements.source == "my_train"
    interface, wall = elements.elements["interface"], elements.elements["wall"]
    ku = 1e6 * INTERFACE["unloading_stiffness_kN_per_mm"]
    assert interface.zone_unloading_stiffness == pytest.approx(ku, rel=0.1)
    ku = 1e6 * WALL["unloading_stiffness_kN_per_mm"]
    assert wall.zone_unloading_stiffness == pytest.approx(ku, rel=0.1)
    assert abs(wall.zone_unloading_stiffness - ku) < abs(wall.unloading_stiffness - ku)
    env = gym.make(ENV_ID, scenario=str(scenario), surrogate=elements)
    assert env.action_space.shape == (3,)
    env.reset(seed=0)
    while True:
        _, _, term, trunc, info = env.step(np.zeros(3, np.float32))
        if term or trunc:
            break
    assert not info["diverged"]
    np.testing.assert_allclose(info["max_crush_m"], run["crush"].max(0), rtol=0.05)
    np.testing.assert_allclose(info["peak_decel_g"], (-run["a"]).max(0) / 9.81, rtol=0.10)


def test_crash_fe_command_needs_the_scenario_and_fits_the_unloading_stiffness(
    fe_case, tmp_path, capsys
):
    scenario, _, nodout, rcforc, ids = fe_case
    args = ["--nodout", str(nodout), "--rcforc", str(rcforc), "--unit-system", "mm-ms-kg-kN"]
    args += ["--car-nodes", *map(str, ids), "--wall-contact", "1", "--interface-contacts", "2"]
    args += ["3", "--direction", "-1", "-o", str(tmp_path / "el.json")]
    with pytest.raises(SystemExit) as exc:  # no silent scenario of railgym's
        main(args)
    assert exc.value.code == 2 and "--scenario" in capsys.readouterr().err
    # a scenario of another number of cars than the car nodes: refused, naming both
    assert main([*args, "--scenario", "paper"]) == 2
    err = capsys.readouterr().err
    assert "car_nodes has 3 nodes" in err and "'paper' has 2 cars" in err
    assert main([*args, "--scenario", str(scenario)]) == 0
    out = capsys.readouterr().out
    assert "interface: " in out and "the zone's own" in out
    el = load_crash_surrogate(tmp_path / "el.json").elements["interface"]
    assert el.zone_unloading_stiffness == pytest.approx(120e6, rel=0.1)
    # one mass per car: the element's own k_u holds the carbodies in series (the 0.4 figure)
    assert el.unloading_stiffness < 0.8 * el.zone_unloading_stiffness
