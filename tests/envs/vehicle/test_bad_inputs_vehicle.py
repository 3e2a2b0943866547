"""Table of bad inputs to VerticalVehicle-v1, its vector env, the whole-vehicle loader and the
track profiles: each raises the stated error type with a message naming the field."""

from __future__ import annotations

import copy
from importlib import resources

import numpy as np
import pytest
import yaml

from railgym.envs.vehicle.env import VerticalVehicleEnv, VerticalVehicleVectorEnv
from railgym.vehicles.vehicle.params import load_whole_vehicle

RAW = yaml.safe_load(
    resources.files("railgym").joinpath("configs", "vehicles", "manchester_whole.yaml").read_text()
)
SHORT = {"backend": "linear", "duration": 0.1}


def _env(**kw):
    return VerticalVehicleEnv(**kw)


def _venv(**kw):
    return VerticalVehicleVectorEnv(**kw)


def _step(action):
    env = VerticalVehicleEnv(**SHORT)
    env.reset(seed=0)
    env.step(action)


def _vstep(actions):
    venv = VerticalVehicleVectorEnv(num_envs=2, **SHORT)
    venv.reset(seed=0)
    venv.step(actions)


def _reset(options, vector=False):
    env = VerticalVehicleVectorEnv(num_envs=2, **SHORT) if vector else VerticalVehicleEnv(**SHORT)
    env.reset(seed=0, options=options)


def _vehicle_file(tmp_path, edit):
    data = copy.deepcopy(RAW)
    edit(data)
    path = tmp_path / "whole.yaml"
    path.write_text(yaml.safe_dump(data))
    load_whole_vehicle(str(path))


def _set(section, key, value):
    def edit(d):
        d[section][key] = value

    return edit


X = np.arange(0.0, 100.0, 0.5)
V, T = ValueError, TypeError
ROWS = [
    # --- env arguments
    ("backend unknown", lambda p: _env(backend="simpack"), V, "backend"),
    ("backend int", lambda p: _env(backend=3), V, "backend"),
    ("duration string", lambda p: _env(duration="20"), T, "duration"),
    ("duration bool", lambda p: _env(duration=True), T, "duration"),
    ("duration zero", lambda p: _env(duration=0.0), V, "duration"),
    ("duration 1e5", lambda p: _env(duration=1e5), V, "duration"),
    ("duration not a multiple", lambda p: _env(duration=0.015), V, "duration"),
    ("control_dt above 1/60", lambda p: _env(control_dt=0.05), V, "control_dt"),
    ("control_dt negative", lambda p: _env(control_dt=-0.01), V, "control_dt"),
    ("control_dt not a multiple of dt", lambda p: _env(control_dt=0.0105), V, "control_dt"),
    ("dt above control_dt", lambda p: _env(dt=0.02), V, "dt"),
    ("dt bool", lambda p: _env(dt=False), T, "dt"),
    ("f_max nan", lambda p: _env(f_max=float("nan")), V, "f_max"),
    ("f_max 1e300", lambda p: _env(f_max=1e300), V, "f_max"),
    ("f_max string", lambda p: _env(f_max="big"), T, "f_max"),
    ("n_actuators 4", lambda p: _env(n_actuators=4), V, "n_actuators"),
    ("n_actuators float", lambda p: _env(n_actuators=2.0), T, "n_actuators"),
    ("n_actuators bool", lambda p: _env(n_actuators=True), T, "n_actuators"),
    ("observation unknown", lambda p: _env(observation="pixels"), V, "observation"),
    ("sensor_noise negative", lambda p: _env(sensor_noise=-0.1), V, "sensor_noise"),
    ("sensor_noise 1e300", lambda p: _env(sensor_noise=1e300), V, "sensor_noise"),
    ("sensor_noise bool", lambda p: _env(sensor_noise=True), T, "sensor_noise"),
    ("reward_weights list", lambda p: _env(reward_weights=[1, 1, 0.1]), T, "reward_weights"),
    ("reward_weights key", lambda p: _env(reward_weights={"comfort": 1.0}), V, "reward_weights"),
    ("reward weight negative", lambda p: _env(reward_weights={"force": -1}), V, "reward_weights"),
    ("reward weight bool", lambda p: _env(reward_weights={"force": True}), T, "reward_weights"),
    ("acc_weighting unknown", lambda p: _env(acc_weighting="Wx"), V, "acc_weighting"),
    ("band reversed", lambda p: _env(band=(100.0, 1.0)), V, "band"),
    ("band string", lambda p: _env(band="1-100"), T, "band"),
    ("band 1 µm", lambda p: _env(band=(1e-6, 100.0)), V, "band"),
    ("flexible int", lambda p: _env(flexible=1), T, "flexible"),
    ("flexible string", lambda p: _env(flexible="yes"), T, "flexible"),
    ("track_class 9", lambda p: _env(track_class=9), V, "track_class"),
    ("track_class bool", lambda p: _env(track_class=True), V, "track_class"),
    ("speed bool", lambda p: _env(speed=True), T, "speed"),
    ("speed string", lambda p: _env(speed="30"), T, "speed"),
    ("speed negative", lambda p: _env(speed=-3.0), V, "speed"),
    ("speed nan", lambda p: _env(speed=float("nan")), V, "speed"),
    ("speed > 2x class max", lambda p: _env(speed=81.0), V, "speed"),
    ("speed range reversed", lambda p: _env(speed=(50.0, 30.0)), V, "speed"),
    ("speed range of three", lambda p: _env(speed=(30.0, 40.0, 50.0)), V, "speed"),
    ("speed range with a bool", lambda p: _env(speed=(30.0, True)), T, "speed"),
    ("speed_limit negative", lambda p: _env(speed_limit=-1.0), V, "speed_limit"),
    ("render_mode human", lambda p: _env(render_mode="human"), V, "render_mode"),
    ("surrogate object", lambda p: _env(surrogate=object()), T, "surrogate"),
    ("surrogate no file", lambda p: _env(surrogate=str(p / "m.json")), V, "surrogate"),
    ("vehicle unknown", lambda p: _env(vehicle="nosuch"), V, "vehicle"),
    ("vehicle int", lambda p: _env(vehicle=3), T, "vehicle"),
    ("vehicle missing file", lambda p: _env(vehicle=str(p / "no.yaml")), V, "vehicle"),
    # --- track profiles
    ("profile missing file", lambda p: _env(profile=str(p / "no.csv")), V, "profile"),
    ("profile a number", lambda p: _env(profile=3.0), T, "profile"),
    ("profile one array", lambda p: _env(profile=(X,)), T, "profile"),
    ("profile z strings", lambda p: _env(profile=(X, ["0"] * X.size)), T, "profile: z"),
    ("profile x bools", lambda p: _env(profile=(X > 0, X)), T, "profile: x"),
    ("profile z nan", lambda p: _env(profile=(X, np.where(X > 3, np.nan, 0))), V, "profile"),
    ("profile x decreasing", lambda p: _env(profile=(X[::-1], X)), V, "profile"),
    ("profile lengths differ", lambda p: _env(profile=(X, X[:-1])), V, "profile"),
    ("profile too short", lambda p: _reset({"profile": (X[:10], X[:10])}), V, "profile"),
    # --- vector env
    ("num_envs zero", lambda p: _venv(num_envs=0), V, "num_envs"),
    ("num_envs float", lambda p: _venv(num_envs=2.0), T, "num_envs"),
    ("num_envs bool", lambda p: _venv(num_envs=True), T, "num_envs"),
    ("num_envs x duration memory", lambda p: _venv(num_envs=50000, duration=600.0), V, "num_envs"),
    # --- actions
    ("action string", lambda p: _step("abc"), T, "action"),
    ("action bool", lambda p: _step(np.array([True, False])), T, "action"),
    ("action complex", lambda p: _step(np.array([1 + 2j, 0])), T, "action"),
    ("action None", lambda p: _step(None), T, "action"),
    ("action nan", lambda p: _step(np.array([np.nan, 0.0], np.float32)), V, "action"),
    ("action inf", lambda p: _step(np.array([np.inf, 0.0])), V, "action"),
    ("action shape", lambda p: _step(np.zeros(1, np.float32)), V, "action"),
    ("vector actions shape", lambda p: _vstep(np.zeros((3, 2))), V, "actions"),
    ("vector actions bool", lambda p: _vstep(np.ones((2, 2), bool)), T, "actions"),
    ("vector actions nan", lambda p: _vstep(np.full((2, 2), np.nan)), V, "actions"),
    # --- reset options
    ("option unknown", lambda p: _reset({"sped": 3}), V, "reset option"),
    ("option speed bool", lambda p: _reset({"speed": True}), T, "speed"),
    ("option speed below sizing", lambda p: _reset({"speed": 1.0}), V, "speed"),
    ("option track_class 0", lambda p: _reset({"track_class": 0}), V, "track_class"),
    ("option profile a dict", lambda p: _reset({"profile": {"x": X}}), T, "profile"),
    ("vector option speed", lambda p: _reset({"speed": -1.0}, vector=True), V, "speed"),
    (
        "vector reset_mask",
        lambda p: _reset({"reset_mask": np.zeros(2, bool)}, True),
        V,
        "reset_mask",
    ),
    # --- whole-vehicle YAML
    (
        "carbody_mass negative",
        lambda p: _vehicle_file(p, _set("whole_vehicle", "carbody_mass", -1.0)),
        V,
        r"whole\.yaml.*whole_vehicle\.carbody_mass",
    ),
    (
        "bogie_mass string",
        lambda p: _vehicle_file(p, _set("whole_vehicle", "bogie_mass", "heavy")),
        T,
        r"whole_vehicle\.bogie_mass",
    ),
    (
        "semi_wheelbase bool",
        lambda p: _vehicle_file(p, _set("whole_vehicle", "semi_wheelbase", True)),
        T,
        r"whole_vehicle\.semi_wheelbase",
    ),
    (
        "bogie_semi_spacing beyond the carbody",
        lambda p: _vehicle_file(p, _set("whole_vehicle", "bogie_semi_spacing", 20.0)),
        V,
        r"whole_vehicle\.bogie_semi_spacing",
    ),
    (
        "unknown whole_vehicle field",
        lambda p: _vehicle_file(p, _set("whole_vehicle", "roll_inertia", 1.0)),
        V,
        r"whole_vehicle\.roll_inertia",
    ),
    (
        "missing whole_vehicle field",
        lambda p: _vehicle_file(p, lambda d: d["whole_vehicle"].pop("bogie_mass")),
        V,
        r"whole_vehicle\.bogie_mass is missing",
    ),
    (
        "unknown section",
        lambda p: _vehicle_file(p, lambda d: d.update(extra={})),
        V,
        r"whole\.yaml.*extra",
    ),
    (
        "base unknown",
        lambda p: _vehicle_file(p, lambda d: d.update(base="nosuch")),
        V,
        r"whole\.yaml.*vehicle 'nosuch'",
    ),
]


@pytest.mark.parametrize(
    ("call", "error", "field"), [r[1:] for r in ROWS], ids=[r[0] for r in ROWS]
)
def test_bad_input_names_the_field(assert_names_the_field, call, error, field):
    assert_names_the_field(call, error, field)


def test_numpy_scalars_are_accepted_like_python_numbers():
    kw = {"backend": "linear", "speed": np.float32(30.0), "duration": np.float64(0.5)}
    a = VerticalVehicleEnv(n_actuators=np.int64(2), flexible=np.bool_(True), **kw)
    b = VerticalVehicleEnv(backend="linear", speed=30.0, duration=0.5)
    assert a.speeds == b.speeds == (30.0, 30.0) and type(a.speeds[0]) is float
    assert a.cfg.n_steps == b.cfg.n_steps == 50
    ra = VerticalVehicleEnv(backend="linear", speed=(np.int64(30), np.float64(40.0)))
    assert ra.speeds == (30.0, 40.0)
    assert VerticalVehicleVectorEnv(num_envs=np.int64(2), **SHORT).num_envs == 2
    np.testing.assert_array_equal(a.reset(seed=1)[0], b.reset(seed=1)[0])


def test_speed_limit_override_allows_a_faster_run():
    env = VerticalVehicleEnv(backend="linear", speed=90.0, speed_limit=100.0, duration=0.1)
    _, info = env.reset(seed=0)
    assert info["speed"] == 90.0
