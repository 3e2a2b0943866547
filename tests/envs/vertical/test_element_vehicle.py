"""No silent vehicle: a user's element runs on the vehicle it was built for or is refused,
through ``gym.make``, ``ReferenceShadow`` and ``railgym evaluate --gap``."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the envs)
from railgym.vehicles.collect import save_vertical_surrogate
from railgym.vehicles.vertical.params import load_vehicle
from surrogates import build, io
from tests.fmu.user_fmu import USER_MAPPING_YAML, USER_VEHICLE_YAML, user_secondary_force
from tests.fresh_process import BARE_ENV, run_cli

ID = "railgym/VerticalSuspension-v2"
UNITS = {"delta": "m", "delta_dot": "m/s", "F_s": "N"}


def _fit() -> object:
    """A static element of the user's secondary law (the FMUs' own, no bump stops)."""
    rng = np.random.default_rng(0)
    u = np.column_stack([rng.uniform(-0.03, 0.03, 600), rng.uniform(-0.3, 0.3, 600)])
    model, _ = build(
        u,
        user_secondary_force(u[:, 0], u[:, 1]),
        m=200,
        seed=0,
        candidates=[(3, 5)],
        inputs=["delta", "delta_dot"],
        output="F_s",
        units=UNITS,
    )
    return model


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The user's folder: ``my_car.yaml``, ``el.json`` (built on it, its vehicle recorded as
    ``railgym collect`` records it) and ``bare.json`` (the same element without the record)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "my_car.yaml").write_text(USER_VEHICLE_YAML)
    model = _fit()
    car = load_vehicle("my_car.yaml")
    save_vertical_surrogate(model, None, tmp_path / "el.json", "test", vehicle=(car, "my_car.yaml"))
    io.save(model, tmp_path / "bare.json", units=UNITS)
    return tmp_path


def test_the_element_records_its_vehicle(folder: Path) -> None:
    record = json.loads((folder / "el.json").read_text())["metadata"]["vehicle"]
    assert record["file"] == str(folder / "my_car.yaml")
    assert record["description"]["vehicle"]["m2"] == 8000.0
    assert set(record["description"]) == {"vehicle"}  # no sections railgym's coach has


def test_without_vehicle_the_element_is_refused(folder: Path) -> None:
    with pytest.raises(ValueError, match=r"vehicle is not given.*'user_quarter_car'.*my_car"):
        gym.make(ID, surrogate="el.json")


def test_on_another_vehicle_the_element_is_refused(folder: Path) -> None:
    with pytest.raises(ValueError, match=r"vehicle 'manchester' is not the vehicle.*vehicle\.m1"):
        gym.make(ID, surrogate="el.json", vehicle="manchester")
    (folder / "heavier.yaml").write_text(USER_VEHICLE_YAML.replace("8000.0", "8800.0"))
    with pytest.raises(ValueError, match=r"vehicle\.m2 differ"):
        gym.make(ID, surrogate=io.load("el.json"), vehicle="heavier.yaml")
    with pytest.raises(ValueError, match="user_quarter_car"):
        gym.make("railgym/VerticalVehicle-v2", surrogate="el.json")


def test_on_its_vehicle_the_element_runs(folder: Path, tmp_path_factory) -> None:
    """Any file with the same numbers is the same vehicle (another name, another folder)."""
    other = tmp_path_factory.mktemp("elsewhere") / "renamed.yaml"
    other.write_text(USER_VEHICLE_YAML.replace("user_quarter_car", "renamed"))
    for vehicle in ("my_car.yaml", str(other)):
        env = gym.make(ID, surrogate="el.json", vehicle=vehicle, duration=1.0)
        assert env.unwrapped.cfg.model.m2 == 8000.0
        env.reset(seed=1)
        for _ in range(100):
            obs, *_ = env.step(np.array([0.2], np.float32))
        assert np.all(np.isfinite(obs))
        env.close()


def test_the_whole_vehicle_on_the_elements_suspension_runs_it(folder: Path) -> None:
    """A whole vehicle whose ``base:`` is the element's vehicle (its m2 is half the carbody,
    whatever the one-bogie file says); another base is refused."""
    whole = "base: {}\nwhole_vehicle:\n" + "".join(
        f"  {k}: {v}\n"
        for k, v in {
            "carbody_mass": 3.0e4,
            "carbody_pitch_inertia": 1.5e6,
            "carbody_length": 24.0,
            "bending_frequency": 9.2,
            "bending_damping": 0.02,
            "bending_modal_mass": 2.0e4,
            "bogie_mass": 3600.0,
            "bogie_pitch_inertia": 2000.0,
            "bogie_semi_spacing": 8.5,
            "semi_wheelbase": 1.25,
        }.items()
    )
    (folder / "coach.yaml").write_text(whole.format("my_car.yaml"))
    env = gym.make("railgym/VerticalVehicle-v2", surrogate="el.json", vehicle="coach.yaml")
    assert env.unwrapped.cfg.model.suspension.m2 == 1.5e4
    env.close()
    (folder / "other.yaml").write_text(whole.format("manchester"))
    with pytest.raises(ValueError, match=r"'other.yaml' is not the vehicle.*vehicle\.m1"):
        gym.make("railgym/VerticalVehicle-v2", surrogate="el.json", vehicle="other.yaml")


def test_an_element_without_a_record_runs_on_the_vehicle_given(folder: Path) -> None:
    env = gym.make(ID, surrogate="bare.json", vehicle="my_car.yaml")
    assert env.unwrapped.cfg.model.name == "user_quarter_car"
    env = gym.make(ID, surrogate="bare.json")
    assert env.unwrapped.cfg.model.name == "manchester"


def test_reference_shadow_compares_with_the_users_fmu(folder: Path, user_c_fmu: Path) -> None:
    from railgym.wrappers import ReferenceShadow

    (folder / "map.yaml").write_text(USER_MAPPING_YAML)
    env = gym.make(ID, surrogate="el.json", vehicle="my_car.yaml", duration=1.0, track_class=4)
    env = ReferenceShadow(env, reference_backend="fmu", fmu=user_c_fmu, fmu_map="map.yaml")
    assert "the FMU" in env.compared_against and "'user_quarter_car'" in env.compared_against
    env.reset(seed=2)
    for _ in range(100):
        *_, info = env.step(np.array([0.3], np.float32))
    shadow = info["shadow"]
    assert shadow["reference"] == env.compared_against
    # the element of the FMU's own law on the FMU's car: close to the FMU, not equal
    assert 0.0 < shadow["err_acc"] < 0.05 * shadow["rms_acc_reference"]
    env.close()
    # railgym's reference of a vehicle file without its element sections: refused, named
    env = gym.make(ID, surrogate="el.json", vehicle="my_car.yaml", duration=1.0)
    with pytest.raises(ValueError, match="damper section is missing in vehicle 'user_quarter_car'"):
        ReferenceShadow(env)


def test_gap_with_the_users_element_needs_its_vehicle_and_names_both_sides(
    folder: Path, user_c_fmu: Path
) -> None:
    gap = ["evaluate", "passive", "--gap", "--surrogate", "el.json", "--episodes", "1"]
    gap += ["--track-class", "4"]
    done = run_cli(*gap, cwd=folder, env=BARE_ENV)
    assert done.returncode == 2, done.stderr
    assert "vehicle is not given" in done.stderr and "user_quarter_car" in done.stderr
    (folder / "map.yaml").write_text(
        USER_MAPPING_YAML + f"fmu: {user_c_fmu}\nvehicle: my_car.yaml\n"
    )
    done = run_cli(*gap, "--backend", "fmu", "--fmu-map", "map.yaml", cwd=folder, env=BARE_ENV)
    assert done.returncode == 0, done.stderr
    head = "surrogate (element el.json) vs fmu (the FMU mapping map.yaml) on vehicle my_car.yaml"
    assert head in done.stdout
