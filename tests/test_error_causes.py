"""Bad input blamed on its real cause, through the entry points a user calls: the profile
length, speed and band of the vertical envs, profile files (units, BOM, folders, encodings)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the envs)

VERTICAL, VEHICLE = "railgym/VerticalSuspension-v0", "railgym/VerticalVehicle-v0"
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
        pytest.skip("VerticalSuspension-v0 takes one speed")
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
