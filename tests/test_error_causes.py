"""Bad input blamed on its real cause, through the entry points a user calls: the profile
length, speed and band of the vertical envs, profile files (units, BOM, folders, encodings)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the envs)

VERTICAL, VEHICLE = "railgym/VerticalSuspension-v1", "railgym/VerticalVehicle-v1"
SPAN = 21.56  # m, wheelset span of the packaged whole vehicle (docs/envs/vehicle_vertical.md)


def _ride(env_id, **kw):
    env = gym.make(env_id, backend="linear", **kw)
    env.reset(seed=0)
    done = False
    while not done:
        obs, _, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape, np.float32))
        done = terminated or truncated
    return obs


def _sine(length, n=3000, amplitude=1e-3):
    x = np.linspace(0.0, length, n)
    return x, amplitude * np.sin(2 * np.pi * x / 7.0)


@pytest.mark.parametrize(("env_id", "extra"), [(VERTICAL, 0.0), (VEHICLE, SPAN)])
def test_a_profile_exactly_as_long_as_documented_runs(env_id, extra):
    length = 30.0 * 2.0 + extra  # speed × duration (+ the wheelset span)
    obs = _ride(env_id, speed=30.0, duration=2.0, profile=_sine(length))
    assert np.isfinite(obs).all()
    with pytest.raises(ValueError, match=rf"too short: .* the run needs {length:.3f} m"):
        _ride(env_id, speed=30.0, duration=2.0, profile=_sine(length - 0.05))


@pytest.mark.parametrize("env_id", [VERTICAL, VEHICLE])
@pytest.mark.parametrize("speed", [1e-9, 0.5, (0.5, 30.0)])
def test_a_tiny_speed_is_blamed_on_the_speed(env_id, speed):
    if env_id == VERTICAL and isinstance(speed, tuple):
        pytest.skip("VerticalSuspension-v1 takes one speed")
    with pytest.raises(ValueError, match=r"^speed must be at least 1 m/s"):
        gym.make(env_id, speed=speed)


def test_a_band_the_vehicle_cannot_sample_is_blamed_on_the_band():
    with pytest.raises(ValueError, match=r"^band shortest wavelength 0\.1 m .* speed 80 m/s"):
        gym.make(VEHICLE, speed=80.0, band=(0.1, 100.0))
    env = gym.make(VEHICLE, speed=80.0, band=(0.33, 100.0), duration=0.1)  # just above 0.32 m
    env.reset(seed=0)
    env = gym.make(VEHICLE, speed=20.0, band=(0.1, 100.0), duration=0.1)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"^band shortest wavelength .* speed 80 m/s"):
        env.reset(seed=0, options={"speed": 80.0})


def _csv(tmp_path, text, encoding="utf-8"):
    path = tmp_path / "track.csv"
    path.write_text(text, encoding=encoding)
    return str(path)


def _rows(x, z):
    return "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(x, z, strict=True))


@pytest.mark.parametrize("env_id", [VERTICAL, VEHICLE])
def test_a_profile_in_millimetres_is_refused(tmp_path, env_id):
    x, z = _sine(100.0, n=401)  # 0.25 m spacing, 1 mm amplitude
    in_mm = _csv(tmp_path, "x,z\n" + _rows(x * 1e3, z * 1e3))
    with pytest.raises(ValueError, match=r"track\.csv: median point spacing 250 m .* in mm"):
        gym.make(env_id, profile=in_mm)
    z_in_mm = _csv(tmp_path, "x,z\n" + _rows(x, 600 * np.sin(x)))
    with pytest.raises(ValueError, match=r"track\.csv: z departs .* at line \d+, above 0\.5 m"):
        gym.make(env_id, profile=z_in_mm)
    header = _csv(tmp_path, "x [mm],z [mm]\n" + _rows(x, z))
    with pytest.raises(ValueError, match=r"track\.csv:1: columns x, z must be in m"):
        gym.make(env_id, profile=header)


def test_a_profile_with_a_byte_order_mark_reads_like_one_without(tmp_path):
    x, z = _sine(100.0, n=401)
    plain = _ride(VERTICAL, speed=30.0, duration=1.0, profile=_csv(tmp_path, _rows(x, z)))
    text = "x,z\n" + _rows(x, z)
    bom = _ride(
        VERTICAL, speed=30.0, duration=1.0, profile=_csv(tmp_path, text, encoding="utf-8-sig")
    )
    np.testing.assert_array_equal(plain, bom)


def test_a_folder_given_as_a_profile_is_called_a_folder(tmp_path):
    with pytest.raises(ValueError, match=r"is a folder, not a CSV file"):
        gym.make(VERTICAL, profile=str(tmp_path))


def test_a_profile_in_another_encoding_names_the_file_and_line(tmp_path):
    path = tmp_path / "track.csv"
    path.write_bytes(b"x,z\n0,0\n1,0\n# \xe9cartement\n")
    with pytest.raises(ValueError, match=r"track\.csv:4: not UTF-8 text"):
        gym.make(VERTICAL, profile=str(path))


# --- multibody tables ----------------------------------------------------------------------
def _table(tmp_path, text: bytes | str):
    path = tmp_path / "bogie.csv"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return path


def test_a_table_with_a_column_named_twice_is_refused(tmp_path):
    from surrogates import io

    path = _table(tmp_path, "t,x,x\n0,1,2\n1,3,4\n")
    with pytest.raises(ValueError, match=r"bogie\.csv: line 1: duplicate column name\(s\) \['x'\]"):
        io.read_table(path)


def test_a_table_in_another_encoding_names_the_file_and_line(tmp_path):
    from surrogates import io

    path = _table(tmp_path, b"t,x [\xb5m]\n0,1\n1,3\n")  # Latin-1 micro sign
    with pytest.raises(ValueError, match=r"bogie\.csv: line 1: not UTF-8 text"):
        io.read_table(path)
    bom = _table(tmp_path, "\ufefft,x\n0,1\n1,3\n".encode())
    assert list(io.read_table(bom).channels) == ["x"]


def test_a_unit_conversion_that_overflows_names_file_line_and_column(tmp_path):
    from surrogates import io

    path = _table(tmp_path, "t,F [kN]\n0,1\n1,1e306\n")
    with pytest.raises(ValueError, match=r"bogie\.csv: line 3: column 'F': 1e\+306 overflows"):
        io.read_table(path)


# --- YAML files ----------------------------------------------------------------------------
def test_a_training_yaml_with_the_env_id_twice_is_refused(tmp_path):
    from agents.training.train_config import load_config

    block = "  algo: ppo\n  policy: MlpPolicy\n  n_timesteps: 100\n"
    path = tmp_path / "twice.yaml"
    path.write_text(
        f"railgym/VerticalSuspension-v1:\n{block}railgym/VerticalSuspension-v1:\n{block}"
    )
    with pytest.raises(ValueError, match=r"twice\.yaml is not valid YAML, line 5: key .* twice"):
        load_config(str(path))


def test_a_vehicle_yaml_with_a_field_twice_is_refused(tmp_path):
    from railgym.vehicles.vertical.params import load_vehicle

    path = tmp_path / "v.yaml"
    path.write_text("vehicle:\n  m1: 1.0\n  m1: 2.0\n")
    with pytest.raises(
        ValueError, match=r"v\.yaml is not valid YAML, line 3: key 'm1' given twice"
    ):
        load_vehicle(str(path))


# --- counts and seeds ----------------------------------------------------------------------
@pytest.mark.parametrize("steps", ["1" + "0" * 30, "10000000000"])
def test_train_timesteps_has_an_upper_bound(capsys, steps):
    from agents.commands.train import main

    with pytest.raises(SystemExit) as info:
        main(["ppo_vertical", "--timesteps", steps])
    assert info.value.code == 2
    assert "--timesteps: must be an integer in 1..1000000000" in capsys.readouterr().err


def test_a_config_with_too_many_timesteps_names_the_field():
    from agents.training.train_config import load_config

    config = {"railgym/VerticalSuspension-v1": {"algo": "ppo", "policy": "MlpPolicy"}}
    config["railgym/VerticalSuspension-v1"]["n_timesteps"] = 10**12
    with pytest.raises(ValueError, match=r"n_timesteps must be .*1000000000"):
        load_config(config)


@pytest.mark.parametrize("seed", [-1, "7", 1.5, True, [1, -2]])
def test_a_bad_seed_is_named(seed):
    from railgym import track
    from surrogates import Kriging
    from surrogates.sampling import select

    match = r"^seed must be None, a non-negative integer or a numpy Generator"
    with pytest.raises(ValueError, match=match):
        track.fra_profile(5, 100.0, 0.05, seed)
    with pytest.raises(ValueError, match=match):
        select(np.random.default_rng(0).random((20, 2)), 5, "random", seed=seed)
    u = np.random.default_rng(0).random((20, 2))
    with pytest.raises(ValueError, match=r"^seed must be"):
        Kriging(seed=seed).fit(u, u.sum(axis=1))


def test_a_float_seed_of_the_vector_env_is_named():
    venv = gym.make_vec(VERTICAL, num_envs=2, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match=r"seed must be None, an int or a list of 2 seeds"):
        venv.reset(seed=1.5)


def test_collect_output_is_not_replaced_without_overwrite(tmp_path, capsys):
    from agents.commands.collect import main

    existing = tmp_path / "element.json"
    existing.write_text("{}")
    with pytest.raises(SystemExit) as info:
        main(["--features", "static", "--out", str(existing)])
    assert info.value.code == 2 and existing.read_text() == "{}"
    assert "exists; pass --overwrite to replace it" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["--out", str(tmp_path / "no" / "element.json")])
    assert "does not exist" in capsys.readouterr().err


# --- command lines and wrong envs ----------------------------------------------------------
def test_refine_out_into_a_missing_folder_fails_before_any_round(tmp_path, capsys):
    from agents.commands.cli import main

    out = tmp_path / "no" / "refined.json"
    code = main(["refine", "skyhook", "--rounds", "1", "--out", str(out)])
    err = capsys.readouterr()
    assert code == 2 and "--out" in err.err and "does not exist" in err.err
    assert "refining" not in err.out  # refused before the work started


def test_evaluate_with_an_empty_address_blames_the_address(capsys):
    from agents.commands.cli import main

    with pytest.raises(SystemExit) as exc:  # refused by the parser (issue 44: no empty value)
        main(["evaluate", "passive", "--address", ""])
    line = capsys.readouterr().err.strip().splitlines()[-1]  # after the usage
    assert exc.value.code == 2 and "--address: is empty" in line and "--workers" not in line


@pytest.mark.parametrize("name", ["Skyhook", "Groundhook", "Passive", "LQR"])
def test_a_vertical_controller_on_the_crash_env_names_the_env(name):
    from agents.controllers import classical as controllers

    with pytest.raises(ValueError, match=r"env must be a railgym VerticalSuspension env"):
        getattr(controllers, name)(gym.make("railgym/TrainCrash-v1"))


@pytest.mark.parametrize("name", ["Skyhook", "Groundhook"])
def test_a_velocity_feedback_on_the_whole_vehicle_names_the_env(name):
    from agents.controllers import classical as controllers

    with pytest.raises(ValueError, match=r"bogie and carbody velocities observed\), got Vert"):
        getattr(controllers, name)(gym.make(VEHICLE))


def test_crash_safety_on_another_railgym_env_is_refused():
    from railgym.wrappers import CrashSafety

    with pytest.raises(ValueError, match=r"CrashSafety summarises crash episodes"):
        CrashSafety(gym.make(VERTICAL))
