"""Loading a policy by what the user names: a controller name (:mod:`agents.controllers.registry`),
a pretrained policy (:mod:`agents.policies.pretrained`), a stable-baselines3 ``.zip``
(:mod:`agents.policies.policy_zip`; manifest checked, only the network weights read:
:mod:`agents.policies.policy_io`) or an RLlib checkpoint folder, as a factory
``env → object with predict`` (:func:`load_policy`); the actuator a trained policy was trained
with (:func:`trained_actuator`).

The commands that run these policies are in :mod:`agents.evaluation`.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from agents._extras import require
from agents.controllers.action_hold import HeldPolicy
from agents.controllers.registry import CRASH_ID, ENV_ID, build_controller, controllers_of
from agents.controllers.residual import ResidualPolicy
from agents.policies.policy_io import RLLIB_MODULE_PATH, check_manifest, load_policy_weights
from agents.policies.policy_zip import PolicySource, find_source, zip_network
from agents.policies.pretrained import PRETRAINED, pretrained_zip
from railgym import _checks as val
from railgym.registration import env_family

__all__ = [
    "POLICY_ENV_KWARGS",
    "RESIDUAL_DESIGN_KWARGS",
    "design_env_kwargs",
    "load_policy",
    "trained_actuator",
    "without_version_warning",
]


def _rllib_policy(path: Path, env_id: str, trust: bool) -> tuple[Any, dict[str, Any], str]:
    """:func:`load_policy` for an RLlib checkpoint folder (needs the ``rllib`` extra)."""
    try:
        from agents.training.train_rllib import load_rllib_policy
    except ImportError as err:
        raise ValueError(
            f"policy {path} is an RLlib checkpoint: install the 'rllib' extra to load it ({err})"
        ) from err
    policy = load_rllib_policy(path, env_id, trust)
    return (lambda env: policy), {}, f"rllib:{path.name}"


def load_policy(
    policy: str, env_id: str = ENV_ID, trust: bool = False
) -> tuple[Any, dict[str, Any], str]:
    """``(factory(env) → object with predict, env kwargs it needs, label)`` for a name or zip.

    A zip must be listed with its SHA-256 in the ``manifest.json`` that :mod:`agents.training.train`
    writes beside it (or ``trust`` given, with a warning); only its network weights are read
    (:func:`agents.policies.policy_io.load_policy_weights`), nothing in it is unpickled or run.
    """
    if not isinstance(policy, str | Path):
        raise val.FieldTypeError("policy", f"must be a controller name or a path, got {policy!r}")
    policy = str(policy)
    controllers = controllers_of(env_id)
    if policy in controllers:
        cls, kwargs, env_kwargs = controllers[policy]
        return (lambda env: cls(env, **kwargs)), env_kwargs, policy
    pretrained = policy in PRETRAINED
    if (
        pretrained
    ):  # shipped in the package (agents.policies.pretrained), for any version of its env
        policy = str(pretrained_zip(policy, env_id))
    path = Path(policy)
    if path.is_dir() and (path / RLLIB_MODULE_PATH).is_dir():
        return _rllib_policy(path, env_id, trust)
    if path.suffix != ".zip" or not path.is_file():
        names = f"one of {sorted(controllers)}, " if controllers else ""
        raise ValueError(
            f"policy must be {names}an existing stable-baselines3 .zip or an RLlib checkpoint "
            f"folder, got {policy!r}"
        )
    return _sb3_policy(path, env_id, trust, pretrained)


def trained_actuator(policy: str, env_id: str = ENV_ID) -> str | None:
    """The actuator (``"force"`` or ``"semi-active"``) a trained policy was trained with, read
    from its run's settings without loading it: an :mod:`agents.training.train` or rl-zoo3 zip (or a
    pretrained name); ``None`` for a controller name, an RLlib checkpoint, a bare zip (its env
    comes from the command) or a path that is not there (:func:`load_policy` says why)."""
    if not isinstance(policy, str | Path) or str(policy) in controllers_of(env_id):
        return None
    policy = str(policy)
    if policy in PRETRAINED:
        try:
            path = pretrained_zip(policy, env_id)
        except ValueError:
            return None
    else:
        path = Path(policy)
    if path.suffix != ".zip" or not path.is_file():
        return None
    source = find_source(path)
    if source.kind == "agents.training.train":
        from agents.training.train_config import load_config

        env_kwargs = load_config(source.config).env_kwargs
    elif source.kind == "rl-zoo3":
        env_kwargs = source.env_kwargs
    else:
        return None
    return str(env_kwargs.get("actuator", "force"))


#: the env arguments a trained policy carries to the env it runs on (they shape its
#: observation and action); the others are the run's own
POLICY_ENV_KWARGS = frozenset(
    {
        "observation",
        "sensor_noise",
        "f_max",
        "control_dt",
        "wheelbase",
        "absorber_range",
        "absorber_rate",
        "n_cars",
        "scenario",
        "n_actuators",
        "flexible",
        "vehicle",
        "actuator",
        "damper",
        "preview",
    }
)


#: the training env arguments a residual policy's controller is designed with (its case)
RESIDUAL_DESIGN_KWARGS = POLICY_ENV_KWARGS | {"track_class", "speed", "reward_weights"}


def design_env_kwargs(env_id: str, kwargs: dict[str, Any]) -> dict[str, Any]:
    """``kwargs`` of an env made only for its spaces and its controller design: the linear
    backend of a track env (it needs nothing of the vehicle but its linear description, so a
    user's vehicle file works; no element is loaded), the crash env as it is."""
    if env_family(env_id) == env_family(CRASH_ID):
        return kwargs
    return {**kwargs, "backend": "linear"}


class _Network(NamedTuple):
    """What a stable-baselines3 zip was trained with."""

    trained_on: str  #: env id
    algo: str
    policy: str  #: SB3 policy class name
    net_kwargs: dict[str, Any]
    env_kwargs: dict[str, Any]
    obs_shape: tuple[int, ...] | None  #: from the zip's data entry (``None``: from a config)
    hold: int = 1  #: env steps per decision (``action_hold`` of an agents.training.train config)
    residual: str | None = None  #: controller the action is added to (``residual``)
    residual_scale: float = 1.0


def _network(path: Path, source: PolicySource, env_id: str) -> _Network:
    """The network and env of the zip ``path``: from its run's ``config.yaml``
    (agents.training.train), else from the zip's data entry (rl-zoo3 or a bare zip)."""
    from agents.training.train_config import ACTIVATIONS, ALGOS, hyperparameters, load_config

    if source.kind == "agents.training.train":
        cfg = load_config(source.config)
        hyper = hyperparameters(ALGOS[cfg.algo], cfg.hyperparameters)
        net_kwargs = dict(hyper.get("policy_kwargs") or {})
        if "use_sde" in hyper:
            net_kwargs["use_sde"] = hyper["use_sde"]
        return _Network(
            cfg.env_id,
            cfg.algo,
            cfg.policy,
            net_kwargs,
            cfg.env_kwargs,
            None,
            cfg.action_hold,
            cfg.residual,
            cfg.residual_scale,
        )
    algo, policy_name, net_kwargs, obs_shape = zip_network(path)
    if "activation_fn" in net_kwargs:
        act = net_kwargs["activation_fn"]
        if act not in ACTIVATIONS:
            raise ValueError(f"policy {path}: activation {act!r} is not supported")
        net_kwargs["activation_fn"] = ACTIVATIONS[act]
    trained_on = source.env_id or env_id
    return _Network(trained_on, algo, policy_name, net_kwargs, source.env_kwargs, obs_shape)


#: (policy, env id) pairs already warned of a version change: the warning is printed once
_WARNED: set[tuple[str, str]] = set()
#: the version warning of :func:`_sb3_policy` (after the policy's path), as a filter's regex
_VERSION_WARNING = r".*: the policy was trained on \S+ and runs on "


@contextmanager
def without_version_warning() -> Iterator[None]:
    """Within the block :func:`load_policy` gives no version warning: for a worker process
    loading a policy that its caller has loaded (and warned of) already."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=_VERSION_WARNING, category=UserWarning)
        yield


def _sb3_policy(
    path: Path, env_id: str, trust: bool, pretrained: bool
) -> tuple[Any, dict[str, Any], str]:
    """:func:`load_policy` of a stable-baselines3 zip: manifest checked, weights only."""
    require("loading a stable-baselines3 policy", "torch", "stable_baselines3")
    check_manifest(path, trust)
    source = find_source(path)
    network = _network(path, source, env_id)
    trained_on = network.trained_on
    where = source.config or path
    if env_family(trained_on) != env_family(env_id):
        raise ValueError(f"{where}: the policy was trained on {trained_on}, not {env_id}")
    if trained_on != env_id and not pretrained and (str(where), env_id) not in _WARNED:
        _WARNED.add((str(where), env_id))
        warnings.warn(
            f"{where}: the policy was trained on {trained_on} and runs on {env_id} (same "
            "spaces and reference model; the surrogate differs between versions)",
            UserWarning,
            stacklevel=3,
        )
    env_kwargs = {k: v for k, v in network.env_kwargs.items() if k in POLICY_ENV_KWARGS}
    probe = gym.make(env_id, **design_env_kwargs(env_id, env_kwargs))  # the single env's spaces
    obs_shape = network.obs_shape
    if obs_shape is not None and obs_shape != probe.observation_space.shape:
        raise ValueError(
            f"policy {path}: it takes observations of shape {obs_shape}, the env gives "
            f"{probe.observation_space.shape} (trained with other env settings: put its "
            "config.yaml, or rl-zoo3's folder, beside it)"
        )
    net = load_policy_weights(
        path,
        network.algo,
        network.policy,
        network.net_kwargs,
        probe.observation_space,
        probe.action_space,
    )
    probe.close()
    run = (source.config.parent if source.kind == "agents.training.train" else path.parent).name
    # rl-zoo3 names a run's final model after the env it trained on (whatever runs it now)
    final = path.parent.name == run and path.stem in ("model", trained_on.replace("/", "-"))
    label = run if final else f"{run}/{path.stem}"
    if network.hold > 1:  # trained to decide every `hold` steps: one held phase per factory call
        return (lambda env: HeldPolicy(net, network.hold)), env_kwargs, label
    name, scale = network.residual, network.residual_scale
    if name is not None:  # one controller per factory call, designed for the training case
        design = {k: v for k, v in network.env_kwargs.items() if k in RESIDUAL_DESIGN_KWARGS}
        design_env = gym.make(env_id, **design_env_kwargs(env_id, design))
        space = design_env.action_space
        bounds = (np.asarray(space.low, np.float64), np.asarray(space.high, np.float64))
        return (
            (
                lambda env: ResidualPolicy(
                    net, build_controller(env_id, name, design_env), scale, bounds
                )
            ),
            env_kwargs,
            label,
        )
    return (lambda env: net), env_kwargs, label
