"""Policy-aware refinement on the whole vehicle (railgym.vehicles.vehicle.refine,
``railgym refine POLICY --env vehicle``)."""

from __future__ import annotations

import numpy as np
import pytest

from agents.commands.cli import main
from agents.commands.refine import vehicle_observation_map
from railgym.envs.vehicle.env import VerticalVehicleEnv
from railgym.vehicles.refinement import RefineOptions
from railgym.vehicles.vehicle.collect import VehicleDesign, collect_vehicle
from railgym.vehicles.vehicle.lanes import hermite
from railgym.vehicles.vehicle.model import N_MECH
from railgym.vehicles.vehicle.refine import RAW_VEHICLE_OBSERVATION, refine_vehicle
from surrogates import io
from surrogates.models.lpr import LegendreRegression


@pytest.mark.parametrize("observation", ["sensors", "full"])
def test_observation_map_reproduces_the_env_observation(observation):
    """The raw vector the refinement loop builds, mapped, equals the env's own observation."""
    env = VerticalVehicleEnv(backend="reference", observation=observation, track_class=4)
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(30):
        obs, *_ = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
    bt, out = env.sim.arrays, env.sim.out
    raw = np.zeros(len(RAW_VEHICLE_OBSERVATION))
    raw[:N_MECH] = bt.state[0, :N_MECH]
    raw[N_MECH : N_MECH + 5] = out.acc[0]
    for j in range(4):
        raw[N_MECH + 5 + j], raw[N_MECH + 9 + j] = hermite(
            bt.z[0], bt.zdot[0], bt.k[0] + bt.off[0, j], env.cfg.dt
        )
    np.testing.assert_allclose(vehicle_observation_map(env)(raw), obs, rtol=1e-6, atol=1e-7)


def pumping(raw):
    """Positive feedback of the carbody velocity over each bogie: drives the element out of a
    gentle passive run's data."""
    vel = raw[7] + np.array([9.5, -9.5]) * raw[8]
    return np.clip(80.0 * vel, -1.0, 1.0)


def test_held_out_error_falls_after_refinement_on_the_whole_vehicle():
    design = VehicleDesign(track_classes=(6,), speeds=(25.0,), duration=4.0, f_max=0.0)
    runs = collect_vehicle(design)["runs"]
    U = np.concatenate([np.column_stack([r["delta"], r["delta_dot"]])[r["rows"]] for r in runs])
    V = np.concatenate([r["force"][r["rows"]] for r in runs])
    model = LegendreRegression(degree=(5, 5)).fit(U, V)
    lines = []
    options = RefineOptions(duration=4.0, n_tracks=1, n_holdout=2, n_add=300)
    kw = dict(data=(U, V), options=options, log=lines.append)
    refined, hist = refine_vehicle(model, pumping, rounds=1, **kw)
    assert [h["round"] for h in hist] == [0, 1] and len(lines) == 2
    assert hist[0]["ood"] > 0 and hist[1]["ood"] < hist[0]["ood"]
    assert hist[1]["error"] < 0.8 * hist[0]["error"]
    assert hist[1]["n_samples"] == V.size + 300 and refined is not model
    assert hist[0]["errors"].shape == (3,)


def test_refine_command_on_the_vehicle_writes_a_loadable_element(tmp_path, capsys):
    out = tmp_path / "refined.json"
    args = ["refine", "modal-skyhook", "--env", "vehicle", "--rounds", "1", "--duration", "1"]
    assert main([*args, "--tracks", "1", "--add", "50", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "whole vehicle" in text and "round 1:" in text and "front / centre / rear" in text
    element = io.load(out)
    assert element.features_["form"] == "maxwell" and element.n_features_in_ == 3
    assert main([*args, "--out", str(out)]) != 0  # no overwrite without --overwrite


def test_refine_command_refuses_an_fmu_reference_for_the_vehicle(tmp_path, capsys):
    args = ["refine", "passive", "--env", "vehicle", "--fmu-map", str(tmp_path / "map.yaml")]
    assert main(args) != 0
    assert "--env vertical" in capsys.readouterr().err
