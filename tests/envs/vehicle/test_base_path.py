"""``base:`` of a whole-vehicle file is read beside that file, through ``gym.make``: from
another working folder, and with a decoy file of the same name in the working folder."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import gymnasium as gym
import pytest

import railgym  # noqa: F401  (registers the envs)
from railgym import _checks as val

ID = "railgym/VerticalVehicle-v2"


def _coach(folder: Path, k2: str) -> Path:
    """``coach_base.yaml`` (the packaged one-bogie coach with secondary stiffness ``k2``) and
    ``coach.yaml`` (the packaged whole vehicle on ``base: coach_base.yaml``) in ``folder``."""
    vehicles = resources.files("railgym") / "configs" / "vehicles"
    one = (vehicles / "manchester.yaml").read_text(encoding="utf-8")
    whole = (vehicles / "manchester_whole.yaml").read_text(encoding="utf-8")
    doc = val.load_yaml(one, "manchester.yaml")
    line = next(x for x in one.splitlines() if x.strip().startswith("k2:"))
    assert float(line.split(":")[1].split("#")[0]) == doc["vehicle"]["k2"]
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "coach_base.yaml").write_text(one.replace(line, f"  k2: {k2}"))
    (folder / "coach.yaml").write_text(whole.replace("base: manchester", "base: coach_base.yaml"))
    return folder / "coach.yaml"


def _k2(vehicle: str) -> float:
    env = gym.make(ID, backend="linear", vehicle=vehicle, duration=1.0)
    k2 = env.unwrapped.cfg.model.suspension.k2
    env.close()
    return k2


def test_base_is_read_beside_the_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    coach = _coach(tmp_path / "cars", "5.5e5")  # a YAML 1.2 float too
    work = tmp_path / "elsewhere"
    work.mkdir()
    monkeypatch.chdir(work)
    assert _k2(str(coach)) == 5.5e5
    assert _k2("../cars/coach.yaml") == 5.5e5


def test_a_decoy_in_the_working_folder_is_not_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    coach = _coach(tmp_path / "cars", "5.5e5")
    _coach(tmp_path, "9.9e5")  # the decoy: another coach_base.yaml in the working folder
    monkeypatch.chdir(tmp_path)
    assert _k2(str(coach)) == 5.5e5
    assert _k2("cars/coach.yaml") == 5.5e5
    assert _k2("coach.yaml") == 9.9e5  # the working folder's own file reads its own base


def test_a_missing_base_names_the_path_beside_the_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    coach = _coach(tmp_path / "cars", "5.5e5")
    (coach.parent / "coach_base.yaml").unlink()
    (tmp_path / "coach_base.yaml").write_text("decoy")  # never read
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError, match=r"cars/coach_base\.yaml' does not exist"):
        gym.make(ID, backend="linear", vehicle="cars/coach.yaml")
