"""Table of bad inputs to the vertical env, its vector env, the vehicle and track loaders and
the vertical simulator: each raises the stated error type with a message naming the field."""

from __future__ import annotations

import copy
from importlib import resources

import numpy as np
import pytest
import yaml

from railgym import track
from railgym.envs.vertical.env import VerticalSuspensionEnv, VerticalSuspensionVectorEnv
from railgym.vehicles.vertical.params import load_vehicle, vehicle_from_dict
from railgym.vehicles.vertical.simulate import simulate
from surrogates import LegendreRegression

RAW = yaml.safe_load(
    resources.files("railgym").joinpath("configs", "vehicles", "manchester.yaml").read_text()
)


def _env(**kw):
    return VerticalSuspensionEnv(**kw)


def _venv(**kw):
    return VerticalSuspensionVectorEnv(**kw)


def _lpr3():
    rng = np.random.default_rng(0)
    u = rng.uniform(-1, 1, (40, 3))
    return LegendreRegression(degree=2).fit(u, u.sum(axis=1))


def _step(action, **kw):
    env = VerticalSuspensionEnv(backend="linear", duration=0.1, **kw)
    env.reset(seed=0)
    env.step(action)


def _vstep(actions):
    venv = VerticalSuspensionVectorEnv(num_envs=2, backend="linear", duration=0.1)
    venv.reset(seed=0)
    venv.step(actions)


def _reset(options, vector=False):
    if vector:
        venv = VerticalSuspensionVectorEnv(num_envs=2, backend="linear", duration=0.1)
        venv.reset(seed=0, options=options)
    else:
        VerticalSuspensionEnv(backend="linear", duration=0.1).reset(seed=0, options=options)


X = np.arange(0.0, 100.0, 0.5)  # profile positions, m: covers 0.1 s at 2 × 40 m/s


def _profile_file(tmp_path, text):
    path = tmp_path / "track.csv"
    path.write_text(text)
    VerticalSuspensionEnv(backend="linear", duration=0.1, profile=str(path)).reset(seed=0)


def _vehicle(section, field, value):
    d = copy.deepcopy(RAW)
    if field is None:
        d[section] = value
    else:
        d[section][field] = value
    vehicle_from_dict(d)


def _vehicle_file(tmp_path, text):
    path = tmp_path / "broken.yaml"
    path.write_text(text)
    load_vehicle(str(path))


def _table(tmp_path, old, new):
    text = resources.files("railgym").joinpath("configs", "track", "fra.yaml").read_text()
    assert old in text
    path = tmp_path / "fra.yaml"
    path.write_text(text.replace(old, new, 1))
    track.load_fra_table(path)


def _simulate(**kw):
    args = {
        "variant": "linear",
        "vehicle": load_vehicle(),
        "z": np.zeros(11),
        "zdot": np.zeros(11),
        "dt": 1e-3,
    } | kw
    simulate(**args)


V, T = ValueError, TypeError
ROWS = [
    # --- env arguments
    ("backend unknown", lambda p: _env(backend="simpack"), V, "backend"),
    ("backend int", lambda p: _env(backend=3), V, "backend"),
    ("speed bool", lambda p: _env(speed=True), T, "speed"),
    ("speed string", lambda p: _env(speed="30"), T, "speed"),
    ("speed complex", lambda p: _env(speed=30 + 0j), T, "speed"),
    ("speed negative", lambda p: _env(speed=-3.0), V, "speed"),
    ("speed nan", lambda p: _env(speed=float("nan")), V, "speed"),
    ("speed 1e6", lambda p: _env(speed=1e6), V, "speed"),
    ("speed > 2x class max", lambda p: _env(speed=81.0), V, "speed"),
    ("speed_limit negative", lambda p: _env(speed_limit=-1.0), V, "speed_limit"),
    ("duration 1e5", lambda p: _env(duration=1e5), V, "duration"),
    ("duration zero", lambda p: _env(duration=0.0), V, "duration"),
    ("duration string", lambda p: _env(duration="20"), T, "duration"),
    ("duration bool", lambda p: _env(duration=True), T, "duration"),
    ("duration not a multiple", lambda p: _env(duration=0.015), V, "duration"),
    ("control_dt not a multiple", lambda p: _env(control_dt=0.0105), V, "control_dt"),
    ("control_dt negative", lambda p: _env(control_dt=-0.01), V, "control_dt"),
    ("dt above control_dt", lambda p: _env(dt=0.02), V, "dt"),
    ("dt bool", lambda p: _env(dt=False), T, "dt"),
    ("f_max nan", lambda p: _env(f_max=float("nan")), V, "f_max"),
    ("f_max 1e300", lambda p: _env(f_max=1e300), V, "f_max"),
    ("f_max string", lambda p: _env(f_max="big"), T, "f_max"),
    ("observation unknown", lambda p: _env(observation="pixels"), V, "observation"),
    ("observation None", lambda p: _env(observation=None), V, "observation"),
    ("sensor_noise 1e300", lambda p: _env(sensor_noise=1e300), V, "sensor_noise"),
    ("sensor_noise negative", lambda p: _env(sensor_noise=-0.1), V, "sensor_noise"),
    ("sensor_noise bool", lambda p: _env(sensor_noise=True), T, "sensor_noise"),
    ("reward_weights list", lambda p: _env(reward_weights=[1, 1, 0.1]), T, "reward_weights"),
    ("reward_weights key", lambda p: _env(reward_weights={"comfort": 1.0}), V, "reward_weights"),
    ("reward weight 1e308", lambda p: _env(reward_weights={"force": 1e308}), V, "reward_weights"),
    ("reward weight negative", lambda p: _env(reward_weights={"force": -1}), V, "reward_weights"),
    ("reward weight string", lambda p: _env(reward_weights={"force": "x"}), T, "reward_weights"),
    ("reward weight bool", lambda p: _env(reward_weights={"force": True}), T, "reward_weights"),
    ("acc_weighting unknown", lambda p: _env(acc_weighting="Wx"), V, "acc_weighting"),
    ("acc_weighting None", lambda p: _env(acc_weighting=None), V, "acc_weighting"),
    ("Wk at 20 Hz", lambda p: _env(acc_weighting="Wk", control_dt=0.05), V, "acc_weighting"),
    ("wheelbase negative", lambda p: _env(wheelbase=-2.5), V, "wheelbase"),
    ("wheelbase 1e9", lambda p: _env(wheelbase=1e9), V, "wheelbase"),
    ("band reversed", lambda p: _env(band=(100.0, 1.0)), V, "band"),
    ("band one value", lambda p: _env(band=(1.0,)), V, "band"),
    ("band string", lambda p: _env(band="1-100"), T, "band"),
    ("band 1e9 m", lambda p: _env(band=(1.0, 1e9)), V, "band"),
    ("band 1 µm", lambda p: _env(band=(1e-6, 100.0)), V, "band"),
    ("track_class 9", lambda p: _env(track_class=9), V, "track_class"),
    ("track_class bool", lambda p: _env(track_class=True), V, "track_class"),
    ("track_class string", lambda p: _env(track_class="5"), V, "track_class"),
    ("track_class float", lambda p: _env(track_class=5.0), V, "track_class"),
    ("vehicle unknown", lambda p: _env(vehicle="nosuch"), V, "vehicle"),
    ("vehicle missing file", lambda p: _env(vehicle=str(p / "no.yaml")), V, "vehicle"),
    ("vehicle int", lambda p: _env(vehicle=3), T, "vehicle"),
    ("render_mode human", lambda p: _env(render_mode="human"), V, "render_mode"),
    ("surrogate object", lambda p: _env(surrogate=object()), T, "surrogate"),
    ("surrogate 3 inputs", lambda p: _env(surrogate=_lpr3()), V, "surrogate"),
    ("surrogate no file", lambda p: _env(surrogate=str(p / "m.json")), V, "surrogate"),
    # --- track profiles
    ("profile missing file", lambda p: _env(profile=str(p / "no.csv")), V, "no.csv"),
    ("profile a number", lambda p: _env(profile=3.0), T, "profile"),
    ("profile one array", lambda p: _env(profile=(X,)), T, "profile"),
    ("profile z strings", lambda p: _env(profile=(X, ["0"] * X.size)), T, "profile: z"),
    ("profile x bools", lambda p: _env(profile=(X > 0, X)), T, "profile: x"),
    ("profile z nan", lambda p: _env(profile=(X, np.where(X > 3, np.nan, 0))), V, "index 7"),
    ("profile x inf", lambda p: _env(profile=(np.append(X[:-1], np.inf), X)), V, "not finite"),
    ("profile x decreasing", lambda p: _env(profile=(X[::-1], X)), V, "strictly increasing"),
    ("profile lengths differ", lambda p: _env(profile=(X, X[:-1])), V, "equal length"),
    ("profile 3 points", lambda p: _env(profile=(X[:3], X[:3])), V, "at least 4"),
    ("profile with wheelbase", lambda p: _env(profile=(X, X), wheelbase=2.5), V, "wheelbase"),
    ("profile too short", lambda p: _reset({"profile": (X[:8], X[:8])}), V, "too short"),
    ("profile too short vector", lambda p: _reset({"profile": (X[:8], X[:8])}, True), V, "short"),
    ("profile option a dict", lambda p: _reset({"profile": {"x": X}}), T, "profile"),
    ("profile file nan", lambda p: _profile_file(p, "x,z\n0,0\n1,nan\n2,0\n3,0\n"), V, "line 3"),
    ("profile file x repeated", lambda p: _profile_file(p, "0,0\n1,0\n1,0\n3,0\n"), V, "line 3"),
    ("profile file 3 columns", lambda p: _profile_file(p, "0,0\n1,0,5\n"), V, r"track\.csv:2"),
    ("profile file not a number", lambda p: _profile_file(p, "0,0\n1,a\n"), V, "csv:2: not a"),
    ("profile file too short", lambda p: _profile_file(p, "0,0\n1,0\n2,0\n3,0\n"), V, "short"),
    # --- vector env
    ("num_envs bool", lambda p: _venv(num_envs=True), T, "num_envs"),
    ("num_envs zero", lambda p: _venv(num_envs=0), V, "num_envs"),
    ("num_envs float", lambda p: _venv(num_envs=2.0), T, "num_envs"),
    ("num_envs string", lambda p: _venv(num_envs="4"), T, "num_envs"),
    ("num_envs 1e6", lambda p: _venv(num_envs=10**6), V, "num_envs"),
    (
        "num_envs x control step memory",
        lambda p: _venv(num_envs=60000, duration=600.0, control_dt=0.1, dt=1e-4),
        V,
        "num_envs",
    ),
    # --- actions
    ("action string", lambda p: _step("abc"), T, "action"),
    ("action string array", lambda p: _step(np.array(["0.1"])), T, "action"),
    ("action complex", lambda p: _step(np.array([1 + 2j])), T, "action"),
    ("action bool", lambda p: _step(np.array([True])), T, "action"),
    ("action None", lambda p: _step(None), T, "action"),
    ("action object", lambda p: _step(np.array([object()])), T, "action"),
    ("action nan", lambda p: _step(np.array([np.nan], np.float32)), V, "action"),
    ("action inf", lambda p: _step(np.array([np.inf])), V, "action"),
    ("action shape", lambda p: _step(np.zeros(2, np.float32)), V, "action"),
    ("vector actions shape", lambda p: _vstep(np.zeros((3, 1))), V, "actions"),
    ("vector actions bool", lambda p: _vstep(np.ones((2, 1), bool)), T, "actions"),
    ("vector actions nan", lambda p: _vstep(np.full((2, 1), np.nan)), V, "actions"),
    # --- reset options
    ("option speed 1e6", lambda p: _reset({"speed": 1e6}), V, "speed"),
    ("option speed bool", lambda p: _reset({"speed": True}), T, "speed"),
    ("option track_class 0", lambda p: _reset({"track_class": 0}), V, "track_class"),
    ("option unknown", lambda p: _reset({"foo": 1}), V, "reset option"),
    ("vector option speed", lambda p: _reset({"speed": -1.0}, vector=True), V, "speed"),
    (
        "vector reset_mask",
        lambda p: _reset({"reset_mask": np.zeros(2, bool)}, True),
        V,
        "reset_mask",
    ),
    # --- vehicle descriptions and files
    ("vehicle.m1 bool", lambda p: _vehicle("vehicle", "m1", True), T, "vehicle.m1"),
    (
        "vehicle.gravity inf",
        lambda p: _vehicle("vehicle", "gravity", float("inf")),
        V,
        "vehicle.gravity",
    ),
    ("vehicle.name empty", lambda p: _vehicle("vehicle", "name", ""), T, "vehicle.name"),
    (
        "air_spring.count float",
        lambda p: _vehicle("air_spring", "count", 2.5),
        T,
        "air_spring.count",
    ),
    (
        "air_spring.count bool",
        lambda p: _vehicle("air_spring", "count", True),
        T,
        "air_spring.count",
    ),
    (
        "damper.c_rebound string",
        lambda p: _vehicle("damper", "c_rebound", "x"),
        T,
        "damper.c_rebound",
    ),
    ("damper section a list", lambda p: _vehicle("damper", None, [1, 2]), T, "damper"),
    (
        "bump_stop.smoothing zero",
        lambda p: _vehicle("bump_stop", "smoothing", 0.0),
        V,
        "bump_stop.smoothing",
    ),
    ("unknown section", lambda p: _vehicle("extra", None, {}), V, "extra"),
    ("description a list", lambda p: vehicle_from_dict([1, 2]), T, "vehicle description"),
    (
        "vehicle YAML syntax",
        lambda p: _vehicle_file(p, "vehicle: [1,\n  m1: 2"),
        V,
        r"broken\.yaml.*line",
    ),
    (
        "vehicle YAML field",
        lambda p: _vehicle_file(
            p, yaml.safe_dump({**RAW, "vehicle": {**RAW["vehicle"], "m2": -1.0}})
        ),
        V,
        r"broken\.yaml.*vehicle\.m2",
    ),
    # --- track functions and table
    ("track speed bool", lambda p: track.track_time_input(5, True, 1.0, 0.01, 0), T, "speed"),
    ("track duration huge", lambda p: track.track_time_input(5, 40.0, 1e9, 1e-3, 0), V, "samples"),
    ("track band string", lambda p: track.fra_profile(5, 10.0, 0.05, 0, "wide"), V, "band"),
    ("table A_v inf", lambda p: _table(p, "A_v: 0.6816", "A_v: .inf"), V, r"classes\.3\.A_v"),
    (
        "table verified string",
        lambda p: _table(p, "verified: true", "verified: yes please"),
        T,
        "verified",
    ),
    ("table syntax", lambda p: _table(p, "classes:", "classes: ["), V, r"fra\.yaml.*line"),
    # --- simulate
    ("simulate dt bool", lambda p: _simulate(dt=True), T, "dt"),
    ("simulate sample_every float", lambda p: _simulate(sample_every=1.5), T, "sample_every"),
    ("simulate z strings", lambda p: _simulate(z=["a"] * 11), T, "z"),
    ("simulate x0 shape", lambda p: _simulate(x0=np.zeros(3)), V, "x0"),
    ("simulate force_a complex", lambda p: _simulate(force_a=1j), T, "force_a"),
    ("simulate variant", lambda p: _simulate(variant="quadratic"), V, "variant"),
]


@pytest.mark.parametrize(
    ("call", "error", "field"), [r[1:] for r in ROWS], ids=[r[0] for r in ROWS]
)
def test_bad_input_names_the_field(assert_names_the_field, call, error, field):
    assert_names_the_field(call, error, field)


def test_numpy_scalars_are_accepted_like_python_numbers():
    a = VerticalSuspensionEnv(backend="linear", speed=np.int64(30), duration=np.float32(0.5))
    b = VerticalSuspensionEnv(backend="linear", speed=30, duration=0.5)
    assert a.speed == b.speed == 30.0 and type(a.speed) is float
    assert a.cfg.duration == b.cfg.duration == 0.5 and a.cfg.n_steps == b.cfg.n_steps == 50
    va = VerticalSuspensionVectorEnv(num_envs=np.int64(2), backend="linear", duration=0.5)
    assert va.num_envs == 2
    np.testing.assert_array_equal(a.reset(seed=1)[0], b.reset(seed=1)[0])


def test_speed_limit_override_allows_a_faster_run():
    env = VerticalSuspensionEnv(backend="linear", speed=90.0, speed_limit=100.0, duration=0.1)
    env.reset(seed=0)
    assert env.sim.speed[0] == 90.0


def test_surrogate_for_a_backend_that_ignores_it_warns(recwarn):
    with pytest.warns(UserWarning, match="surrogate is ignored by backend='reference'"):
        VerticalSuspensionEnv(backend="reference", surrogate=_lpr3())


@pytest.mark.parametrize(
    ("kwargs", "error", "field"),
    [
        ({"variant": "quadratic"}, ValueError, "variant"),
        ({"sample_rate": True}, TypeError, "sample_rate"),
        ({"sample_rate": 33.0}, ValueError, "sample_rate"),
        ({"dt": "1ms"}, TypeError, "dt"),
        ({"vehicle": "nosuch"}, ValueError, "vehicle"),
    ],
)
def test_collect_vertical_bad_arguments(kwargs, error, field):
    from railgym.vehicles.collect import collect_vertical

    with pytest.raises(error, match=field):
        collect_vertical(duration=0.1, **kwargs)
