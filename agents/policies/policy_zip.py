"""What a stable-baselines3 ``.zip`` was trained with, read without unpickling anything.

``railgym evaluate`` rebuilds a policy network from its algorithm, policy name and
``policy_kwargs`` and the env settings that shape its observations and actions
(:func:`agents.policies.policy_io.load_policy_weights` then reads only the weights). Those come
from, in this order:

1. an ``agents.training.train`` run: the nearest ``config.yaml`` in the zip's folder or up to
   :data:`LEVELS` folders above it (``runs/NAME/model.zip``, and the checkpoints
   ``runs/NAME/checkpoints/model_N_steps.zip``);
2. an rl-zoo3 run (``python -m rl_zoo3.train ... -f LOG``): the run folder
   ``LOG/ALGO/ENV_k/`` holds the zips (final, ``best_model.zip``, ``rl_model_N_steps.zip``)
   and a folder with ``args.yml`` (algorithm, env id, ``--env-kwargs``) and ``config.yml``
   (hyperparameters, ``env_kwargs``); these files carry Python tags
   (``!!python/object/apply:collections.OrderedDict``), which are read as plain mappings
   and nothing else;
3. nothing beside it: the env of the evaluation as given by its flags.

For 2 and 3 the algorithm, policy and ``policy_kwargs`` are taken from the zip's ``data``
entry, the JSON that SB3 writes: the readable fields only (the policy class's module,
``n_epochs``, the JSON copies of ``policy_kwargs`` entries), never its ``:serialized:``
pickles, except that the policy class name is read by disassembling its pickle
(:mod:`pickletools`, which runs nothing).
"""

from __future__ import annotations

import base64
import binascii
import json
import pickletools
import re
import zipfile
from pathlib import Path
from typing import Any, NamedTuple

import yaml

from railgym._checks import Yaml12Loader

__all__ = ["LEVELS", "PolicySource", "find_source", "zip_network"]

#: folders above the zip searched for its run's config
LEVELS = 2
#: largest ``data`` entry read from a zip, bytes
MAX_DATA_BYTES = 16 * 2**20
#: policy classes of SB3 → the policy name that builds them
POLICY_NAMES = {
    "ActorCriticPolicy": "MlpPolicy",
    "SACPolicy": "MlpPolicy",
    "TD3Policy": "MlpPolicy",
}
#: ``policy_kwargs`` entries that do not shape the network used for prediction
TRAINING_ONLY = {"optimizer_class", "optimizer_kwargs"}
#: ``policy_kwargs`` entries at their SB3 default when they name these classes
DEFAULT_CLASSES = {"features_extractor_class": "FlattenExtractor"}
_CLASS = re.compile(r"<class '([\w.]+)'>")


class PolicySource(NamedTuple):
    """Where the settings of a zip come from: ``kind`` (``"agents.training.train"``, ``"rl-zoo3"``
    or ``"zip"``), the ``config`` file (``None`` for a bare zip), the ``env_id`` it was
    trained on (``None``: unknown) and its ``env_kwargs``."""

    kind: str
    config: Path | None
    env_id: str | None
    env_kwargs: dict[str, Any]


class _ZooLoader(Yaml12Loader):
    """Safe YAML loader (YAML 1.2 floats are numbers) that also reads rl-zoo3's ordered
    dicts as plain mappings."""


def _ordered_dict(loader: yaml.SafeLoader, node: yaml.Node) -> dict[Any, Any]:
    if not isinstance(node, yaml.SequenceNode) or len(node.value) != 1:
        raise yaml.constructor.ConstructorError(None, None, "expected [[key, value], ...]", None)
    pairs = loader.construct_sequence(node.value[0], deep=True)
    return {k: v for k, v in pairs}


_ZooLoader.add_constructor(
    "tag:yaml.org,2002:python/object/apply:collections.OrderedDict", _ordered_dict
)


def read_zoo_yaml(path: Path) -> dict[str, Any]:
    """An rl-zoo3 ``args.yml`` / ``config.yml`` as a dict (any other Python tag is an error;
    so is a file that is not UTF-8 text, naming the file and the byte)."""
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise ValueError(
            f"{path}: not an rl-zoo3 settings file: not UTF-8 text (byte "
            f"{err.object[err.start]:#04x} at offset {err.start}); rl-zoo3 writes args.yml and "
            "config.yml as YAML text, so the file is damaged or another file took its name"
        ) from None
    try:
        data = yaml.load(text, Loader=_ZooLoader)  # noqa: S506
    except yaml.YAMLError as err:
        raise ValueError(f"{path}: not an rl-zoo3 settings file ({err})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping, got {type(data).__name__}")
    return data


def _zoo_folder(folder: Path) -> Path | None:
    """The sub-folder of an rl-zoo3 run folder holding ``args.yml`` and ``config.yml``."""
    found = [
        sub
        for sub in sorted(folder.iterdir())
        if sub.is_dir() and (sub / "args.yml").is_file() and (sub / "config.yml").is_file()
    ]
    return found[0] if found else None


def find_source(path: Path) -> PolicySource:
    """The run settings of the zip ``path`` (see the module docstring for the search)."""
    folder = path.resolve().parent
    for d in [folder, *folder.parents][: LEVELS + 1]:
        if (d / "config.yaml").is_file():
            return PolicySource("agents.training.train", d / "config.yaml", None, {})
        zoo = _zoo_folder(d)
        if zoo is not None:
            args = read_zoo_yaml(zoo / "args.yml")
            config = read_zoo_yaml(zoo / "config.yml")
            env_kwargs = {**(config.get("env_kwargs") or {}), **(args.get("env_kwargs") or {})}
            env_id = args.get("env")
            if not isinstance(env_id, str):
                raise ValueError(f"{zoo / 'args.yml'}: no env id under 'env'")
            return PolicySource("rl-zoo3", zoo / "config.yml", env_id, env_kwargs)
    return PolicySource("zip", None, None, {})


def zip_data(path: Path) -> dict[str, Any]:
    """The JSON ``data`` entry of the SB3 zip ``path`` (its ``:serialized:`` fields stay
    base64 text)."""
    try:
        with zipfile.ZipFile(path) as zf:
            info = zf.getinfo("data")
            if info.file_size > MAX_DATA_BYTES:
                raise ValueError(f"policy {path}: its data entry is over {MAX_DATA_BYTES} bytes")
            data = json.loads(zf.read(info))
    except KeyError:
        raise ValueError(f"policy {path}: no data entry, not a stable-baselines3 zip") from None
    except zipfile.BadZipFile as err:
        raise ValueError(f"policy {path}: not a zip file ({err})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ValueError(f"policy {path}: its data entry is not JSON ({err})") from None
    if not isinstance(data, dict):
        raise ValueError(f"policy {path}: its data entry is not a JSON object")
    return data


def _pickled_class_name(entry: dict[str, Any]) -> str | None:
    """Name of the class a ``:serialized:`` field pickles, read from its opcodes."""
    try:
        raw = base64.b64decode(entry.get(":serialized:", ""), validate=True)
        strings = [arg for op, arg, _ in pickletools.genops(raw) if isinstance(arg, str)]
    except (binascii.Error, ValueError):
        return None
    return strings[-1] if strings else None


def zip_network(path: Path) -> tuple[str, str, dict[str, Any], tuple[int, ...] | None]:
    """``(algo, policy name, policy_kwargs, observation shape)`` of an SB3 zip from its
    ``data`` entry; ``activation_fn`` as a name (``"relu"``), ``use_sde`` included."""
    data = zip_data(path)
    cls = data.get("policy_class")
    if not isinstance(cls, dict) or not isinstance(cls.get("__module__"), str):
        raise ValueError(f"policy {path}: its data entry does not name the policy class")
    module, name = cls["__module__"], _pickled_class_name(cls)
    if name not in POLICY_NAMES:
        raise ValueError(
            f"policy {path}: policy class {name!r} is not supported (MlpPolicy of PPO, A2C, "
            "SAC, TD3)"
        )
    algo = {
        "stable_baselines3.sac.policies": "sac",
        "stable_baselines3.td3.policies": "td3",
        "stable_baselines3.common.policies": "ppo" if "n_epochs" in data else "a2c",
    }.get(module)
    if algo is None:
        raise ValueError(f"policy {path}: cannot tell the algorithm from {module}.{name}")
    raw = data.get("policy_kwargs") or {}
    kwargs: dict[str, Any] = {}
    for key, value in raw.items():
        if key.startswith(":") or key in TRAINING_ONLY:
            continue
        match = _CLASS.fullmatch(value) if isinstance(value, str) else None
        if match and key == "activation_fn":
            kwargs[key] = match.group(1).rsplit(".", 1)[-1].lower()
        elif match:
            if match.group(1).rsplit(".", 1)[-1] != DEFAULT_CLASSES.get(key):
                raise ValueError(f"policy {path}: policy_kwargs.{key} {value} is not supported")
        else:
            kwargs[key] = value
    if algo in ("ppo", "a2c") and data.get("use_sde"):
        kwargs["use_sde"] = True
    space = data.get("observation_space")
    shape = space.get("_shape") if isinstance(space, dict) else None
    obs_shape = tuple(int(n) for n in shape) if isinstance(shape, list) else None
    return algo, POLICY_NAMES[name], kwargs, obs_shape
