"""Components combine: ``railgym combine`` fits one bench-tested damper (a table in mm, mm/s
and kN) with the vehicle file's spring (and bump stops, as known physics) into the element
of ``VerticalSuspension``; the element on the user's vehicle rides as the user's FMU does."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the envs)
from railgym.vehicles.components import combine_damper, spring_force
from railgym.vehicles.vertical.params import load_vehicle
from surrogates import io
from tests.fmu.user_fmu import USER_CAR, USER_MAPPING_YAML, USER_VEHICLE_YAML, user_secondary_force
from tests.fresh_process import BARE_ENV, run_cli

ID = "railgym/VerticalSuspension-v2"
#: the user's car with its spring's progression: the vehicle file gives the spring
CAR = USER_VEHICLE_YAML + f"static_spring:\n  progression: {USER_CAR.progression}\n"
BUMP = """\
bump_stop:
  free_travel_compression: 0.04
  free_travel_rebound: 0.05
  stiffness: 2.0e+6
  cubic_stiffness: 0.0
  smoothing: 0.002
"""


def _damper(dv: np.ndarray) -> np.ndarray:
    """One of the FMU's two dampers, N at m/s: half its secondary force at zero deflection."""
    return 0.5 * user_secondary_force(0.0, dv)


def _bench(path: Path) -> Path:
    """A bench test of one damper over strokes ±40 mm and velocities ±0.3 m/s, in mm, mm/s
    and kN (the force does not depend on the stroke: a pure damper)."""
    rng = np.random.default_rng(1)
    du, dv = rng.uniform(-0.04, 0.04, 800), rng.uniform(-0.3, 0.3, 800)
    rows = "\n".join(
        f"{a * 1e3:.12g},{b * 1e3:.12g},{c * 1e-3:.15g}"
        for a, b, c in zip(du, dv, _damper(dv), strict=True)
    )
    path.write_text("du [mm],dv [mm/s],F [kN]\n" + rows + "\n")
    return path


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``bench.csv``, ``car.yaml`` and ``el.json`` built by ``railgym combine``."""
    folder = tmp_path_factory.mktemp("bench")
    _bench(folder / "bench.csv")
    (folder / "car.yaml").write_text(CAR)
    args = ["combine", "bench.csv", "--vehicle", "car.yaml", "--dampers", "2", "-o", "el.json"]
    done = run_cli(*args, "--quiet", cwd=folder, env=BARE_ENV)
    assert done.returncode == 0, done.stderr
    return folder


def test_the_element_is_the_damper_and_the_vehicles_spring(folder: Path) -> None:
    model = io.load(folder / "el.json")
    doc = json.loads((folder / "el.json").read_text())
    assert model.features_["units"] == {"x1-x2": "m", "v1-v2": "m/s", "F_s": "N"}
    assert model.features_["known_physics"] == []  # the car has no bump stops
    assert doc["metadata"]["vehicle"]["description"]["static_spring"]["progression"] == 30.0
    rng = np.random.default_rng(9)
    u = np.column_stack([rng.uniform(-0.035, 0.035, 400), rng.uniform(-0.25, 0.25, 400)])
    law = user_secondary_force(u[:, 0], u[:, 1])  # the FMU's whole secondary law
    assert np.sqrt(np.mean((model.predict(u) - law) ** 2) / np.mean(law**2)) < 0.005


def test_the_element_rides_as_the_users_fmu(
    folder: Path, user_c_fmu: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Surrogate env (the combined element on car.yaml) against the FMU env, passive, class
    4 and 6: relative RMS carbody acceleration within 3 % (measured 0.7–1.7 %)."""
    monkeypatch.chdir(folder)
    (folder / "map.yaml").write_text(USER_MAPPING_YAML)
    sides = {"surrogate": {"surrogate": "el.json"}}
    sides["fmu"] = {"backend": "fmu", "fmu": user_c_fmu, "fmu_map": "map.yaml"}
    for track_class in (4, 6):
        acc = {}
        for side, kw in sides.items():
            env = gym.make(ID, vehicle="car.yaml", duration=4.0, track_class=track_class, **kw)
            env.reset(seed=1)
            a = []
            for _ in range(400):
                env.step(np.zeros(1, np.float32))
                a.append(env.unwrapped.carbody_acceleration)
            acc[side] = np.array(a)
            env.close()
        err = np.sqrt(np.mean((acc["surrogate"] - acc["fmu"]) ** 2) / np.mean(acc["fmu"] ** 2))
        assert err < 0.03, (track_class, err)
    with pytest.raises(ValueError, match="vehicle is not given"):
        gym.make(ID, surrogate="el.json")


def test_bump_stops_of_the_vehicle_are_known_physics(tmp_path: Path) -> None:
    (tmp_path / "stops.yaml").write_text(CAR + BUMP)
    rng = np.random.default_rng(2)
    u = np.column_stack([rng.uniform(-0.03, 0.03, 300), rng.uniform(-0.3, 0.3, 300)])
    model, _, veh = combine_damper(u, _damper(u[:, 1]), tmp_path / "stops.yaml", dampers=2)
    assert model.features_["known_physics"] == ["bump_stop"]
    spring = spring_force(u[:, 0], veh)
    np.testing.assert_allclose(spring, 4.3e5 * u[:, 0] * (1 + 30.0 * u[:, 0] ** 2))
    law = spring + 2 * _damper(u[:, 1])  # no bump-stop force in the fit: the kernel adds it
    assert np.sqrt(np.mean((model.predict(u) - law) ** 2) / np.mean(law**2)) < 0.01
    env = gym.make(ID, surrogate=model, vehicle=str(tmp_path / "stops.yaml"), duration=1.0)
    env.reset(seed=0)
    env.close()


def test_bad_tables_are_refused(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from agents.commands.combine import main

    (tmp_path / "car.yaml").write_text(CAR)
    assert load_vehicle(tmp_path / "car.yaml").static_spring is not None
    argv = [str(tmp_path / "t.csv"), "--vehicle", str(tmp_path / "car.yaml"), "-o"]
    for header, text in (
        ("du,dv,F", "no unit for column(s) ['du', 'dv', 'F']"),
        ("du [mm],dv [mm],F [kN]", "column 'dv' is in 'mm', which is not a unit of m/s"),
    ):
        (tmp_path / "t.csv").write_text(header + "\n1,2,3\n4,5,6\n")
        assert main([*argv, str(tmp_path / "e.json")]) == 2
        assert text in capsys.readouterr().err
    assert not (tmp_path / "e.json").exists()
