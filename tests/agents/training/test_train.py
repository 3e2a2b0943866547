"""agents.training.train: the SB3 adapter's autoreset semantics, config validation, a short
PPO run."""

from __future__ import annotations

import csv
import hashlib
import json
from pathlib import Path

import gymnasium as gym
import numba
import numpy as np
import pytest
import yaml
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, SyncVectorEnv

pytest.importorskip("stable_baselines3")

import railgym  # noqa: E402
from agents.commands.train import main  # noqa: E402
from agents.controllers.classical import Passive  # noqa: E402
from agents.policies.loading import load_policy  # noqa: E402
from agents.training.train import GymVecToSB3, evaluate, load_config, make_vec, train  # noqa: E402

ENV_ID = "railgym/VerticalSuspension-v1"
CONFIGS = Path(railgym.__file__).parent / "configs" / "agents"


class Countdown(gym.Env):
    """Toy env: obs ``[t, L]``; terminates when ``t`` reaches the length ``L`` drawn in reset."""

    observation_space = spaces.Box(0.0, 100.0, (2,), np.float32)
    action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t, self.length = 0, int(self.np_random.integers(2, 6))
        return self._obs(), {"t": 0}

    def step(self, action):
        self.t += 1
        done = self.t >= self.length
        info = {"t": self.t, "tt": np.array([self.t, 2 * self.t]), "late": self.t > 3}
        return self._obs(), float(action[0]) + self.t, done, False, info

    def _obs(self):
        return np.array([self.t, self.length], np.float32)


if "test/Countdown-v0" not in gym.registry:
    gym.register("test/Countdown-v0", entry_point=Countdown)


class Zero:
    """Policy with SB3's ``predict`` that always commands 0."""

    def predict(self, obs, deterministic=True):
        return np.zeros((len(obs), 1), np.float32), None


def _csv_rows(path: Path) -> list[dict[str, float]]:
    with path.open() as fh:
        return [{k: float(v or "nan") for k, v in row.items()} for row in csv.DictReader(fh)]


def _tiny_config(seed: int | None = 3) -> dict:
    block = {
        "algo": "ppo",
        "n_timesteps": 2048,
        "policy": "MlpPolicy",
        "n_envs": 4,
        "env_kwargs": {"duration": 1.0},
        "eval_freq": 1024,
        "n_eval_episodes": 2,
        "checkpoint_freq": 1024,
        "n_steps": 128,
        "batch_size": 128,
        "n_epochs": 2,
        "policy_kwargs": {"net_arch": [16], "activation_fn": "tanh"},
    }
    if seed is not None:
        block["seed"] = seed
    return {ENV_ID: block}


def test_native_vector_env_matches_single_envs_across_autoresets():
    """Same-step autoreset on the native NEXT_STEP env: terminal obs = last obs of the
    episode, returned obs = first obs of the next one, as for single envs stepped alongside."""
    n, seed, kwargs = 3, 7, {"duration": 0.05}  # 5 steps per episode
    adapter = GymVecToSB3(
        gym.make_vec(ENV_ID, n, vectorization_mode="vector_entry_point", **kwargs)
    )
    singles = [gym.make(ENV_ID, **kwargs) for _ in range(n)]
    adapter.seed(seed)
    obs = adapter.reset()
    expected = np.stack([e.reset(seed=seed + i)[0] for i, e in enumerate(singles)])
    np.testing.assert_array_equal(obs, expected)
    rng = np.random.default_rng(0)
    n_done = 0
    for step in range(1, 13):
        actions = rng.uniform(-1, 1, (n, 1)).astype(np.float32)
        obs, rewards, dones, infos = adapter.step(actions)
        for i, env in enumerate(singles):
            o, r, term, trunc, _ = env.step(actions[i])
            assert rewards[i] == pytest.approx(r, rel=1e-6)
            assert dones[i] == (term or trunc) == (step % 5 == 0)
            if dones[i]:
                n_done += 1
                np.testing.assert_array_equal(infos[i]["terminal_observation"], o)
                assert infos[i]["TimeLimit.truncated"] is True
                assert infos[i]["time"] == pytest.approx(0.05)
                o, _ = env.reset()
                assert adapter.reset_infos[i]["time"] == 0.0
                assert not np.array_equal(o, infos[i]["terminal_observation"])
            else:
                assert "terminal_observation" not in infos[i]
            np.testing.assert_array_equal(obs[i], o)
    assert n_done == 2 * n


class NoPartialReset(SyncVectorEnv):
    """A NEXT_STEP vector env without Gymnasium's partial reset (like the native envs)."""

    def reset(self, *, seed=None, options=None):
        if options:
            raise ValueError("reset takes no options")
        return super().reset(seed=seed)


@pytest.mark.parametrize("mode", [AutoresetMode.SAME_STEP, AutoresetMode.NEXT_STEP])
def test_uneven_episodes_match_single_envs(mode):
    """SAME_STEP: final_obs passed through; NEXT_STEP: finished sub-envs partially reset."""
    n = 3
    adapter = GymVecToSB3(SyncVectorEnv([Countdown for _ in range(n)], autoreset_mode=mode))
    singles = [Countdown() for _ in range(n)]
    adapter.seed(11)
    obs = adapter.reset()
    np.testing.assert_array_equal(obs, [e.reset(seed=11 + i)[0] for i, e in enumerate(singles)])
    partial = 0
    for _ in range(20):
        obs, rewards, dones, infos = adapter.step(np.zeros((n, 1), np.float32))
        partial += 0 < dones.sum() < n
        for i, env in enumerate(singles):
            o, r, term, _, info = env.step(np.zeros(1))
            assert rewards[i] == r and dones[i] == term
            if term:
                np.testing.assert_array_equal(infos[i]["terminal_observation"], o)
                assert infos[i]["t"] == info["t"] == o[1]  # final step's info, not the reset's
                assert infos[i]["TimeLimit.truncated"] is False
                o, _ = env.reset()
            np.testing.assert_array_equal(obs[i], o)
    assert partial >= 3
    assert adapter.partial_reset


def _run_without_partial_reset(seed: int) -> list[tuple]:
    adapter = GymVecToSB3(NoPartialReset([Countdown for _ in range(3)]))
    adapter.seed(seed)
    obs = adapter.reset()
    trace = []
    for _ in range(20):
        new, _, dones, infos = adapter.step(np.zeros((3, 1), np.float32))
        if dones.any():
            assert dones.all(), "an unfinished episode must be ended when another one ends"
            for i in range(3):
                final = infos[i]["terminal_observation"]
                assert final[0] == obs[i][0] + 1  # the step was made
                assert infos[i]["TimeLimit.truncated"] is bool(final[0] < final[1])
            np.testing.assert_array_equal(new[:, 0], 0.0)  # all fresh episodes
        else:
            np.testing.assert_array_equal(new[:, 0], obs[:, 0] + 1)
        trace.append((new.copy(), dones.copy()))
        obs = new
    assert not adapter.partial_reset
    return trace


def test_without_partial_reset_all_episodes_end_together_reproducibly():
    with pytest.warns(UserWarning, match="no partial reset"):
        a = _run_without_partial_reset(5)
    with pytest.warns(UserWarning, match="no partial reset"):
        b = _run_without_partial_reset(5)
    assert sum(d.any() for _, d in a) >= 3
    for (oa, da), (ob, db) in zip(a, b, strict=True):
        np.testing.assert_array_equal(oa, ob)
        np.testing.assert_array_equal(da, db)


def test_evaluate_reads_final_info_of_same_step_sync_env():
    venv = make_vec("test/Countdown-v0", 4, {})  # no native vector env: SAME_STEP sync
    assert venv.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    lengths = np.array([Countdown().reset(seed=8 + i)[0][1] for i in range(4)])
    stats = evaluate(Zero(), venv, seed=8)
    assert stats["mean_length"] == stats["mean_t"] == stats["mean_tt_0"] == lengths.mean()
    assert stats["mean_tt_1"] == 2 * lengths.mean() and "mean_tt" not in stats
    assert stats["mean_late"] == np.mean(lengths > 3)
    assert stats["mean_reward"] == pytest.approx(np.mean(lengths * (lengths + 1) / 2))


def test_evaluate_passive_matches_single_episode_rms():
    kwargs = {"duration": 0.5}
    venv = make_vec(ENV_ID, 2, kwargs)
    stats = evaluate(Passive(venv), venv, seed=4)
    rms = []
    for i in range(2):
        env = gym.make(ENV_ID, **kwargs)
        env.reset(seed=4 + i)
        acc, done = [], False
        while not done:
            _, _, term, trunc, info = env.step(np.zeros(1, np.float32))
            acc.append(info["carbody_acc"])
            done = term or trunc
        rms.append(np.sqrt(np.mean(np.square(acc))))
    assert stats["mean_length"] == 50
    assert stats["mean_rms_carbody_acc"] == pytest.approx(np.mean(rms), rel=1e-9)
    assert stats["mean_rms_carbody_acc"] > 0.05


def test_short_ppo_run_saves_reloadable_reproducible_policy(tmp_path, monkeypatch, capsys):
    from stable_baselines3 import PPO

    path = tmp_path / "configs" / "ppo_tiny.yaml"
    path.parent.mkdir()
    path.write_text(yaml.safe_dump(_tiny_config()))
    monkeypatch.chdir(tmp_path)
    assert main([str(path), "--quiet"]) == 0
    out = tmp_path / "runs" / "ppo_tiny"  # default: runs/<stem>/ in the working directory
    assert sorted(p.name for p in path.parent.iterdir()) == ["ppo_tiny.yaml"]
    for name in ("model.zip", "best_model.zip", "progress.csv", "eval.csv", "config.yaml"):
        assert (out / name).is_file(), name
    manifest = json.loads((out / "manifest.json").read_text())["sha256"]
    assert manifest == {
        n: hashlib.sha256((out / n).read_bytes()).hexdigest()
        for n in ("best_model.zip", "model.zip")
    }
    # a second run into the same folder is refused before any work, unless --overwrite
    before = (out / "model.zip").read_bytes()
    assert main([str(path), "--quiet"]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert (out / "model.zip").read_bytes() == before
    saved = yaml.safe_load((out / "config.yaml").read_text())
    assert saved[ENV_ID]["seed"] == 3 and saved[ENV_ID]["eval_seed"] == 999_999
    assert saved["run"]["timesteps"] == 2048 and saved["run"]["steps_per_s"] > 0
    assert {"torch", "stable_baselines3", "gymnasium", "railgym"} <= set(saved["run"]["versions"])
    assert load_config(out / "config.yaml") == load_config(path)
    rows = _csv_rows(out / "eval.csv")
    assert [r["timesteps"] for r in rows] == [1024, 2048]
    assert all(r["mean_length"] == 100 and 0.05 < r["mean_rms_carbody_acc"] < 5 for r in rows)
    progress = _csv_rows(out / "progress.csv")
    assert progress[-1]["time/total_timesteps"] == 2048
    assert np.isfinite(progress[-1]["rollout/ep_rew_mean"])  # VecMonitor episode stats
    names = sorted(p.name for p in (out / "checkpoints").iterdir())
    assert names == ["manifest.json", "model_1024_steps.zip", "model_2048_steps.zip"]

    # the last evaluation used the in-memory final model; the reloaded one acts identically
    model = PPO.load(out / "model.zip", device="cpu")
    venv = make_vec(ENV_ID, 2, {"duration": 1.0})
    assert evaluate(model, venv, seed=999_999)["mean_reward"] == pytest.approx(
        rows[-1]["mean_reward"], rel=1e-12
    )
    obs, _ = venv.reset(seed=1)
    action, _ = model.predict(obs, deterministic=True)
    # railgym evaluate's loader reads only the weights: the same actions, nothing unpickled
    factory, env_kwargs, label = load_policy(str(out / "model.zip"))
    assert label == "ppo_tiny" and env_kwargs == {}
    np.testing.assert_array_equal(factory(venv).predict(obs, deterministic=True)[0], action)
    (out / "model.zip").write_bytes(before + b"\0")  # changed after training: refused
    with pytest.raises(ValueError, match="SHA-256 differs.*--trust"):
        load_policy(str(out / "model.zip"))

    # same seed, same training: identical policy; another seed: a different one
    def act(folder: Path) -> np.ndarray:
        return PPO.load(folder / "model.zip").predict(obs, deterministic=True)[0]

    same = train(_tiny_config(), tmp_path / "same", progress=False)
    np.testing.assert_array_equal(act(same), action)
    other = train(_tiny_config(seed=4), tmp_path / "other", progress=False)
    assert not np.array_equal(act(other), action)


def test_env_kernels_run_on_env_threads_while_learning_and_are_restored(tmp_path, monkeypatch):
    """torch's and numba's OpenMP threads spin for the cores: ``learn`` runs the env kernels on
    ``env_threads`` numba threads, and the process gets its own number back afterwards."""
    from stable_baselines3 import PPO

    seen = []
    learn = PPO.learn

    def spy(self, *args, **kwargs):
        seen.append(numba.get_num_threads())
        return learn(self, *args, **kwargs)

    monkeypatch.setattr(PPO, "learn", spy)
    before = numba.get_num_threads()
    cfg = _tiny_config()
    cfg[ENV_ID]["env_threads"] = 1
    train(cfg, tmp_path / "one", progress=False)
    assert seen == [1] and numba.get_num_threads() == before


def test_short_sac_run_with_schedule_reloads(tmp_path, capsys):
    from stable_baselines3 import SAC

    block = {
        "algo": "sac",
        "n_timesteps": 400,
        "n_envs": 2,
        "seed": 5,
        "env_kwargs": {"duration": 1.0},
        "eval_freq": 200,
        "n_eval_episodes": 1,
        "learning_starts": 100,
        "buffer_size": 1000,
        "batch_size": 32,
        "learning_rate": "lin_1e-3",
        "policy_kwargs": {"net_arch": [16]},
        "eval_echo": ["rms_carbody_acc"],
    }
    out = train({ENV_ID: block}, tmp_path, progress=True)
    rows = _csv_rows(out / "eval.csv")
    echoed = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("eval @ 400")]
    assert echoed and f"rms_carbody_acc {rows[-1]['mean_rms_carbody_acc']:.4g}" in echoed[0]
    assert "out_of_domain" not in echoed[0]
    assert [r["timesteps"] for r in rows] == [200, 400]
    model = SAC.load(out / "model.zip", device="cpu")
    assert model.lr_schedule(1.0) == pytest.approx(1e-3) and model.lr_schedule(0.25) == 2.5e-4
    venv = make_vec(ENV_ID, 1, {"duration": 1.0})
    assert evaluate(model, venv, 999_999)["mean_reward"] == pytest.approx(rows[-1]["mean_reward"])
    obs, _ = venv.reset(seed=2)
    weights_only = load_policy(str(out / "model.zip"))[0](venv)
    np.testing.assert_array_equal(
        weights_only.predict(obs, deterministic=True)[0], model.predict(obs, deterministic=True)[0]
    )


#: the agents.training.train configs (``trainer: rllib`` files are agents.training.train_rllib's,
#: tests/agents/training/test_rllib.py)
SB3_CONFIGS = [
    p
    for p in sorted(CONFIGS.glob("*.yaml"))
    if next(iter(yaml.safe_load(p.read_text()).values())).get("trainer") != "rllib"
]


@pytest.mark.parametrize("path", SB3_CONFIGS, ids=lambda p: p.name)
def test_shipped_configs_are_valid(path):
    cfg = load_config(path)
    assert cfg.algo == path.stem.split("_")[0]
    assert cfg.n_timesteps >= 100 * cfg.n_envs and cfg.eval_freq < cfg.n_timesteps


def test_missing_seed_is_drawn_and_recorded():
    a, b = load_config(_tiny_config(seed=None)), load_config(_tiny_config(seed=None))
    assert isinstance(a.seed, int) and 0 <= a.seed < 2**31
    assert a.seed != b.seed


@pytest.mark.parametrize(
    ("change", "field"),
    [
        (lambda c: {}, "env id"),
        (lambda c: {"NoSuchEnv-v0": c[ENV_ID]}, "env id"),
        (lambda c: {**c, "Other-v0": {}}, "env id"),
        (lambda c: c[ENV_ID].pop("algo") and c, "algo"),
        (lambda c: c[ENV_ID].update(algo="dqn2") or c, "algo"),
        (lambda c: c[ENV_ID].pop("n_timesteps") and c, "n_timesteps"),
        (lambda c: c[ENV_ID].update(n_envs=0) or c, "n_envs"),
        (lambda c: c[ENV_ID].update(seed=-1) or c, "seed"),
        (lambda c: c[ENV_ID].update(env_kwargs=[1]) or c, "env_kwargs"),
        (lambda c: c[ENV_ID].update(learning_rat=0.1) or c, "learning_rat"),
        (lambda c: c[ENV_ID].update(learning_rate="lin_fast") or c, "learning_rate"),
        (lambda c: c[ENV_ID].update(vectorization_mode="async") or c, "vectorization_mode"),
        (lambda c: c[ENV_ID].update(n_envs=5000) or c, "n_envs must be at most 1024"),
        (lambda c: c[ENV_ID].update(n_eval_episodes=2.0) or c, "n_eval_episodes must be an int"),
        (lambda c: c[ENV_ID].update(seed=2**32) or c, "seed must be at most"),
        (lambda c: c[ENV_ID].update(eval_seed="1") or c, "eval_seed must be an integer"),
        (lambda c: c[ENV_ID].update(n_threads=True) or c, "n_threads must be an integer"),
        (lambda c: c[ENV_ID].update(env_threads=0) or c, "env_threads must be at least 1"),
        (lambda c: c[ENV_ID].update(eval_echo="rms") or c, "eval_echo must be a sequence"),
        (lambda c: c[ENV_ID].update(eval_echo=["rms", 3]) or c, r"eval_echo\[1\] must be a name"),
        (lambda c: c[ENV_ID].update(policy=None) or c, "policy must be a policy name"),
        (lambda c: c[ENV_ID].update(policy_kwargs=[16]) or c, "policy_kwargs must be a mapping"),
        (lambda c: c[ENV_ID].update(env_id="x") or c, "unknown config key 'env_id'"),
        (lambda c: c[ENV_ID].update(n_steps=0) or c, "n_steps must be at least 1"),
        (lambda c: c[ENV_ID].update(batch_size="x") or c, "batch_size must be an integer"),
        (lambda c: c[ENV_ID].update(n_epochs=True) or c, "n_epochs must be an integer"),
        (lambda c: c[ENV_ID].update(gamma=2.0) or c, r"gamma must be in \[0, 1\]"),
        (lambda c: c[ENV_ID].update(learning_rate=-1.0) or c, "learning_rate must be positive"),
        (lambda c: c[ENV_ID].update(learning_rate="nan") or c, "learning_rate must be finite"),
        (lambda c: c[ENV_ID].update(learning_rate="lin_-3e-4") or c, "learning_rate must be pos"),
        (lambda c: c[ENV_ID].update(ent_coef="auto") or c, "ent_coef must be a number, got"),
        (
            lambda c: {ENV_ID: {"algo": "sac", "n_timesteps": 100, "ent_coef": "fast"}},
            "ent_coef must be a number or 'auto'",
        ),
        (
            lambda c: c[ENV_ID].update(policy_kwargs={"net_arch": "big"}) or c,
            "policy_kwargs.net_arch must be a sequence",
        ),
        (
            lambda c: c[ENV_ID].update(policy_kwargs={"net_arch": {"pi": [64, 0]}}) or c,
            r"policy_kwargs\.net_arch\.pi\[1\] must be at least 1",
        ),
        (
            lambda c: c[ENV_ID].update(policy_kwargs={"activation_fn": "swish2"}) or c,
            "activation_fn",
        ),
    ],
)
def test_bad_config_raises_naming_the_field(change, field):
    with pytest.raises(ValueError, match=field):
        load_config(change(_tiny_config()))


def test_packaged_config_by_name_and_a_same_named_folder_changes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "ppo_vertical").mkdir()  # a folder named like the packaged config
    assert load_config("ppo_vertical") == load_config(CONFIGS / "ppo_vertical.yaml")
    with pytest.raises(ValueError, match="unknown config 'ppo_vertica'.*packaged name"):
        load_config("ppo_vertica")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"env_kwargs": {"duration": 1.0, "speed": -1.0}}, "env_kwargs: speed must be positive"),
        ({"env_kwargs": {"sped": 3.0}}, "env_kwargs: .*unknown argument\\(s\\) \\['sped'\\]"),
        ({"eval_env_kwargs": {"backend": "simpack"}}, "eval_env_kwargs: backend must be one of"),
        ({"policy": "CnnPolicyX"}, "ppo settings: Policy CnnPolicyX unknown"),
    ],
)
def test_env_and_algorithm_errors_are_named_and_nothing_is_written(tmp_path, change, message):
    cfg = _tiny_config()
    cfg[ENV_ID].update(change)
    with pytest.raises(ValueError, match=message):
        train(cfg, tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()


def test_make_vec_modes():
    assert isinstance(make_vec(ENV_ID, 2, {"duration": 0.1}, "sync"), SyncVectorEnv)
    with pytest.raises(ValueError, match="vectorization_mode"):
        make_vec("test/Countdown-v0", 2, {}, "vector_entry_point")


def test_dict_config_needs_out_and_file_must_exist(tmp_path):
    with pytest.raises(ValueError, match="out"):
        train(_tiny_config(), progress=False)
    with pytest.raises(ValueError, match="does not exist"):
        load_config(tmp_path / "missing.yaml")


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("a: [1,\n", r"c\.yaml is not valid YAML, line 2"),
        ("- 1\n", "config must be a mapping"),
        (b"\xff\xfe", r"c\.yaml.* cannot be read.*utf-8"),
    ],
)
def test_unreadable_config_file_is_one_clear_error(tmp_path, text, match):
    path = tmp_path / "c.yaml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    with pytest.raises(ValueError, match=match):
        load_config(path)


def test_numpy_integers_are_accepted_and_bools_rejected():
    cfg = _tiny_config()
    cfg[ENV_ID].update(n_envs=np.int64(2), seed=np.int32(7))
    got = load_config(cfg)
    assert (got.n_envs, got.seed) == (2, 7) and type(got.seed) is int
    cfg[ENV_ID]["n_envs"] = True
    with pytest.raises(ValueError, match="n_envs"):
        load_config(cfg)


def test_rllib_config_is_pointed_to_its_trainer():
    with pytest.raises(ValueError, match="railgym train-rllib"):
        load_config("ppo_vertical_rllib")
