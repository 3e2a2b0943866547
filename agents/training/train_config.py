"""Training configs of :mod:`agents.training.train`: reading, checks and the resolved form.

Config file: one top-level key, the Gymnasium env id, holding

======================  ==========================================================================
``algo``                ``ppo``, ``sac``, ``td3`` or ``a2c`` (required)
``n_timesteps``         total environment steps (all sub-envs together)
``policy``              stable-baselines3 policy name, e.g. ``MlpPolicy``
``n_envs``              sub-envs of the vector env (``gym.make_vec``), at most 1024
                        (``MAX_ENVS``)
``seed``                seeds python/numpy/torch and the envs (sub-env ``i``: ``seed + i``),
                        0 … 2³² − 1; drawn at random and recorded when absent
``env_kwargs``          passed to ``gym.make_vec`` (e.g. ``backend``, ``duration``, ``vehicle:
                        my_car.yaml``); a relative file path (``vehicle``, ``surrogate``,
                        ``fmu``, ``fmu_map``, ``profile``) is read beside the config file
``eval_env_kwargs``     overrides of ``env_kwargs`` for the evaluation env (e.g. ``backend:
                        reference``)
``eval_freq``           steps between evaluations; ``n_eval_episodes``: episodes per evaluation
                        (one per sub-env of the evaluation env, at most ``MAX_ENVS``);
                        ``eval_seed`` (default 999999, the same for every run): the same
                        evaluation tracks every time
``eval_echo``           ``info`` entries printed with each evaluation (e.g.
                        ``[rms_carbody_acc]``); all of them go to ``eval.csv``
``checkpoint_freq``     steps between checkpoints
``n_threads``           torch CPU threads (default 1: small networks are fastest on one
                        thread), at most 256
``env_threads``         numba threads of the env kernels while training (default 1, at most
                        256): torch's and numba's OpenMP threads spin-wait for the cores
                        between their parallel regions, and alternating rollouts and updates
                        on more threads than cores ran the env ~10 × slower (docs/results.md,
                        *Training throughput*)
``envelope``            per-episode track class and speed of the training env (vertical and
                        vehicle envs; :mod:`agents.training.envelope`): ``track_class`` (list),
                        ``speed_kmh`` ([min, max]; absent: each class's maximum speed)
``action_hold``         env steps per decision of the policy (default 1): the action is held
                        in between, in training and wherever the policy is loaded
                        (:mod:`agents.controllers.action_hold`), at most 1000; ``n_timesteps``, the
                        evaluation and checkpoint intervals then count decisions
``residual``            a classical controller (its ``railgym evaluate`` name, e.g. ``lqg``) whose
                        action the policy's is added to (:mod:`agents.controllers.residual`), in
                        training and wherever the policy is loaded; ``residual_scale`` (default 1,
                        at most 2): the weight of the policy's action. Native vector envs and
                        ``action_hold`` 1 only
``vectorization_mode``  ``vector_entry_point`` (the env's native vector env, default where it
                        has one) or ``sync`` (a ``SAME_STEP`` ``SyncVectorEnv`` of single
                        envs)
everything else         hyperparameters of the algorithm (``learning_rate``, ``n_steps``,
                        ``policy_kwargs`` with ``net_arch`` and ``activation_fn`` as a name, …);
                        ``lin_<v>`` is a schedule falling linearly from ``v`` to 0 (rl-zoo3)
======================  ==========================================================================

Config errors name the field (``n_envs must be at least 1, got 0``; a YAML syntax error names
the file and line). The common stable-baselines3 hyperparameters are checked here as well
(:data:`INT_HYPERPARAMETERS`, :data:`UNIT_HYPERPARAMETERS`, ...; ``policy_kwargs.net_arch``),
so that a bad value is one error naming it before any env is built; others go to SB3.
"""

from __future__ import annotations

import inspect
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import A2C, PPO, SAC, TD3
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.utils import LinearSchedule

from agents.controllers.action_hold import check_hold
from agents.controllers.residual import check_scale
from railgym import _checks as val
from surrogates.checks import MAX_SEED

__all__ = ["ALGOS", "TrainConfig", "hyperparameters", "load_config"]

ALGOS: dict[str, type[BaseAlgorithm]] = {"ppo": PPO, "sac": SAC, "td3": TD3, "a2c": A2C}
ACTIVATIONS = {
    "tanh": torch.nn.Tanh,
    "relu": torch.nn.ReLU,
    "elu": torch.nn.ELU,
    "leakyrelu": torch.nn.LeakyReLU,
    "silu": torch.nn.SiLU,
}
VECTORIZATION_MODES = ("vector_entry_point", "sync")
#: default seed of the evaluation env: every run is evaluated on the same tracks
EVAL_SEED = 999_999
#: top-level key of the saved config that :func:`load_config` ignores
RUN_KEY = "run"
#: most sub-envs of the training or the evaluation vector env
MAX_ENVS = 1024
#: keys of rl-zoo3's hyperparameter files that agents.training.train does not implement
RLZOO_ONLY = (
    "normalize",
    "normalize_kwargs",
    "frame_stack",
    "env_wrapper",
    "vec_env_wrapper",
    "callback",
)
#: most torch CPU threads
MAX_THREADS = 256
#: most environment steps of one run (and most steps between evaluations or checkpoints):
#: days of training at the envs' speeds; a larger count is a typo, not a plan
MAX_TIMESTEPS = 10**9


@dataclass
class TrainConfig:
    """A validated training config (see the module docstring for the fields)."""

    env_id: str
    algo: str
    n_timesteps: int
    policy: str
    n_envs: int
    seed: int
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    eval_env_kwargs: dict[str, Any] = field(default_factory=dict)
    eval_freq: int = 10_000
    n_eval_episodes: int = 4
    eval_seed: int = EVAL_SEED
    checkpoint_freq: int = 50_000
    n_threads: int = 1
    env_threads: int = 1
    vectorization_mode: str | None = None
    eval_echo: list[str] = field(default_factory=list)
    envelope: dict[str, Any] | None = None
    action_hold: int = 1
    residual: str | None = None
    residual_scale: float = 1.0
    hyperparameters: dict[str, Any] = field(default_factory=dict)

    def to_yaml_dict(self) -> dict[str, Any]:
        """The config-file form: ``{env_id: {...}}``."""
        block = asdict(self)
        del block["env_id"]
        block.update(block.pop("hyperparameters"))
        return {self.env_id: block}


def _names(value: Any, field: str) -> list[str]:
    """A list of names (``eval_echo``); ``None`` is the empty list."""
    names = list(val.sequence([] if value is None else value, field))
    for i, name in enumerate(names):
        if not isinstance(name, str):
            raise val.FieldTypeError(f"{field}[{i}]", f"must be a name, got {name!r}")
    return names


#: env arguments that name a file (a relative one is read beside the config file)
PATH_ARGUMENTS = ("vehicle", "surrogate", "fmu", "fmu_map", "profile")


def checked_env_kwargs(value: Any, field: str, folder: Path | None = None) -> dict[str, Any]:
    """A mapping of env arguments; ``None`` is the empty mapping. A relative path of
    :data:`PATH_ARGUMENTS` that names a file in ``folder`` (the config file's) becomes that
    file, so a config works from any working directory."""
    out = dict(val.mapping({} if value is None else value, field))
    for key in PATH_ARGUMENTS:
        arg = out.get(key)
        if folder is not None and isinstance(arg, str) and not Path(arg).is_absolute():
            local = folder / arg
            if local.is_file():  # absolute: the run's config.yaml loads from anywhere
                out[key] = str(local.resolve())
    return out


#: integer hyperparameters of SB3 and their smallest value
INT_HYPERPARAMETERS = {
    "n_steps": 1,
    "batch_size": 1,
    "n_epochs": 1,
    "buffer_size": 1,
    "learning_starts": 0,
    "gradient_steps": -1,
    "policy_delay": 1,
    "sde_sample_freq": -1,
    "stats_window_size": 1,
}
#: hyperparameters in [0, 1]
UNIT_HYPERPARAMETERS = ("gamma", "gae_lambda", "tau")
#: hyperparameters > 0 (a number, or a ``lin_<v>`` schedule for the first two)
POSITIVE_HYPERPARAMETERS = ("learning_rate", "clip_range", "max_grad_norm")
#: hyperparameters >= 0 (SAC's ``ent_coef`` may also be ``auto`` / ``auto_<v>``)
NON_NEGATIVE_HYPERPARAMETERS = ("ent_coef", "vf_coef", "target_policy_noise", "target_noise_clip")
#: boolean hyperparameters
BOOL_HYPERPARAMETERS = ("use_sde", "normalize_advantage", "optimize_memory_usage")


def _number(key: str, text: str) -> float | str:
    """A number written as text (YAML reads ``3e-4`` as a string); other text unchanged."""
    try:
        number = float(text)
    except ValueError:
        return text
    return val.real(number, key)


def _check_hyperparameter(key: str, value: Any, algo: type[BaseAlgorithm]) -> None:
    """Type and range of the hyperparameters in the tables above (others are SB3's)."""
    if isinstance(value, LinearSchedule):
        return
    if key == "ent_coef" and algo is SAC and isinstance(value, str):
        if value != "auto" and not value.startswith("auto_"):
            raise val.FieldError(key, f"must be a number or 'auto' / 'auto_<v>', got {value!r}")
        return
    if key in INT_HYPERPARAMETERS:
        val.integer(value, key, min=INT_HYPERPARAMETERS[key])
    elif key in UNIT_HYPERPARAMETERS:
        val.in_range(value, key, 0.0, 1.0)
    elif key in POSITIVE_HYPERPARAMETERS:
        val.positive(value, key)
    elif key in NON_NEGATIVE_HYPERPARAMETERS:
        val.non_negative(value, key)
    elif key in BOOL_HYPERPARAMETERS:
        val.boolean(value, key)


def _net_arch(value: Any, field: str) -> Any:
    """``net_arch``: a list of layer widths, or a mapping of such lists (``pi``, ``vf``, ``qf``)."""
    if isinstance(value, dict):
        return {k: _net_arch(v, f"{field}.{k}") for k, v in value.items()}
    return [
        val.integer(w, f"{field}[{i}]", min=1, max=1 << 16)
        for i, w in enumerate(val.sequence(value, field))
    ]


def hyperparameters(algo: type[BaseAlgorithm], hyper: dict[str, Any]) -> dict[str, Any]:
    """Hyperparameters of ``algo`` as SB3 takes them, checked.

    Names are checked against the algorithm's signature and the common ones by type and range
    (module docstring); numbers written as strings become floats, rl-zoo3's ``lin_<v>`` a
    schedule from ``v`` (> 0) down to 0, ``policy_kwargs.activation_fn`` (a name) a torch
    module, and ``policy_kwargs.net_arch`` must be layer widths.
    """
    allowed = set(inspect.signature(algo.__init__).parameters) - {"self", "policy", "env"}
    out: dict[str, Any] = {}
    for key, value in hyper.items():
        if key in RLZOO_ONLY:
            raise val.FieldError(
                key,
                f"rl-zoo3's {key!r} is not supported by agents.training.train (train this file "
                "with python -m rl_zoo3.train)",
                full=True,
            )
        if key == "policy_kwargs" and isinstance(value, str):
            raise val.FieldError(
                key,
                "is a Python expression (rl-zoo3's string form), which is never evaluated: "
                "write it as a mapping (net_arch: [64, 64], activation_fn: tanh)",
            )
        if key not in allowed:
            raise val.FieldError(
                key,
                f"unknown config key {key!r}: not a run setting nor a "
                f"hyperparameter of {algo.__name__}",
                full=True,
            )
        if isinstance(value, str) and value.startswith("lin_"):
            start = _number(key, value[4:])
            if isinstance(start, str):
                raise val.FieldError(key, f"must be a number or 'lin_<number>', got {value!r}")
            value = LinearSchedule(val.positive(start, key), 0.0, 1.0)
        elif isinstance(value, str):
            value = _number(key, value)
        _check_hyperparameter(key, value, algo)
        out[key] = value
    pk = out.get("policy_kwargs")
    if pk is not None:
        pk = dict(val.mapping(pk, "policy_kwargs"))
        act = pk.get("activation_fn")
        if isinstance(act, str):
            name = act.lower().removeprefix("nn.").replace("_", "")
            if name not in ACTIVATIONS:
                raise val.FieldError(
                    "policy_kwargs.activation_fn",
                    f"must be one of {sorted(ACTIVATIONS)}, got {act!r}",
                )
            pk["activation_fn"] = ACTIVATIONS[name]
        if "net_arch" in pk:
            pk["net_arch"] = _net_arch(pk["net_arch"], "policy_kwargs.net_arch")
        out["policy_kwargs"] = pk
    return out


def _env_block(config: str | Path | dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """The env id and its settings of a config (file, packaged name or dict): exactly one
    top-level key, a registered env, an SB3 (not RLlib) run."""
    source = "config"
    if isinstance(config, str | Path):
        text, source = val.resolve_yaml(config, "config", "railgym", ("configs", "agents"))
        config = val.load_yaml(text, source)
    if not isinstance(config, dict):
        raise val.FieldTypeError(
            "config", f"must be a mapping {{env id: settings}}, got {config!r}", full=False
        )
    ids = [k for k in config if k != RUN_KEY]
    if len(ids) != 1:
        raise val.FieldError(
            "config",
            "config must have exactly one top-level key, the env id (e.g. "
            f"'railgym/VerticalSuspension-v1'), got {ids}",
            full=True,
        )
    env_id = ids[0]
    if env_id not in gym.registry:
        raise val.FieldError(
            "env id",
            f"{source}: env id {env_id!r} is not a registered Gymnasium env (the config's "
            "top-level key)",
            full=True,
        )
    block = config[env_id]
    if not isinstance(block, dict):
        raise val.FieldTypeError(
            env_id, f"settings of {env_id!r} must be a mapping, got {block!r}", full=True
        )
    if block.get("trainer", "sb3") == "rllib":
        raise val.FieldError("trainer", "is 'rllib': train this file with railgym train-rllib")
    return env_id, block


def _envelope(envelope: Any, env_id: str, mode: str | None) -> dict[str, Any] | None:
    """The checked ``envelope`` of a crash-env run as a dict (``None``: none)."""
    if envelope is None:
        return None
    from agents.training.envelope import ENVELOPE_ENVS, check_envelope
    from railgym.registration import env_family

    if env_family(env_id) not in ENVELOPE_ENVS:
        raise val.FieldError("envelope", f"is for {list(ENVELOPE_ENVS)}, not {env_id}")
    if mode == "sync":
        raise val.FieldError("envelope", "needs the native vector env, not sync")
    return check_envelope(envelope).to_dict()


def _residual(name: Any, env_id: str, mode: str | None, hold: int) -> str | None:
    """The checked ``residual`` controller name (``None``: none)."""
    if name is None:
        return None
    from agents.controllers.registry import controllers_of

    controllers = controllers_of(env_id)
    if not controllers:
        raise val.FieldError("residual", f"{env_id} has no classical controllers")
    name = val.choice(name, "residual", sorted(controllers))
    if mode == "sync":
        raise val.FieldError("residual", "needs the native vector env, not sync")
    if hold > 1:
        raise val.FieldError(
            "residual", f"needs action_hold 1 (its controller acts every step), got {hold}"
        )
    return name


def load_config(config: str | Path | dict[str, Any], algo: str | None = None) -> TrainConfig:
    """Read and validate a config: path of a ``.yaml`` / ``.yml`` file, the name of a packaged
    config (``ppo_vertical``, see ``railgym/configs/agents/``) or the content as a dict.

    rl-zoo3's hyperparameter files are read too: they have no ``algo`` (rl-zoo3 takes it
    from ``--algo``), which ``algo`` then gives; their evaluation and checkpoint settings take
    the defaults here. A missing ``seed`` is drawn from the OS entropy, so that it can be
    recorded.
    """
    env_id, block = _env_block(config)
    folder = None
    if isinstance(config, str | Path) and Path(config).suffix in (".yaml", ".yml"):
        folder = Path(config).parent
    f = val.Fields(block, "")
    if algo is not None:
        algo = val.choice(algo, "--algo", sorted(ALGOS))
        if block.get("algo", algo) != algo:
            raise val.FieldError("algo", f"is {block['algo']!r} in the file but --algo is {algo!r}")
    algo = val.choice(f.get("algo", algo), "algo", sorted(ALGOS))
    policy = f.get("policy", "MlpPolicy")
    if not isinstance(policy, str) or not policy:
        raise val.FieldTypeError("policy", f"must be a policy name, got {policy!r}")
    mode = f.get("vectorization_mode", None)
    if mode is not None:
        mode = val.choice(mode, "vectorization_mode", VECTORIZATION_MODES)
    seed = f.get("seed", None)
    if seed is None:
        seed = int(np.random.default_rng().integers(2**31))  # OS entropy

    def count(key: str, default: int | None, lo: int = 1, hi: int | None = None) -> int:
        raw = f.get(key) if default is None else f.get(key, default)
        return val.integer(raw, key, min=lo, max=hi)

    run_keys = set(TrainConfig.__dataclass_fields__) - {"env_id", "hyperparameters"}
    hyper = {k: v for k, v in block.items() if k not in run_keys}
    hyperparameters(ALGOS[algo], hyper)  # validates; applied by train()
    envelope = _envelope(f.get("envelope", None), env_id, mode)
    hold = check_hold(f.get("action_hold", 1))
    residual = _residual(f.get("residual", None), env_id, mode, hold)
    if residual is None and block.get("residual_scale", 1.0) != 1.0:  # 1.0: the default
        raise val.FieldError(
            "residual_scale", "is given without residual: (it scales a residual policy's action)"
        )
    return TrainConfig(
        env_id=env_id,
        algo=algo,
        policy=policy,
        seed=val.integer(seed, "seed", min=0, max=MAX_SEED),
        n_timesteps=count("n_timesteps", None, hi=MAX_TIMESTEPS),
        n_envs=count("n_envs", 1, hi=MAX_ENVS),
        env_kwargs=checked_env_kwargs(f.get("env_kwargs", None), "env_kwargs", folder),
        eval_env_kwargs=checked_env_kwargs(
            f.get("eval_env_kwargs", None), "eval_env_kwargs", folder
        ),
        eval_freq=count("eval_freq", 10_000, hi=MAX_TIMESTEPS),
        n_eval_episodes=count("n_eval_episodes", 4, hi=MAX_ENVS),
        eval_seed=count("eval_seed", EVAL_SEED, lo=0, hi=MAX_SEED),
        checkpoint_freq=count("checkpoint_freq", 50_000, hi=MAX_TIMESTEPS),
        n_threads=count("n_threads", 1, hi=MAX_THREADS),
        env_threads=count("env_threads", 1, hi=MAX_THREADS),
        vectorization_mode=mode,
        eval_echo=_names(f.get("eval_echo", None), "eval_echo"),
        envelope=envelope,
        action_hold=hold,
        residual=residual,
        residual_scale=check_scale(f.get("residual_scale", 1.0)),
        hyperparameters=hyper,
    )
