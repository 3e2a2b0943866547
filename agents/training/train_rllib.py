"""Train PPO with RLlib (new API stack) on the native railgym vector envs.

Usage (needs the ``rllib`` extra, its own virtual environment: ``ray[rllib]`` pins
``gymnasium==1.2.2``; see ``docs/scaling.md``)::

    railgym train-rllib CONFIG.yaml [-o DIR] [--overwrite] [--iterations N] [--seed S]
                                    [--address ADDR] [--quiet] [--debug]

    railgym train-rllib railgym/configs/agents/ppo_vertical_rllib.yaml

Config file: one top-level key, the Gymnasium env id, holding

==========================  =======================================================================
``trainer``                 ``rllib`` (required: marks the file for this trainer)
``algo``                    ``ppo``
``iterations``              training iterations (``algo.train()`` calls)
``seed``                    RLlib's ``debugging(seed=...)`` and the env seeds (drawn and recorded
                            when absent)
``num_env_runners``         env-runner actors (0: sample in the driver)
``num_envs_per_env_runner`` sub-envs of each runner's native vector env
                            (``gym_env_vectorize_mode="vector_entry_point"``)
``env_kwargs``              keyword arguments of the env (e.g. ``backend``, ``duration``)
``eval_env_kwargs``         overrides of ``env_kwargs`` for the evaluation (e.g. ``backend:
                            reference``)
``n_eval_episodes``         evaluation episodes (one per sub-env), on the tracks of ``eval_seed``
                            (default 999999, as :mod:`agents.training.train`)
``training``                keyword arguments of ``PPOConfig.training`` (``lr``, ``gamma``,
                            ``lambda_``, ``train_batch_size_per_learner``, ``minibatch_size``,
                            ``num_epochs``, ``clip_param``, …)
``model``                   fields of RLlib's ``DefaultModelConfig`` (``fcnet_hiddens``,
                            ``fcnet_activation``, …)
==========================  =======================================================================

Output folder (``--out``; default ``runs/<config-stem>/``; an existing non-empty folder only
with ``--overwrite``): ``checkpoint/`` (``Algorithm.save_to_path``), ``manifest.json`` (SHA-256
of every checkpoint file: RLlib checkpoints are pickles, :func:`load_rllib_policy` loads only a
listed, unchanged checkpoint unless trusted), ``progress.csv`` (per iteration: env steps, mean
episode return, wall time), ``eval.csv`` (the evaluation of the policy reloaded from the saved
checkpoint on the evaluation env, the columns of :func:`agents.training.train.evaluate`) and
``config.yaml`` (the resolved config plus a ``run`` section: versions, wall time, steps/s).

Ray: a local instance with as many CPUs as the env runners need (``ray.init(num_cpus=...)``),
or an existing cluster with ``--address``.
"""

from __future__ import annotations

import dataclasses
import inspect
import json
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents._extras import extra_error
from agents._predict import SB3Predict
from agents.commands.flags import error_status
from agents.commands.train_rllib import MAX_ITERATIONS, build_parser
from agents.policies.policy_io import RLLIB_MODULE_PATH, refuse_untrusted, sha256
from railgym import _checks as val
from railgym.progress import quiet
from railgym.report.output import prepare_output_dir, write_text_atomic

try:  # the 'rllib' extra (ray, torch) and the SB3 evaluation of the 'agents' extra
    import ray
    import torch
    from ray.rllib.algorithms.algorithm_config import AlgorithmConfig
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
    from ray.rllib.core.rl_module.rl_module import RLModule
    from ray.tune.registry import register_env

    from agents.training.run_files import (
        read_run,
        run_folder,
        speed_text,
        versions,
        write_config,
        write_csv,
    )
    from agents.training.train import evaluate, make_vec
    from agents.training.train_config import (
        EVAL_SEED,
        MAX_ENVS,
        MAX_SEED,
        RUN_KEY,
        checked_env_kwargs,
    )
except ImportError as _err:
    raise extra_error(_err, "RLlib training (agents.training.train_rllib)") from _err

ALGOS = ("ppo",)
#: RLlib's name of the native vector env creator (registered by :func:`_register`)
RLLIB_ENV = "railgym-native-vector"
#: where ``Algorithm.save_to_path`` puts the policy module
MODULE_PATH = RLLIB_MODULE_PATH
MANIFEST = "manifest.json"
FORMAT = "railgym-rllib-manifest/1"


@dataclass
class RLlibConfig:
    """A validated RLlib training config (see the module docstring for the fields)."""

    env_id: str
    iterations: int
    seed: int
    trainer: str = "rllib"
    algo: str = "ppo"
    num_env_runners: int = 2
    num_envs_per_env_runner: int = 8
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    eval_env_kwargs: dict[str, Any] = field(default_factory=dict)
    n_eval_episodes: int = 4
    eval_seed: int = EVAL_SEED
    training: dict[str, Any] = field(default_factory=dict)
    model: dict[str, Any] = field(default_factory=dict)

    def to_yaml_dict(self) -> dict[str, Any]:
        """The config-file form: ``{env_id: {...}}``."""
        block = asdict(self)
        del block["env_id"]
        return {self.env_id: block}


def _training_keys() -> set[str]:
    names = set(inspect.signature(PPOConfig.training).parameters)
    names |= set(inspect.signature(AlgorithmConfig.training).parameters)
    return names - {"self", "kwargs"}


def _check_names(value: Any, name: str, allowed: set[str]) -> dict[str, Any]:
    unknown = sorted(set(value) - allowed)
    if unknown:
        raise val.FieldError(name, f"has unknown keys {unknown} (allowed: {sorted(allowed)})")
    return dict(value)


def load_rllib_config(config: str | Path | dict[str, Any]) -> RLlibConfig:
    """Read and validate a config: a ``.yaml`` / ``.yml`` path, the name of a packaged config
    (``ppo_vertical_rllib``) or the content as a dict; errors name the field."""
    if isinstance(config, str | Path):
        text, source = val.resolve_yaml(config, "config", "railgym", ("configs", "agents"))
        config = val.load_yaml(text, source)
    if not isinstance(config, dict):
        raise val.FieldTypeError(
            "config", f"must be a mapping {{env id: settings}}, got {config!r}"
        )
    ids = [k for k in config if k != RUN_KEY]
    if len(ids) != 1 or ids[0] not in gym.registry:
        raise val.FieldError("config", f"must have one top-level key, a registered env id: {ids}")
    env_id = ids[0]
    f = val.Fields(config[env_id], env_id)
    fields = {x.name for x in dataclasses.fields(RLlibConfig)} - {"env_id"}
    _check_names(f.data, env_id, fields)
    if f.get("trainer", None) != "rllib":
        raise val.FieldError(f.field("trainer"), f"must be 'rllib', got {f.get('trainer', None)!r}")
    algo = val.choice(f.get("algo", "ppo"), f.field("algo"), ALGOS)
    seed = f.get("seed", None)
    if seed is None:
        seed = int(np.random.default_rng().integers(2**31))  # OS entropy, recorded
    model_fields = {x.name for x in dataclasses.fields(DefaultModelConfig)}
    training = checked_env_kwargs(f.get("training", None), f.field("training"))
    model = checked_env_kwargs(f.get("model", None), f.field("model"))
    return RLlibConfig(
        env_id=env_id,
        iterations=f.integer("iterations", min=1, max=MAX_ITERATIONS),
        seed=val.integer(seed, f.field("seed"), min=0, max=MAX_SEED),
        algo=algo,
        num_env_runners=val.integer(f.get("num_env_runners", 2), f.field("num_env_runners"), 0),
        num_envs_per_env_runner=val.integer(
            f.get("num_envs_per_env_runner", 8), f.field("num_envs_per_env_runner"), 1, MAX_ENVS
        ),
        env_kwargs=checked_env_kwargs(f.get("env_kwargs", None), f.field("env_kwargs")),
        eval_env_kwargs=checked_env_kwargs(
            f.get("eval_env_kwargs", None), f.field("eval_env_kwargs")
        ),
        n_eval_episodes=val.integer(
            f.get("n_eval_episodes", 4), f.field("n_eval_episodes"), 1, MAX_ENVS
        ),
        eval_seed=val.integer(f.get("eval_seed", EVAL_SEED), f.field("eval_seed"), 0, MAX_SEED),
        training=_check_names(training, f.field("training"), _training_keys()),
        model=_check_names(model, f.field("model"), model_fields),
    )


def native_vector_env(ctx: dict[str, Any]) -> gym.vector.VectorEnv:
    """RLlib env creator: the env's native vector env with ``ctx["num_envs"]`` sub-envs;
    ``ctx["env_id"]`` the Gymnasium id, the other entries its keyword arguments."""
    kwargs = {k: v for k, v in dict(ctx).items() if k not in ("num_envs", "env_id")}
    return make_vec(ctx["env_id"], int(ctx.get("num_envs", 1)), kwargs, "vector_entry_point")


def build_algo_config(cfg: RLlibConfig) -> PPOConfig:
    """The RLlib ``PPOConfig`` of ``cfg``: new API stack, native vector envs, CPU learner."""
    training = {
        k: float(v) if isinstance(v, str) else v for k, v in cfg.training.items()
    }  # YAML reads ``3e-4`` as text
    return (
        PPOConfig()
        .api_stack(enable_rl_module_and_learner=True, enable_env_runner_and_connector_v2=True)
        .environment(RLLIB_ENV, env_config={"env_id": cfg.env_id, **cfg.env_kwargs})
        .env_runners(
            num_env_runners=cfg.num_env_runners,
            num_envs_per_env_runner=cfg.num_envs_per_env_runner,
            gym_env_vectorize_mode="vector_entry_point",
            num_cpus_per_env_runner=1,
        )
        .learners(num_learners=0, num_gpus_per_learner=0)
        .training(**training)
        .rl_module(model_config=DefaultModelConfig(**cfg.model))
        .debugging(seed=cfg.seed)
    )


class RLlibPolicy(SB3Predict):
    """SB3-style ``predict`` on an RLlib ``RLModule``: the deterministic action of its
    action distribution (the mean for a Gaussian), clipped to the action space."""

    def __init__(self, module: RLModule, action_space: gym.spaces.Box) -> None:
        self.module = module
        self.low, self.high = action_space.low, action_space.high
        self.dist = module.get_inference_action_dist_cls()

    def predict_action(
        self, observation: Any, episode_start: Any, deterministic: bool
    ) -> np.ndarray:
        """Actions (n, n_act) for observations (n, n_obs); stochastic unless ``deterministic``."""
        obs = torch.as_tensor(np.asarray(observation, np.float32))
        with torch.no_grad():
            out = self.module.forward_inference({"obs": obs})
            dist = self.dist.from_logits(out["action_dist_inputs"])
            action = (dist.to_deterministic() if deterministic else dist).sample().numpy()
        return np.clip(action, self.low, self.high).astype(np.float32)


def write_checkpoint_manifest(checkpoint: Path) -> Path:
    """``manifest.json`` beside ``checkpoint``: SHA-256 of every file under it."""
    files = {
        p.relative_to(checkpoint).as_posix(): sha256(p)
        for p in sorted(checkpoint.rglob("*"))
        if p.is_file()
    }
    path = checkpoint.parent / MANIFEST
    write_text_atomic(path, json.dumps({"format": FORMAT, "sha256": files}, indent=2) + "\n")
    return path


def check_checkpoint_manifest(checkpoint: Path, trust: bool = False) -> None:
    """Refuse (``ValueError``) a checkpoint whose files are not exactly those listed with their
    hashes in the ``manifest.json`` beside it; with ``trust`` only warn."""
    checkpoint = Path(checkpoint)
    manifest = checkpoint.parent / MANIFEST
    try:
        listed = json.loads(manifest.read_text(encoding="utf-8"))["sha256"]
    except (OSError, ValueError, KeyError, TypeError) as err:
        problem = f"{manifest} is missing or unreadable ({err})"
    else:
        files = {
            p.relative_to(checkpoint).as_posix(): p for p in checkpoint.rglob("*") if p.is_file()
        }
        same = set(files) == set(listed) and all(sha256(files[k]) == listed[k] for k in files)
        problem = None if same else f"its files differ from those listed in {manifest}"
    if problem is not None:
        refuse_untrusted(
            f"RLlib checkpoint {checkpoint}: {problem}; it is a pickle and may run code",
            trust,
            " (pass trust=True / --trust to load it anyway)",
            "; loading it because of trust",
        )


def load_rllib_policy(checkpoint: str | Path, env_id: str, trust: bool = False) -> RLlibPolicy:
    """The policy of a checkpoint written by :func:`train_rllib` (manifest checked)."""
    checkpoint = Path(checkpoint)
    if not (checkpoint / MODULE_PATH).is_dir():
        raise ValueError(f"{checkpoint} is not an RLlib algorithm checkpoint (no {MODULE_PATH})")
    check_checkpoint_manifest(checkpoint, trust)
    module = RLModule.from_checkpoint(checkpoint / MODULE_PATH)
    probe = gym.make(env_id)
    policy = RLlibPolicy(module, probe.action_space)
    probe.close()
    return policy


def _progress_row(result: dict[str, Any], wall: float) -> dict[str, Any]:
    runners = result.get("env_runners", {})
    return {
        "iteration": result["training_iteration"],
        "env_steps": int(result.get("num_env_steps_sampled_lifetime", 0)),
        "episode_return_mean": float(runners.get("episode_return_mean", np.nan)),
        "wall_s": round(wall, 2),
    }


def train_rllib(
    config: str | Path | dict[str, Any],
    out: str | Path | None = None,
    iterations: int | None = None,
    seed: int | None = None,
    address: str | None = None,
    overwrite: bool = False,
) -> Path:
    """Train, save a checkpoint, reload it and evaluate it; returns the output folder.

    ``out`` defaults to ``runs/<config stem>/`` (required for a dict config);
    ``iterations`` and ``seed`` override the config; ``address`` joins a Ray cluster.
    """
    cfg = load_rllib_config(config)
    out = run_folder(config, out)
    if iterations is not None:
        cfg.iterations = val.integer(iterations, "iterations", 1, MAX_ITERATIONS)
    if seed is not None:
        cfg.seed = val.integer(seed, "seed", min=0, max=MAX_SEED)
    out = prepare_output_dir(out, overwrite)
    run: dict[str, Any] = {"versions": versions(ray, torch)}
    write_config(out, cfg, run)
    started = not ray.is_initialized()
    if started:
        if address is None:
            ray.init(num_cpus=max(cfg.num_env_runners, 1) + 1, include_dashboard=False)
        else:
            ray.init(address=address)
    try:
        register_env(RLLIB_ENV, native_vector_env)
        algo = build_algo_config(cfg).build_algo()
        rows, t0 = [], time.perf_counter()
        for _ in range(cfg.iterations):
            result = algo.train()
            rows.append(_progress_row(result, time.perf_counter() - t0))
        wall = time.perf_counter() - t0
        checkpoint = Path(algo.save_to_path(str((out / "checkpoint").resolve())))
        algo.stop()
    finally:
        if started:
            ray.shutdown()
    write_checkpoint_manifest(checkpoint)
    write_csv(out / "progress.csv", rows)
    policy = load_rllib_policy(checkpoint, cfg.env_id)
    eval_kwargs = {**cfg.env_kwargs, **cfg.eval_env_kwargs}
    venv = make_vec(cfg.env_id, cfg.n_eval_episodes, eval_kwargs, "vector_entry_point")
    stats = evaluate(policy, venv, cfg.eval_seed)
    venv.close()
    write_csv(out / "eval.csv", [{"timesteps": rows[-1]["env_steps"], **stats}])
    steps = rows[-1]["env_steps"]
    run.update(wall_s=round(wall, 1), steps_per_s=round(steps / wall, 1), timesteps=steps)
    run["eval"] = {k: stats[k] for k in ("mean_reward", "std_reward", "mean_length")}
    write_config(out, cfg, run)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``railgym train-rllib``; returns the exit status (2: user error)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with quiet(args.quiet):
            out = train_rllib(
                args.config, args.out, args.iterations, args.seed, args.address, args.overwrite
            )
    except Exception as err:
        return error_status(parser.prog, err, args.debug)
    run = read_run(out)
    reward = run["eval"]["mean_reward"]
    print(f"{speed_text(run)}; evaluation reward {reward:.4g}; checkpoint, logs in {out}/")
    return 0
