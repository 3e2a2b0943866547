"""The cases of issue 44's table (and their kind), each through the door a user takes."""

from __future__ import annotations

import warnings
from importlib.resources import files
from pathlib import Path

import gymnasium as gym
import pytest
import yaml

from agents.commands.cli import main as railgym_main

V1 = "railgym/VerticalSuspension-v1"
WHOLE = "railgym/VerticalVehicle-v1"


def _quiet_make(env_id: str, **kwargs: object) -> gym.Env:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gym.make(env_id, **kwargs)


@pytest.mark.parametrize("options", [["hold"], "hold", ("hold", True)])
def test_reset_options_of_the_wrong_shape_name_options(options: object) -> None:
    env = _quiet_make(V1)
    with pytest.raises(TypeError, match=r"^options must be a mapping"):
        env.reset(seed=0, options=options)


@pytest.mark.parametrize("flag", ["--seeds", "--seed", "--episodes", "--timesteps"])
def test_benchmark_negative_counts_name_the_flag(flag: str, capsys: pytest.CaptureFixture) -> None:
    config = str(Path(__file__).resolve().parents[2] / "configs" / "agents" / "ppo_vertical.yaml")
    with pytest.raises(SystemExit) as exc:
        railgym_main(["benchmark", config, flag, "-1"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {flag}:" in err and "Traceback" not in err


@pytest.mark.parametrize(
    "argv",
    [
        ["evaluate", "passive", "--vehicle", "{folder}"],
        ["evaluate", "passive", "--env", "crash", "--scenario", "{folder}"],
        ["evaluate", "passive", "--vehicle", "{folder}.yaml"],
    ],
)
def test_a_folder_for_a_file_is_named_as_a_folder(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    folder = tmp_path / "my_vehicle"
    folder.mkdir()
    (tmp_path / "my_vehicle.yaml").mkdir()
    assert railgym_main([a.format(folder=folder) for a in argv]) == 2
    assert "is a folder, expected a" in capsys.readouterr().err


def test_a_folder_for_the_damper_element_is_named_as_a_folder(tmp_path: Path) -> None:
    for folder in (tmp_path / "elements", tmp_path / "element.json"):
        folder.mkdir()
        with pytest.raises(ValueError, match=r"^damper_element .* is a folder, expected a file"):
            _quiet_make(V1, actuator="semi-active", damper_element=str(folder))


def _damper_file(tmp_path: Path, factor: float) -> Path:
    text = files("railgym").joinpath("configs", "dampers", "mr_secondary.yaml").read_text()
    doc = yaml.safe_load(text)
    doc["damper"]["c_b"] *= factor
    path = tmp_path / "my_damper.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_the_element_of_another_damper_is_refused(tmp_path: Path) -> None:
    """Issue 44: a damper with 3× the packaged ``c_b`` ran the packaged damper's element."""
    damper = str(_damper_file(tmp_path, 3.0))
    with pytest.raises(ValueError, match=r"^damper_element was built for damper 'mr_secondary'"):
        _quiet_make(V1, actuator="semi-active", damper=damper, damper_element="mr_secondary")
    with pytest.raises(ValueError, match=r"c_b 8000 \(given 24000\)"):
        _quiet_make(WHOLE, actuator="semi-active", damper=damper, damper_element="mr_secondary")
    # the reference backend runs the user's damper itself; the same damper is accepted
    _quiet_make(V1, actuator="semi-active", damper=damper, backend="reference").reset(seed=0)
    same = str(_damper_file(tmp_path, 1.0))
    env = _quiet_make(V1, actuator="semi-active", damper=same, damper_element="mr_secondary")
    env.reset(seed=0)


def test_reference_fmu_of_a_vehicle_block_alone_names_the_missing_section(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """Issue 44: 61 lines of C compiler errors before; now the section, before any C."""
    car = {"m1": 1800.0, "m2": 8000.0, "k1": 2.4e6, "c1": 3.0e4, "k2": 4.3e5, "c2": 1.7e4}
    path = tmp_path / "my_car.yaml"
    path.write_text(yaml.safe_dump({"vehicle": {**car, "gravity": 9.81}}))
    out = tmp_path / "car.fmu"
    assert railgym_main(["export-reference-fmu", "-o", str(out), "--vehicle", str(path)]) == 2
    err = capsys.readouterr().err
    assert "damper section is missing" in err and "my_car.yaml" in err
    assert len(err.strip().splitlines()) == 1 and not out.exists()


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("semi_wheelbase", 20.0, r"semi_wheelbase \(20\.0 m\) must be less than bogie_semi"),
        ("semi_wheelbase", 4.0, r"semi_wheelbase .*beyond the carbody's ends"),
        ("carbody_pitch_inertia", 1e8, r"carbody_pitch_inertia .*exceeds carbody_mass"),
    ],
)
def test_a_whole_vehicle_that_cannot_exist_is_refused_naming_the_field(
    tmp_path: Path, field: str, value: float, message: str
) -> None:
    """Issue 44: ``semi_wheelbase: 20`` (bogies overlap) ran and diverged at t = 0.01 s."""
    folder = files("railgym").joinpath("configs", "vehicles")
    doc = yaml.safe_load(folder.joinpath("manchester_whole.yaml").read_text())
    doc["base"] = str(folder.joinpath("manchester.yaml"))
    doc["whole_vehicle"][field] = value
    path = tmp_path / "coach.yaml"
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(ValueError, match=rf"coach\.yaml: whole_vehicle\.{message}"):
        _quiet_make(WHOLE, vehicle=str(path))
