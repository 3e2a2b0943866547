"""``railgym export-policy``: a trained SB3 policy as a C co-simulation FMU and as ONNX.

Round trips on 10⁴ observations: FMU output (through FMPy) and ONNX output (onnxruntime) =
``policy.predict(obs, deterministic=True)`` × f_max, for PPO and SAC policies as
:func:`agents.training.train.train` writes them (a few hundred steps of training).
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from agents.commands.cli import main
from tests.markers import needs_cc

pytest.importorskip("stable_baselines3")
fmpy = pytest.importorskip("fmpy", reason="the 'fmi' extra (fmpy) is not installed")
pytestmark = needs_cc
ID = "railgym/VerticalSuspension-v1"
BLOCKS = {
    "ppo": {
        "n_steps": 64,
        "batch_size": 64,
        "n_epochs": 1,
        # default init of the action layer (not SB3's 0.01 gain): forces of a few kN
        "policy_kwargs": {"net_arch": [16, 8], "ortho_init": False},
    },
    "sac": {
        "learning_starts": 64,
        "batch_size": 32,
        "buffer_size": 1000,
        "policy_kwargs": {"net_arch": [16, 8]},
    },
}


@pytest.fixture(scope="module", params=["ppo", "sac"])
def trained(request, tmp_path_factory):
    """(run folder, algo) of a tiny policy trained by agents.training.train."""
    from agents.training.train import train

    algo = request.param
    block = {
        "algo": algo,
        "n_timesteps": 256,
        "n_envs": 2,
        "seed": 0,
        "env_kwargs": {"backend": "linear", "duration": 1.0, "f_max": 6000.0},
        "eval_freq": 10**6,
        "n_eval_episodes": 1,
        "checkpoint_freq": 10**6,
        **BLOCKS[algo],
    }
    out = train({ID: block}, tmp_path_factory.mktemp(algo) / f"{algo}_run", progress=False)
    return out, algo


def _observations(n: int, seed: int = 0) -> np.ndarray:
    """``n`` normalised observations spread over and beyond the ride's range."""
    return np.random.default_rng(seed).normal(0.0, 1.5, (n, 5)).astype(np.float32)


def _predict_forces(run, obs):
    from agents.policies.loading import load_policy

    factory, env_kwargs, _ = load_policy(str(run / "model.zip"), ID)
    assert env_kwargs["f_max"] == 6000.0
    action, _ = factory(None).predict(obs, deterministic=True)
    return np.clip(action, -1, 1).astype(float) * 6000.0


def _fmu_forces(fmu_path, names, obs_si):
    return _fmu_outputs(fmu_path, names, obs_si, ["actuator_force"])[:, 0]


def _fmu_outputs(fmu_path, names, obs_si, outputs):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(
        guid=md.guid,
        unzipDirectory=extract(str(fmu_path)),
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="controller",
    )
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    ins, outs = [vr[n] for n in names], [vr[n] for n in outputs]
    out = np.empty((len(obs_si), len(outputs)))
    for i, row in enumerate(obs_si):
        fmu.setReal(ins, row.tolist())
        fmu.doStep(currentCommunicationPoint=i * 0.01, communicationStepSize=0.01)
        out[i] = fmu.getReal(outs)
    fmu.terminate()
    fmu.freeInstance()
    return out


def test_policy_fmu_and_onnx_reproduce_predict(trained, tmp_path):
    import gymnasium as gym
    from fmpy.validation import validate_fmu

    run, algo = trained
    fmu, onnx_path = tmp_path / "controller.fmu", tmp_path / "controller.onnx"
    args = ["export-policy", str(run / "model.zip"), "-o", str(fmu)]
    have_onnx = True
    try:
        import onnxruntime  # noqa: F401
    except ImportError:
        have_onnx = False
    assert main(args + (["--onnx", str(onnx_path)] if have_onnx else [])) == 0
    assert validate_fmu(str(fmu)) == []
    env = gym.make(ID, f_max=6000.0).unwrapped
    names, scale = list(env.obs_names), env.obs_scale
    md = fmpy.read_model_description(str(fmu))
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    assert [v.name for v in inputs] == names  # the env's channels, in its order
    assert [v.unit for v in inputs] == ["m/s2", "m/s2", "m", "m/s", "m/s"]
    obs = _observations(10_000)
    # SI values whose float32 normalisation is exactly the observation given to predict
    obs_si = obs.astype(float) * scale
    expected = _predict_forces(run, obs)[:, 0]
    assert np.ptp(expected) > 100.0  # the policy's force varies over these observations
    got = _fmu_forces(fmu, names, obs_si)
    assert np.max(np.abs(got - expected)) <= 1e-5 * 6000.0
    big = np.abs(expected) > 60.0
    assert np.all(np.abs(got - expected)[big] <= 1e-5 * np.abs(expected[big]))
    if algo == "sac":  # squashed: the FMU stays within ±f_max
        assert np.all(np.abs(got) <= 6000.0)
    if have_onnx:
        import onnxruntime as ort

        sess = ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
        (onnx_out,) = sess.run(None, {"observation": obs_si})
        assert onnx_out.shape == (10_000, 1)
        assert np.max(np.abs(onnx_out[:, 0] - expected)) <= 1e-5 * 6000.0
    # outputs are not overwritten; a missing zip is a user error (exit status 2)
    assert main(args) == 2
    assert main(["export-policy", str(run / "nope.zip"), "-o", str(tmp_path / "x.fmu")]) == 2


def test_export_policy_refuses_a_zip_not_in_the_manifest(trained, tmp_path, capsys):
    run, _ = trained
    copy = tmp_path / "run"
    shutil.copytree(run, copy)
    (copy / "manifest.json").unlink()
    out = tmp_path / "c.fmu"
    assert main(["export-policy", str(copy / "model.zip"), "-o", str(out)]) == 2
    assert "manifest.json" in capsys.readouterr().err and not out.exists()


def test_controller_fmu_with_reference_fmu_reproduces_the_reference_episode(
    trained, tmp_path, load_example
):
    """FMPy as master: controller FMU + vehicle FMU = the env's reference episode under the
    same policy (docs/fmi.md, the engineer's loop)."""
    from agents.policies.loading import load_policy
    from agents.policies.policy_fmu import export_policy
    from railgym.fmu.reference import export_reference_fmu

    run, _ = trained
    ex = load_example("fmu_closed_loop")
    vehicle, _ = export_reference_fmu(tmp_path / "vehicle.fmu", kind="cs")
    controller, _ = export_policy(run / "model.zip", tmp_path / "controller.fmu")
    factory, env_kwargs, _ = load_policy(str(run / "model.zip"), ID)
    ep = ex.env_episode(factory(None), seed=4, duration=4.0, track_class=4, **env_kwargs)
    args = (vehicle, controller, ep["z"], ep["zdot"], ep["dt"], ep["n_sub"])
    co = ex.closed_loop(*args, interpolate=True)
    assert co["carbody_acc"].shape == ep["carbody_acc"].shape == (400,)
    # the controller acts: its forces change the ride by more than the tolerance below
    passive = ex.env_episode(_Zero(), seed=4, duration=4.0, track_class=4, **env_kwargs)
    assert np.std(ep["force"]) > 100.0
    assert ex.rms_difference(passive["carbody_acc"], ep["carbody_acc"]) > 0.02
    # target 1 %; with the Hermite track input the same integration: rounding only
    assert ex.rms_difference(co["carbody_acc"], ep["carbody_acc"]) < 1e-6
    assert np.max(np.abs(co["force"] - ep["force"])) < 1e-3 * 6000.0
    # a plain master holding the track over each 1 ms step: a coupling error, still small
    held = ex.closed_loop(*args, interpolate=False)
    assert 1e-4 < ex.rms_difference(held["carbody_acc"], ep["carbody_acc"]) < 0.02


class _Zero:
    """Passive: action 0."""

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return np.zeros(1, np.float32), None


def test_whole_vehicle_policy_fmu_has_two_forces_named_like_the_vehicle_fmu(
    tmp_path, tiny_ppo_block
):
    """A VerticalVehicle-v1 policy: 11 observation inputs, two force outputs, each equal to
    predict × f_max; its names are the whole-vehicle reference FMU's outputs and inputs."""
    from agents.policies.loading import load_policy
    from agents.policies.policy_fmu import export_policy
    from agents.training.train import train
    from railgym.fmu.reference import VEHICLE_INPUTS, VEHICLE_OUTPUTS

    vid = "railgym/VerticalVehicle-v1"
    block = tiny_ppo_block(**BLOCKS["ppo"])
    run = train({vid: block}, tmp_path / "ppo_vehicle", progress=False)
    fmu, _ = export_policy(run / "model.zip", tmp_path / "controller.fmu")
    md = fmpy.read_model_description(str(fmu))
    ins = [v.name for v in md.modelVariables if v.causality == "input"]
    outs = [v.name for v in md.modelVariables if v.causality == "output"]
    assert set(ins) <= {name for name, _, _ in VEHICLE_OUTPUTS} and len(ins) == 11
    assert set(outs) <= {name for name, _, _ in VEHICLE_INPUTS} and len(outs) == 2
    factory, _, _ = load_policy(str(run / "model.zip"), vid)
    import gymnasium as gym

    scale = gym.make(vid).unwrapped.obs_scale
    obs = np.random.default_rng(1).normal(0.0, 1.5, (2000, 11)).astype(np.float32)
    action, _ = factory(None).predict(obs, deterministic=True)
    expected = np.clip(action, -1, 1).astype(float) * 8000.0
    assert np.ptp(expected, axis=0).min() > 100.0
    got = _fmu_outputs(fmu, ins, obs.astype(float) * scale, outs)
    assert np.max(np.abs(got - expected)) <= 1e-5 * 8000.0


def test_policy_fmu_descriptions_hold_plain_numbers(tmp_path, capsys):
    """The observation scales, f_max and the residual scale read as numbers (``0.04``), not
    as numpy reprs (``np.float64(0.04)``), in the FMU's variable descriptions."""
    import zipfile
    from xml.etree import ElementTree

    from fmpy.validation import validate_fmu

    out = tmp_path / "controller.fmu"
    assert main(["export-policy", "ppo-vertical", "-o", str(out), "--quiet"]) == 0
    assert validate_fmu(str(out)) == []
    with zipfile.ZipFile(out) as zf:
        root = ElementTree.fromstring(zf.read("modelDescription.xml"))
    texts = [e.get("description", "") for e in root.iter()]
    assert not any("np." in t for t in texts), texts
    assert any("the env's obs × 0.04)" in t for t in texts), texts
    assert any("× f_max (8000.0 N)" in t for t in texts), texts
