"""``railgym export-policy`` of residual policies: the FMU (and ONNX graph) holds the
classical base beside the network, its state included.

Closed loop on the env: every step the env's observation goes to the FMU (FMPy, set inputs,
read the force, ``fmi2DoStep``) and to ``policy.predict(obs, deterministic=True)`` of the
loaded :class:`agents.controllers.residual.ResidualPolicy` (the LQG's Kalman estimate
included), whose
action steps the env; the forces agree within 10⁻⁵·f_max over two episodes, the FMU put back
at rest with ``fmi2Reset`` and the policy with ``episode_start`` between them. Pretrained
names resolve as in ``railgym evaluate``; what cannot be exported is one line and exit 2.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from agents.commands.cli import main
from tests.fresh_process import run_cli
from tests.markers import needs_cc

pytest.importorskip("stable_baselines3")
fmpy = pytest.importorskip("fmpy", reason="the 'fmi' extra (fmpy) is not installed")
pytestmark = needs_cc
ID = "railgym/VerticalSuspension-v1"
VID = "railgym/VerticalVehicle-v1"
#: |FMU − predict·f_max| / f_max allowed at every step
TOL = 1e-5


def _has_onnxruntime() -> bool:
    try:
        import onnxruntime  # noqa: F401
    except ImportError:
        return False
    return True


class _FMU:
    """One instance of a controller FMU through FMPy's ``FMU2Slave``."""

    def __init__(self, path: Path, inputs: list[str]) -> None:
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        md = read_model_description(str(path))
        vr = {v.name: v.valueReference for v in md.modelVariables}
        self.outputs = [v.name for v in md.modelVariables if v.causality == "output"]
        self.ins, self.outs = [vr[n] for n in inputs], [vr[n] for n in self.outputs]
        self.slave = FMU2Slave(
            guid=md.guid,
            unzipDirectory=extract(str(path)),
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName="controller",
        )
        self.slave.instantiate()
        self._start()
        self.t = 0.0

    def _start(self) -> None:
        self.slave.setupExperiment(startTime=0.0)
        self.slave.enterInitializationMode()
        self.slave.exitInitializationMode()

    def reset(self) -> None:
        """``fmi2Reset``: the controller's state back at rest."""
        self.slave.reset()
        self._start()
        self.t = 0.0

    def force(self, obs_si: np.ndarray, dt: float) -> np.ndarray:
        """Set the observation, read the forces (N), then ``fmi2DoStep`` over ``dt``."""
        self.slave.setReal(self.ins, [float(x) for x in obs_si])
        out = np.array(self.slave.getReal(self.outs))
        self.slave.doStep(currentCommunicationPoint=self.t, communicationStepSize=dt)
        self.t += dt
        return out

    def close(self) -> None:
        self.slave.terminate()
        self.slave.freeInstance()


def _closed_loop(env, policy, fmu: _FMU, seeds=(0, 1)) -> dict[str, np.ndarray]:
    """Episodes of ``env`` under ``policy.predict``; per step (all episodes) the observation
    (the env's and SI), the expected force ``action·f_max``, the FMU's and the episode."""
    base = env.unwrapped
    f_max, dt = base.cfg.f_max, base.cfg.control_dt
    rec: dict[str, list] = {"obs": [], "obs_si": [], "expected": [], "fmu": [], "episode": []}
    for k, seed in enumerate(seeds):
        obs, _ = env.reset(seed=seed)
        if k:
            fmu.reset()
        start = True
        while True:
            action, _ = policy.predict(obs, episode_start=np.array([start]), deterministic=True)
            start = False
            obs_si = obs.astype(float) * base.obs_scale  # float32 obs exactly, after scaling
            rec["obs"].append(obs)
            rec["obs_si"].append(obs_si)
            rec["expected"].append(np.asarray(action, float) * f_max)
            rec["fmu"].append(fmu.force(obs_si, dt))
            rec["episode"].append(k)
            obs, _, term, trunc, _ = env.step(action)
            if term or trunc:
                break
    return {key: np.array(v) for key, v in rec.items()}


def _onnx_forces(path: Path, run: dict[str, np.ndarray]) -> tuple[np.ndarray, list[str]]:
    """Forces of the ONNX graph along the closed loop's observations, its controller state
    fed back (zeros at each episode start); and the graph's input names."""
    import onnxruntime as ort

    sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    names = [i.name for i in sess.get_inputs()]
    n_state = sess.get_inputs()[1].shape[1] if len(names) > 1 else 0
    state, forces = np.zeros((1, n_state)), []
    for k, obs_si in enumerate(run["obs_si"]):
        if k == 0 or run["episode"][k] != run["episode"][k - 1]:
            state = np.zeros((1, n_state))
        feed = {"observation": obs_si[None]}
        if n_state:
            feed["controller_state"] = state
        out = sess.run(None, feed)
        forces.append(out[0][0])
        if n_state:
            state = out[1]
    return np.array(forces, float), names


def _check_closed_loop(fmu_path, onnx_path, env, factory, stateful: bool) -> float:
    """The FMU (and ONNX) forces = predict·f_max over two episodes; returns the max relative
    difference of the FMU. Also: the base and the network both shape the force."""
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu_path)) == []
    base = env.unwrapped
    f_max = base.cfg.f_max
    fmu = _FMU(fmu_path, list(base.obs_names))
    policy = factory(env)
    run = _closed_loop(env, policy, fmu)
    fmu.close()
    expected, got = run["expected"], run["fmu"]
    assert len(expected) >= 200 and set(run["episode"]) == {0, 1}
    # informative: most steps do not saturate, the forces span the range
    assert np.mean(np.abs(expected) < 0.999 * f_max) > 0.5
    assert np.ptp(expected) > 0.5 * f_max
    rel = float(np.max(np.abs(got - expected)) / f_max)
    assert rel <= TOL
    # both parts shape the force: the network alone and the base alone are far from the sum
    agent = np.array([policy.policy.predict(o, deterministic=True)[0] for o in run["obs"]])
    net_only = np.clip(policy.scale * np.clip(agent, -1, 1), -1, 1) * f_max
    assert np.max(np.abs(net_only.reshape(expected.shape) - expected)) > 0.1 * f_max
    ctrl = factory(env).controller  # a fresh base along the same observations
    starts = np.r_[True, np.diff(run["episode"]) != 0]
    base_only = np.array(
        [
            ctrl.predict(o, episode_start=np.array([s]))[0]
            for o, s in zip(run["obs"], starts, strict=True)
        ]
    )
    assert np.max(np.abs(base_only.reshape(expected.shape) * f_max - expected)) > 0.02 * f_max
    if stateful:  # a fresh instance on episode 2 = the reset one; a stale one is not
        second = run["episode"] == 1
        fresh, stale = _FMU(fmu_path, list(base.obs_names)), _FMU(fmu_path, list(base.obs_names))
        dt = base.cfg.control_dt
        for obs_si in run["obs_si"][~second][:50]:
            stale.force(obs_si, dt)
        first = run["obs_si"][second][:20]
        again = np.array([fresh.force(o, dt) for o in first])
        old = np.array([stale.force(o, dt) for o in first])
        np.testing.assert_array_equal(again, got[second][:20])
        assert np.max(np.abs(old - again)) > 1e-3 * f_max
        fresh.close()
        stale.close()
    if onnx_path is not None:
        forces, names = _onnx_forces(onnx_path, run)
        assert names == (["observation", "controller_state"] if stateful else ["observation"])
        assert np.max(np.abs(forces - expected)) <= TOL * f_max
    return rel


@pytest.fixture(scope="module", params=["ppo-vertical", "ppo-vehicle", "ppo-preview"])
def shipped(request, tmp_path_factory):
    """(name, env id, FMU, ONNX or None) of a shipped residual policy, exported by name."""
    from agents.policies.policy_fmu import export_policy
    from agents.policies.pretrained import PRETRAINED

    name = request.param
    out = tmp_path_factory.mktemp(name)
    onnx = out / "controller.onnx" if _has_onnxruntime() else None
    fmu, onnx_path = export_policy(name, out / "controller.fmu", onnx)
    return name, PRETRAINED[name], fmu, onnx_path


def test_shipped_residual_fmu_reproduces_predict_with_its_lqg(shipped):
    """The shipped residuals of the LQG (and of the LQ preview, its preview channels as FMU
    inputs): FMU = ResidualPolicy.predict·f_max step by step on the reference backend, over
    two episodes (state reset between them)."""
    from agents.policies.loading import load_policy

    name, env_id, fmu, onnx = shipped
    factory, env_kwargs, label = load_policy(name, env_id)
    assert label == name
    md = fmpy.read_model_description(str(fmu))
    env = gym.make(env_id, **env_kwargs, backend="reference", duration=4.0)
    ins = [v.name for v in md.modelVariables if v.causality == "input"]
    outs = [v.name for v in md.modelVariables if v.causality == "output"]
    assert ins == list(env.unwrapped.obs_names)
    assert outs == (
        ["actuator_force"]
        if env_id.startswith("railgym/VerticalSuspension")
        else ["actuator_force_front", "actuator_force_rear"]
    )
    base = "lq-preview" if name == "ppo-preview" else "lqg"
    assert f"residual of {base}, scale 0.5" in md.description
    rel = _check_closed_loop(fmu, onnx, env, factory, stateful=True)
    print(f"{name}: max |FMU - predict·f_max| / f_max = {rel:.3g}")


def test_cli_exports_a_pretrained_name_in_a_fresh_process(tmp_path):
    out = tmp_path / "c.fmu"
    done = run_cli("export-policy", "ppo-vertical", "-o", str(out), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert out.is_file() and f"wrote {out}" in done.stdout
    assert fmpy.read_model_description(str(out)).coSimulation is not None


def test_cli_refuses_the_crash_policy_saying_why(tmp_path):
    """``ppo-crash`` sets absorber force scales (and holds its action 10 steps): one line
    naming the env and why, exit status 2, nothing written."""
    out = tmp_path / "c.fmu"
    done = run_cli("export-policy", "ppo-crash", "-o", str(out), cwd=tmp_path)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr
    assert "ppo-crash" in lines[0] and "cannot be exported" in lines[0]
    why = "railgym/TrainCrash-v1 policy's action sets the crash absorbers' force scale"
    assert f"{why}, not an actuator force" in lines[0]
    assert "action_hold is 10" in lines[0]
    assert not out.exists()


def test_crash_zip_without_hold_is_refused_not_an_attribute_error(tmp_path, capsys, tiny_ppo_block):
    """A crash policy that decides every step (``action_hold`` 1): the same clear refusal
    (it used to end in ``AttributeError: 'CrashParams' object has no attribute 'f_max'``)."""
    from agents.training.train import train

    crash = {"scenario": "envelope", "control_dt": 0.005, "backend": "reference"}
    block = tiny_ppo_block(n_timesteps=64, n_steps=32, env_kwargs=crash)
    run = train({"railgym/TrainCrash-v1": block}, tmp_path / "crash", progress=False)
    out = tmp_path / "c.fmu"
    assert main(["export-policy", str(run / "model.zip"), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "absorbers' force scale" in err and "AttributeError" not in err
    assert not out.exists()


#: tiny residual runs of agents.training.train: (algo, base, observation)
TINY = {
    "ppo-lqr": ("ppo", "lqr", "full"),
    "sac-skyhook": ("sac", "skyhook", "sensors"),
}
ALGO_BLOCKS = {
    "ppo": {"n_steps": 32, "batch_size": 64, "n_epochs": 1},
    "sac": {"learning_starts": 32, "batch_size": 32, "buffer_size": 1000},
}


def _tiny_residual(tmp_path: Path, algo: str, residual: str, observation: str) -> Path:
    """The run folder of a residual policy trained a few steps by agents.training.train
    (f_max 6 kN)."""
    from agents.training.train import train

    block = {
        "algo": algo,
        "n_timesteps": 64,
        "n_envs": 2,
        "seed": 0,
        "residual": residual,
        "residual_scale": 0.5,
        "env_kwargs": {
            "backend": "linear",
            "duration": 1.0,
            "observation": observation,
            "f_max": 6000.0,
        },
        "eval_freq": 10**6,
        "n_eval_episodes": 1,
        "checkpoint_freq": 10**6,
        # default init of the action layer (not SB3's 0.01 gain): a correction of kN
        "policy_kwargs": {"net_arch": [8], **({"ortho_init": False} if algo == "ppo" else {})},
        **ALGO_BLOCKS[algo],
    }
    return train({ID: block}, tmp_path / f"{algo}_{residual}", progress=False)


@pytest.mark.parametrize("case", sorted(TINY))
def test_trained_memoryless_residual_fmu_reproduces_predict(case, tmp_path):
    """Residuals of the memoryless linear bases (full-state LQR, active skyhook), PPO and
    SAC a few steps trained, f_max 6 kN: FMU and ONNX = predict·f_max over two episodes."""
    from agents.policies.loading import load_policy

    run = _tiny_residual(tmp_path, *TINY[case])
    fmu, onnx = tmp_path / "c.fmu", tmp_path / "c.onnx"
    args = ["export-policy", str(run / "model.zip"), "-o", str(fmu)]
    assert main(args + (["--onnx", str(onnx)] if _has_onnxruntime() else [])) == 0
    factory, env_kwargs, _ = load_policy(str(run / "model.zip"), ID)
    assert env_kwargs["f_max"] == 6000.0
    env = gym.make(ID, **env_kwargs, backend="reference", duration=2.0, track_class=4)
    rel = _check_closed_loop(fmu, onnx if _has_onnxruntime() else None, env, factory, False)
    print(f"{case}: max |FMU - predict·f_max| / f_max = {rel:.3g}")


def test_cli_refuses_the_semi_active_policy_saying_why(tmp_path, capsys):
    """``ppo-semiactive`` commands a damper: one line naming it and why, nothing written."""
    out = tmp_path / "c.fmu"
    assert main(["export-policy", "ppo-semiactive", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "ppo-semiactive" in err
    assert "damper command in [0, 1] (actuator: semi-active)" in err
    assert not out.exists()


def test_cli_refuses_a_semi_active_residual_naming_it(tmp_path, capsys):
    run = _tiny_residual(tmp_path, "ppo", "semi-active", "sensors")
    out = tmp_path / "c.fmu"
    assert main(["export-policy", str(run / "model.zip"), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(run / "config.yaml") in err
    assert "residual controller 'semi-active' (Skyhook) cannot be exported" in err
    assert "a switching law, not a linear function of the observation" in err
    assert not out.exists()


def test_a_base_that_is_not_linear_is_refused_naming_it():
    """``semi-active`` switches; another non-linear law is found by the probe."""
    from agents.controllers.classical import Skyhook
    from agents.policies.residual_export import linear_base

    env = gym.make(ID)
    with pytest.raises(ValueError, match=r"'semi-active' \(Skyhook\).*a switching law"):
        linear_base(Skyhook(env, mode="semi-active"), "semi-active", 0.5)

    class Cubic(Skyhook):
        def force(self, x):
            return super().force(x) ** 3

    with pytest.raises(ValueError, match="'cubic'.*not a linear function of the observation"):
        linear_base(Cubic(env), "cubic", 0.5)
    base = linear_base(Skyhook(env), "skyhook", 0.5)  # active: F = −c_sky·ẋ2
    carbody_vel = env.unwrapped.obs_names.index("carbody_vel")
    assert base.n_x == 0 and base.g[0, carbody_vel] == pytest.approx(-Skyhook(env).c_sky)


def _base_actions(base, obs: np.ndarray) -> np.ndarray:
    """The equations of :mod:`agents.policies.residual_export` in numpy, from rest, on the env's
    observations ``obs`` (steps, n_obs): the base's action per step."""
    xp, up, out = np.zeros(base.n_x), np.zeros(base.g.shape[0]), []
    for o in obs:
        y = o.astype(float) * base.obs_scale
        xe = xp + base.m @ (y - base.c @ xp - base.d @ up)
        f = np.clip(base.g @ y - base.k @ xe, -base.f_max, base.f_max)
        xp, up = base.phi @ xe + base.gamma @ f, f
        out.append(np.float32(np.clip(f / base.f_max, -1, 1)))
    return np.array(out)


@pytest.mark.parametrize(
    ("env_id", "name"),
    [
        (env_id, name)
        for env_id, names in (
            (ID, ["passive", "skyhook", "groundhook", "lqr", "lqg"]),
            (VID, ["passive", "skyhook", "modal-skyhook", "lqr", "lqg"]),
        )
        for name in names
    ],
)
def test_every_linear_base_is_its_controller(env_id, name):
    """Each exportable controller of both vertical envs: the exported matrices reproduce its
    ``predict`` (the LQG's estimate carried over 60 steps) on random observations."""
    from agents.controllers.registry import build_controller, controllers_of
    from agents.policies.residual_export import linear_base

    env = gym.make(env_id, **controllers_of(env_id)[name][2])
    ctrl = build_controller(env_id, name, env)
    base = linear_base(ctrl, name, 0.5)
    assert (base.n_x > 0) == (name == "lqg") and base.scale == 0.5
    n_obs = len(env.unwrapped.obs_names)
    obs = np.random.default_rng(3).normal(0.0, 0.7, (60, n_obs)).astype(np.float32)
    want = np.array([ctrl.predict(o)[0] for o in obs])
    got = _base_actions(base, obs)
    assert name == "passive" or np.ptp(want) > 0.1  # the controller acts on these
    np.testing.assert_allclose(got, want.reshape(got.shape), rtol=0, atol=1e-6)
