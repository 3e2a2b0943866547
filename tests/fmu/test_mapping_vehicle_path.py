"""``vehicle:`` of an FMU mapping file is read beside that file: from another working folder,
with a decoy file of the same name in the working folder, and a missing file is an error
naming the mapping's ``vehicle`` and the path beside it."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pytest

import railgym  # noqa: F401  (registers the envs)
from railgym.fmu.mapping import FMUError, fmu_vehicle, mapping_vehicle

ID = "railgym/VerticalSuspension-v1"
MAP = "version: 1\nfmu: none.fmu\nvehicle: {vehicle}\nenv: vertical\ninputs: {{}}\noutputs: {{}}\n"


def _mapping(folder: Path, vehicle: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "map.yaml"
    path.write_text(MAP.format(vehicle=vehicle))
    return path


def test_vehicle_is_read_beside_the_mapping_not_from_the_working_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _mapping(tmp_path / "maps", "car.yaml")
    beside = tmp_path / "maps" / "car.yaml"
    beside.write_text("vehicle: {}\n")
    (tmp_path / "car.yaml").write_text("decoy\n")  # never read
    monkeypatch.chdir(tmp_path)
    for got in (mapping_vehicle("maps/map.yaml"), fmu_vehicle("maps/map.yaml")):
        assert Path(got).resolve() == beside.resolve()
    # the same mapping from the mapping's own folder
    monkeypatch.chdir(tmp_path / "maps")
    assert Path(mapping_vehicle("map.yaml")).resolve() == beside.resolve()


def test_a_missing_vehicle_names_the_field_and_the_path_beside_the_mapping(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _mapping(tmp_path / "maps", "car.yaml")
    (tmp_path / "car.yaml").write_text("decoy\n")  # the working folder's file: not taken
    monkeypatch.chdir(tmp_path)
    message = r"^maps/map\.yaml: vehicle 'car\.yaml' .* 'maps/car\.yaml' does not exist"
    with pytest.raises(FMUError, match=message) as err:
        mapping_vehicle("maps/map.yaml")
    assert err.value.field == "vehicle"
    with pytest.raises(FMUError, match=message):  # through the user's door
        gym.make(ID, backend="fmu", fmu_map="maps/map.yaml")


def test_packaged_names_and_absolute_paths_are_as_given(tmp_path: Path) -> None:
    assert mapping_vehicle(_mapping(tmp_path / "a", "manchester")) == "manchester"
    car = tmp_path / "elsewhere" / "car.yaml"
    assert mapping_vehicle(_mapping(tmp_path / "b", str(car))) == str(car)
