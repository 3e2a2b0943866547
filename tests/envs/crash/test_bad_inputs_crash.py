"""Bad inputs to the crash scenario loader, the crash models and TrainCrash-v1: each is one
clear ``ValueError`` naming the field; numpy scalars are accepted where numbers belong."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest

from railgym.envs.crash.env import TrainCrashEnv, TrainCrashVectorEnv, default_surrogate
from railgym.vehicles.crash.model import crash_model
from railgym.vehicles.crash.scenario import load_scenario, parse_scenario

OBSTACLE = {
    "type": "obstacle",
    "mass_t": 15.0,
    "face_mass_t": 2.0,
    "friction": 0.0,
    "zone": {
        "stroke_mm": [10, 600],
        "force_kN": [400, 400],
        "absorber_stroke_mm": 600,
        "unloading_stiffness_kN_per_mm": 80,
    },
}


@pytest.mark.parametrize(
    "field, value, message",
    [
        # finiteness and range checked before the conversion to SI
        ("cars.lead.mass_t", 1e307, r"crash\.cars\.lead\.mass_t must be in \[1, 1000\]"),
        ("cars.lead.mass_t", 1e-6, r"crash\.cars\.lead\.mass_t must be in"),  # a 1-gram car
        ("cars.passenger.EA_MN", 1e305, r"crash\.cars\.passenger\.EA_MN must be in"),
        ("speed_kmh", 1e200, r"crash\.speed_kmh must be in \[1, 500\]"),
        ("gravity", 1e308, r"crash\.gravity must be in"),
        ("friction", 3.0, r"crash\.friction must be in \[0, 1\]"),
        ("n_cars", 10**6, r"crash\.n_cars must be in \[1, 50\]"),
        ("cars.lead.n_nodes", True, r"crash\.cars\.lead\.n_nodes must be an integer"),
        ("cars.lead.n_nodes", 10_000, r"crash\.cars\.lead\.n_nodes must be in"),
        ("cars.lead.length_m", True, r"crash\.cars\.lead\.length_m must be a number"),
        (
            "zones.wall.force_kN",
            [1e306, 600, 600, 2200, 2200, 3000, 3000],
            r"crash\.zones\.wall\.force_kN\[0\] must be in",
        ),
        (
            "zones.wall.stroke_mm",
            [3, 87, 587, 617, 2050, 2080, 1e300],
            r"crash\.zones\.wall\.stroke_mm\[6\] must be in",
        ),
        (
            "zones.wall.unloading_stiffness_kN_per_mm",
            1e300,
            r"crash\.zones\.wall\.unloading_stiffness_kN_per_mm must be in",
        ),
        (
            "zones.interface.coupler.stiffness_kN_per_mm",
            1e300,
            r"crash\.zones\.interface\.coupler\.stiffness_kN_per_mm must be in",
        ),
        (
            "zones.interface.coupler.slack_mm",
            1e9,
            r"crash\.zones\.interface\.coupler\.slack_mm must be in",
        ),
        (
            "zones.wall.fold_wavelength_mm",
            1e-9,
            r"crash\.zones\.wall\.fold_wavelength_mm must be in",
        ),
        ("barrier", dict(OBSTACLE, face_mass_t=1e-9), r"crash\.barrier\.face_mass_t must be in"),
        ("barrier", dict(OBSTACLE, mass_t=1e307), r"crash\.barrier\.mass_t must be in"),
    ],
)
def test_scenario_numbers_out_of_range_name_the_field(crash_raw, set_field, field, value, message):
    with pytest.raises(ValueError, match=message):
        parse_scenario(set_field(crash_raw(), field, value))


def test_a_chain_too_light_and_stiff_for_a_stable_step_is_rejected(crash_raw):
    raw = crash_raw()
    raw["cars"]["lead"].update(mass_t=1.0, length_m=1.0, n_nodes=100, EA_MN=1e6)
    sc = parse_scenario(raw)  # every field is within its limits ...
    with pytest.raises(ValueError, match=r"stable time step .*crash\.cars\.\*\.mass_t"):
        crash_model(sc, "reference")  # ... but the combination is not


def test_numpy_scalars_in_a_raw_scenario_are_numbers(crash_raw, set_field):
    raw = set_field(crash_raw(), "cars.lead.mass_t", np.float32(30.39))
    raw["n_cars"] = np.int64(3)
    sc = parse_scenario(raw)
    assert sc.n_cars == 3 and sc.lead.mass == pytest.approx(30_390.0, rel=1e-6)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"control_dt": 0.5}, r"control_dt must be in \[1e-06, 0\.01\]"),  # would miss the peaks
        ({"control_dt": 5e-324}, r"control_dt must be in"),  # was an OverflowError
        ({"control_dt": True}, r"control_dt must be a number"),
        ({"control_dt": "0.001"}, r"control_dt must be a number"),
        ({"max_duration": 1e9}, r"max_duration must be at most 60"),
        ({"absorber_range": True}, r"absorber_range must be a number"),
        ({"absorber_range": 1.5}, r"absorber_range must be in \(0, 1\)"),
        ({"absorber_range": np.float32(np.nan)}, r"absorber_range must be finite"),
        ({"absorber_rate": np.inf}, r"absorber_rate must be finite"),
        ({"speed_jitter": 1.0}, r"speed_jitter must be in \[0, 1\)"),
        ({"speed": True}, r"speed must be a number"),
        ({"speed": 1e200}, r"speed must be at most 138\.889"),
        ({"speed": 0.0}, r"speed must be positive"),
        ({"n_cars": True}, r"n_cars must be an integer"),
        ({"n_cars": 2.0}, r"n_cars must be an integer"),
        ({"n_cars": 51}, r"n_cars must be at most 50"),
        ({"reward_weights": {"decel": 1e308}}, r"reward_weights\['decel'\] must be at most"),
        ({"reward_weights": {"intrusion": True}}, r"reward_weights\['intrusion'\] must be a"),
        ({"reward_weights": [1.0, 2.0]}, r"reward_weights must be a mapping"),
        ({"surrogate_variant": "lpr"}, r"surrogate_variant must be one of"),
    ],
)
def test_env_arguments_name_the_field(kwargs, message):
    with pytest.raises(ValueError, match=message):
        TrainCrashEnv(**kwargs)


def test_numpy_scalars_are_accepted_as_env_arguments():
    env = TrainCrashEnv(
        backend="reference",
        absorber_range=np.float32(0.3),
        n_cars=np.int64(2),
        speed=np.float64(10.0),
        control_dt=np.float32(0.005),
        max_duration=np.int64(1),
    )
    assert env.cfg.absorber_range == pytest.approx(0.3) and env.cfg.n_steps == 200
    assert env.cfg.scenario.speed == 10.0


def test_a_surrogate_for_the_wrong_backend_scenario_or_shape_is_rejected():
    paper = default_surrogate(load_scenario("paper"))
    with pytest.raises(ValueError, match=r"surrogate is only used by backend='surrogate'"):
        TrainCrashEnv(backend="reference", surrogate=paper)
    other = dataclasses.replace(paper, source="speed25")
    with pytest.raises(ValueError, match=r"surrogate was built for scenario 'speed25'"):
        TrainCrashEnv(surrogate=other)
    no_interface = dataclasses.replace(paper, elements={"wall": paper.elements["wall"]})
    with pytest.raises(ValueError, match=r"surrogate does not fit .* no 'interface' element"):
        TrainCrashEnv(surrogate=no_interface)
    wall = paper.elements["wall"]
    two_inputs = copy.deepcopy(wall.loading)
    two_inputs.exponents_ = np.zeros((two_inputs.exponents_.shape[0], 2), np.int64)
    elements = {**paper.elements, "wall": dataclasses.replace(wall, loading=two_inputs)}
    bad = dataclasses.replace(paper, elements=elements)
    with pytest.raises(ValueError, match=r"surrogate does not fit .* 2 inputs, expected 1"):
        TrainCrashEnv(surrogate=bad)


@pytest.mark.parametrize(
    "action, message",
    [
        (np.array(["0.5", "0.1"]), "action must hold real numbers"),
        (np.array([0.1 + 1j, 0.0]), "action must hold real numbers"),
        (np.array([True, False]), "action must hold real numbers"),
        ([None, 0.0], "action must hold real numbers"),
        (np.array([np.nan, 0.0]), "action must be finite"),
        (np.zeros(3), r"action must have shape \(2,\)"),
    ],
)
def test_bad_actions_are_rejected_by_step(action, message):
    env = TrainCrashEnv(backend="reference", max_duration=0.01)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        env.step(action)


@pytest.mark.parametrize(
    "actions", [np.full((2, 2), "0.1"), np.ones((2, 2), bool), np.full((2, 2), 1j)]
)
def test_bad_actions_are_rejected_by_the_vector_env(actions):
    venv = TrainCrashVectorEnv(num_envs=2, backend="reference", max_duration=0.01)
    venv.reset(seed=0)
    with pytest.raises(ValueError, match="actions must hold real numbers"):
        venv.step(actions)


def test_extreme_weights_and_actions_keep_every_output_finite():
    env = TrainCrashEnv(backend="surrogate", reward_weights={"decel": 1e6, "intrusion": 1e6})
    env.reset(seed=0)
    rng = np.random.default_rng(1)
    while True:
        obs, r, term, trunc, info = env.step(rng.choice([-1e30, 1e30], 2))
        assert np.isfinite(r) and np.all(np.isfinite(obs))
        values = [v for k, v in info.items() if k != "reward_terms"]
        assert all(np.all(np.isfinite(v)) for v in [*values, *info["reward_terms"].values()])
        assert sum(info["reward_terms"].values()) == pytest.approx(r, rel=1e-12, abs=1e-12)
        if term or trunc:
            break


@pytest.mark.parametrize(
    "kwargs",
    [{"n_cars": 3, "speed": 138.88}, {"n_cars": 50, "speed": 100.0}],
    ids=["3-cars-500-kmh", "50-cars-360-kmh"],
)
def test_default_elements_that_cannot_be_fitted_say_what_they_are_fitted_on(kwargs):
    """No packaged elements fit these trains, so gym.make fits the default ones on a passive
    reference run of the case, which gives no elastic unloading: the error names the case (the
    user gave no training data) and the ways out."""
    import gymnasium as gym

    import railgym  # noqa: F401  (registers the envs)

    with pytest.raises(ValueError) as info:
        gym.make("railgym/TrainCrash-v1", backend="surrogate", **kwargs)
    msg = str(info.value)
    for text in (
        "default surrogate elements",
        "fitted on a passive reference run of this scenario",
        f"n_cars={kwargs['n_cars']}, speed={kwargs['speed']:g} m/s",
        "gives no elastic unloading of the wall element",
        "k_u cannot be estimated",
        "packaged train at a speed within its envelope (packaged: scenario paper (2 cars), "
        "25–50 km/h)",
        "give surrogate= elements",
    ):
        assert text in msg, msg
    assert "the training data hold" not in msg


def test_exporting_no_element_as_an_fmu_names_the_argument(tmp_path):
    from railgym.vehicles.crash.fe import export_crash_element_fmu

    with pytest.raises(TypeError) as info:
        export_crash_element_fmu(None, tmp_path / "e.fmu")
    assert isinstance(info.value, ValueError)
    msg = str(info.value)
    assert msg.startswith("element must be a CrashElement") and "got NoneType" in msg
    assert "elements['wall']" in msg and not (tmp_path / "e.fmu").exists()
