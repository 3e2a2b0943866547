"""The user's vehicle end to end, on FMUs the project did not write (:mod:`tests.fmu.user_fmu`):
map → collect → build → validate → train on the surrogate → evaluate and ``--gap`` on the FMU
→ export the controller → co-simulate it with the user's FMU in a plain FMPy master.

Every command runs in a fresh process and must exit 0. The sizes are small (the path, not the
figures of ``docs/fmi.md``, which ``-m slow`` measures at full size).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import railgym  # noqa: F401  (registers the envs)
from surrogates import io
from tests.fmu.user_fmu import (
    USER_CAR,
    USER_MAPPING_YAML,
    USER_VEHICLE_YAML,
    user_secondary_force,
)

ID = "railgym/VerticalSuspension-v1"


def _run(args: list[str], cwd: Path, timeout: float = 600) -> str:
    """A command in a fresh process in ``cwd``: exit 0 (never an abort at exit), its stdout."""
    res = subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    assert res.returncode == 0, f"{args}: exit {res.returncode}\n{res.stdout}\n{res.stderr}"
    assert "corrupted" not in res.stderr and "Segmentation" not in res.stderr
    return res.stdout


@pytest.fixture(scope="module")
def project(tmp_path_factory, request):
    """A user's folder: their FMU (C or pythonfmu), vehicle file and mapping."""
    folder = tmp_path_factory.mktemp("my_car")
    fmu = request.getfixturevalue(request.param)
    (folder / "my_car.yaml").write_text(USER_VEHICLE_YAML)
    mapping = yaml.safe_load(USER_MAPPING_YAML)
    (folder / "map.yaml").write_text(
        yaml.safe_dump({**mapping, "fmu": str(fmu), "vehicle": "my_car.yaml"}, sort_keys=False)
    )
    return folder


def _collect(folder: Path) -> Path:
    out = folder / "element.json"
    if not out.exists():
        cmd = [sys.executable, "-m", "agents.commands.cli", "collect", "--features", "static"]
        _run([*cmd, "--fmu-map", "map.yaml", "--out", "element.json", "--quiet"], folder)
    return out


@pytest.mark.parametrize("project", ["user_c_fmu", "user_py_fmu"], indirect=True)
def test_the_element_recovers_the_users_secondary_law(project):
    """Collected through the command line with the vehicle from the mapping, no bump-stop
    law subtracted: the element is the FMU's own law within 2 % RMS over the collected range."""
    from railgym.fmu.collect import collect_fmu

    model = io.load(_collect(project))
    assert model.features_["known_physics"] == []
    assert model.features_["units"] == {"x1-x2": "m", "v1-v2": "m/s", "F_s": "N"}
    doc = json.loads((project / "element.json").read_text())
    assert "user_quarter_car" in doc["metadata"]["source"]
    record = doc["metadata"]["vehicle"]  # the vehicle the element runs on (else refused)
    assert record["file"] == str(project / "my_car.yaml")
    assert record["description"]["vehicle"]["m2"] == 8000.0
    assert doc["metadata"]["envelope"]["track_classes"] == [5]  # the paper design's run
    u = collect_fmu(project / "map.yaml", "paper")["U"]
    law = user_secondary_force(u[:, 0], u[:, 1])
    err = np.sqrt(np.mean((model.predict(u) - law) ** 2) / np.mean(law**2))
    assert err < 0.02


@pytest.mark.parametrize("project", ["user_c_fmu"], indirect=True)
def test_the_users_path_from_fmu_to_controller(project, load_example):
    folder = project
    _collect(folder)
    # validate: surrogate env against the FMU env
    table = _run(
        [sys.executable, "-m", "agents.commands.cli", "validate", "--env", "vertical"]
        + ["--element", "element.json", "--backend", "fmu", "--fmu-map", "map.yaml", "--seeds", "2"]
        + ["--track-class", "5", "--duration", "4"],
        folder,
    )
    last = [line for line in table.splitlines() if line.startswith("|")][-1]
    median = float(last.split("|")[4].split("/")[0])
    assert last.split("|")[5].strip() == "0 of 2"  # no diverged track
    assert median < 3.0  # % relative RMS carbody acceleration
    # train on the surrogate (a short run: the path, not the figure)
    config = yaml.safe_load(
        (Path(railgym.__file__).parent / "configs/agents/ppo_vertical_lqg.yaml").read_text()
    )
    block = config["railgym/VerticalSuspension-v3"]
    block.update(n_timesteps=4096, n_envs=8, eval_freq=4096, n_eval_episodes=1, n_steps=256)
    block["env_kwargs"].update(surrogate="element.json", vehicle="my_car.yaml", duration=2.0)
    block["eval_env_kwargs"] = {"backend": "fmu", "fmu_map": "map.yaml", "surrogate": None}
    block.pop("checkpoint_freq")
    (folder / "my_ppo.yaml").write_text(yaml.safe_dump(config))
    _run(
        [sys.executable, "-m", "agents.commands.cli", "train", "my_ppo.yaml", "--quiet"],
        folder,
    )
    zip_path = folder / "runs" / "my_ppo" / "model.zip"
    # evaluate and the transfer gap on the FMU; the LQG is designed for this car
    ev = ["railgym", "evaluate", str(zip_path), "lqg", "--backend", "fmu", "--fmu-map"]
    ev += ["map.yaml", "--track-class", "5", "--episodes", "2"]
    out = _run(ev, folder)
    rows = {line.split()[1]: line.split() for line in out.splitlines() if line[:5].strip() == "5"}
    assert float(rows["lqg"][4]) > 30.0  # Δa_w % against passive on the user's car
    gap = _run([*ev, "--gap", "--surrogate", "element.json"], folder)
    assert "largest |gap| of my_ppo" in gap
    assert gap.startswith("railgym/VerticalSuspension-v2,")  # the FMU's whole tracks, both sides
    # export the residual controller and co-simulate it with the user's FMU
    _run(["railgym", "export-policy", str(zip_path), "-o", "controller.fmu"], folder)
    from agents.policies.loading import load_policy

    factory, env_kwargs, _ = load_policy(str(zip_path))
    env = gym.make(ID, backend="fmu", fmu_map=str(folder / "map.yaml"), duration=2.0)
    ref = load_example("fmu_closed_loop").run_episode(env, factory(env), seed=3)
    got = _master_loop(folder / "controller.fmu", _fmu_of(folder), ref)
    err = np.sqrt(np.mean((got - ref["carbody_acc"]) ** 2) / np.mean(ref["carbody_acc"] ** 2))
    assert err < 0.01


def _fmu_of(folder: Path) -> Path:
    return Path(yaml.safe_load((folder / "map.yaml").read_text())["fmu"])


def _master_loop(controller: Path, vehicle: Path, ref: dict) -> np.ndarray:
    """A plain FMPy master: the user's FMU gives only states; the master forms the
    controller's inputs from them (the mapping's expressions, the bogie acceleration as the
    second-order backward difference of ``v1``) and holds the force over a control step."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    def slave(path: Path, name: str) -> tuple[FMU2Slave, dict]:
        md = read_model_description(str(path))
        s = FMU2Slave(
            guid=md.guid,
            unzipDirectory=extract(str(path)),
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=name,
        )
        s.instantiate()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        return s, {v.name: v.valueReference for v in md.modelVariables}

    car, cv = slave(vehicle, "car")
    ctrl, kv = slave(controller, "controller")
    z, zdot, n_sub, dt = ref["z"], ref["zdot"], ref["n_sub"], ref["dt"]
    names = ["x1", "v1", "x2", "v2", "a2"]
    x1, v1, x2, v2, a2 = car.getReal([cv[n] for n in names])
    v1s = [v1]  # the bogie velocity samples since the reset
    acc = []
    for n in range(ref["carbody_acc"].size):
        if len(v1s) == 1:
            a1 = 0.0
        elif len(v1s) == 2:
            a1 = (v1s[-1] - v1s[-2]) / dt
        else:
            a1 = (3 * v1s[-1] - 4 * v1s[-2] + v1s[-3]) / (2 * dt)
        obs = {"carbody_acc": a2, "bogie_acc": a1, "deflection": x1 - x2}
        obs.update(deflection_rate=v1 - v2, carbody_vel=v2)
        ctrl.setReal([kv[k] for k in obs], list(obs.values()))
        (force,) = ctrl.getReal([kv["actuator_force"]])
        ctrl.doStep(currentCommunicationPoint=n * n_sub * dt, communicationStepSize=n_sub * dt)
        for m in range(n * n_sub, (n + 1) * n_sub):
            car.setReal([cv["zr"], cv["zr_dot"], cv["Fact"]], [z[m], zdot[m], force])
            car.doStep(currentCommunicationPoint=m * dt, communicationStepSize=dt)
            x1, v1, x2, v2, a2 = car.getReal([cv[k] for k in names])
            v1s.append(v1)
        acc.append(a2)
    for s in (car, ctrl):
        s.terminate()
        s.freeInstance()
    return np.array(acc)


def test_the_users_car_is_not_railgyms():
    """The test car differs from the packaged vehicle in every mass and stiffness."""
    from railgym.vehicles.vertical.params import load_vehicle

    ours = load_vehicle("manchester")
    assert (USER_CAR.m1, USER_CAR.m2) != (ours.m1, ours.m2)
    assert USER_CAR.k2 != ours.k2 and USER_CAR.k1 != ours.k1
