"""Policy files that run no code: a SHA-256 manifest written at training time, and a loader
that reads only the network weights of a stable-baselines3 ``.zip``.

stable-baselines3's own ``load`` unpickles the ``:serialized:`` fields of the zip's ``data``
entry, so a crafted file runs arbitrary code. Here the policy network is rebuilt from the
run's ``config.yaml`` (algorithm, policy name, ``policy_kwargs``) and the env's spaces, and
only the zip's ``policy.pth`` state dict is read, with ``torch.load(weights_only=True)``.
:func:`agents.training.train.train` records the hash of every zip it writes in ``manifest.json``;
:func:`check_manifest` refuses a zip that is not listed there with its hash, unless trusted.
"""

from __future__ import annotations

import hashlib
import io
import json
import re
import warnings
import zipfile
from pathlib import Path
from typing import Any

from railgym.report.output import write_text_atomic

__all__ = [
    "MANIFEST",
    "RLLIB_MODULE_PATH",
    "check_manifest",
    "load_policy_weights",
    "refuse_untrusted",
    "sha256",
    "write_manifest",
]

#: manifest file name, beside the zips it lists
MANIFEST = "manifest.json"
#: where an RLlib algorithm checkpoint keeps its policy module (see
#: :mod:`agents.training.train_rllib`)
RLLIB_MODULE_PATH = Path("learner_group") / "learner" / "rl_module" / "default_policy"
#: format tag of the manifest
FORMAT = "railgym-policy-manifest/1"
#: largest ``policy.pth`` read from a zip, bytes
MAX_WEIGHTS_BYTES = 256 * 2**20


def sha256(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with Path(path).open("rb") as fh:
        for chunk in iter(lambda: fh.read(2**20), b""):
            h.update(chunk)
    return h.hexdigest()


def write_manifest(folder: str | Path) -> Path:
    """Record the SHA-256 of every ``*.zip`` directly in ``folder`` in ``folder/manifest.json``."""
    folder = Path(folder)
    files = {p.name: sha256(p) for p in sorted(folder.glob("*.zip"))}
    path = folder / MANIFEST
    write_text_atomic(path, json.dumps({"format": FORMAT, "sha256": files}, indent=2) + "\n")
    return path


def check_manifest(path: str | Path, trust: bool = False) -> None:
    """Check that ``path`` is a zip the training run wrote: listed with its hash in the
    ``manifest.json`` beside it.

    Raises
    ------
    ValueError
        No manifest, the zip is not listed or its hash differs, and ``trust`` is false; with
        ``trust`` a warning is given instead.
    """
    path = Path(path)
    manifest = path.parent / MANIFEST
    problem = None
    try:
        listed = json.loads(manifest.read_text(encoding="utf-8")).get("sha256", {})
        expected = listed.get(path.name) if isinstance(listed, dict) else None
    except FileNotFoundError:
        problem = f"no {MANIFEST} beside it"
    except (OSError, ValueError, AttributeError) as err:
        problem = f"{manifest} is unreadable ({err})"
    else:
        if expected is None:
            problem = f"it is not listed in {manifest}"
        elif expected != sha256(path):
            problem = f"its SHA-256 differs from the one in {manifest}"
    if problem is not None:
        refuse_untrusted(
            f"policy {path}: {problem}, so it was not written by this run's training",
            trust,
            "; pass --trust to load its weights anyway",
            "; loading its network weights because of --trust",
        )


def refuse_untrusted(message: str, trust: bool, refused: str, trusted: str) -> None:
    """A file that failed its manifest check: ``ValueError(message + refused)``, or with
    ``trust`` a ``UserWarning`` ``message + trusted`` (pointing at the loader's caller)."""
    if not trust:
        raise ValueError(message + refused)
    warnings.warn(message + trusted, stacklevel=3)


def _weights(path: Path) -> dict[str, Any]:
    """The ``policy.pth`` state dict of an SB3 zip, read without unpickling anything."""
    import torch

    try:
        with zipfile.ZipFile(path) as zf:
            info = zf.getinfo("policy.pth")
            if info.file_size > MAX_WEIGHTS_BYTES:
                raise ValueError(f"policy {path}: policy.pth is over {MAX_WEIGHTS_BYTES} bytes")
            raw = zf.read(info)
    except KeyError:
        raise ValueError(f"policy {path}: no policy.pth in the zip") from None
    except zipfile.BadZipFile as err:
        raise ValueError(f"policy {path}: not a zip file ({err})") from None
    try:
        with warnings.catch_warnings():  # torch warns about the pickle protocol of foreign files
            warnings.simplefilter("ignore", UserWarning)
            state = torch.load(io.BytesIO(raw), map_location="cpu", weights_only=True)
    except Exception as err:  # torch raises UnpicklingError, RuntimeError, EOFError, ...
        # torch's own text advises weights_only=False, the unsafe load this module exists to
        # avoid: it never reaches the user
        raise ValueError(
            f"policy {path}: policy.pth is not a weights-only state dict: it holds objects "
            f"other than tensors and plain containers, or is damaged ({_why(err)}), and "
            "railgym never unpickles such objects (they can run code); use a zip written by "
            "stable-baselines3's save() (agents.training.train writes one), or export the policy's "
            "state_dict() from a trusted copy"
        ) from None
    if not isinstance(state, dict):
        raise ValueError(f"policy {path}: policy.pth holds {type(state).__name__}, not weights")
    return state


def _why(err: Exception) -> str:
    """A short reason of a failed weights-only ``torch.load``, without torch's advice."""
    text = str(err)
    if "weights_only" in text or "Weights only" in text:
        found = re.search(r"WeightsUnpickler error:\s*(\S[^\n]*)", text)
        # its first clause only: torch goes on to advise allow-listing the object
        detail = re.split(r"\. | was not an allowed", found[1])[0] if found else ""
        return "the weights-only reader refused it" + (f": {detail}" if detail else "")
    first = text.strip().split(". ")[0].splitlines()[0] if text.strip() else ""
    return f"{type(err).__name__}: {first}" if first else type(err).__name__


def load_policy_weights(
    path: str | Path,
    algo: str,
    policy: str,
    policy_kwargs: dict[str, Any],
    observation_space: Any,
    action_space: Any,
) -> Any:
    """The SB3 policy network of ``path`` (an SB3 zip), built from the config and the spaces.

    Parameters
    ----------
    path : SB3 ``.zip``; only its ``policy.pth`` is read.
    algo : ``ppo``, ``sac``, ``td3`` or ``a2c``.
    policy : SB3 policy name (``MlpPolicy``).
    policy_kwargs : resolved ``policy_kwargs`` of the config (activation as a torch module).
    observation_space, action_space : the single env's spaces.

    Returns
    -------
    An SB3 ``BasePolicy`` in evaluation mode; ``predict(obs, deterministic=True)`` as a model.
    """
    from agents.training.train_config import ALGOS

    path = Path(path)
    aliases = ALGOS[algo].policy_aliases
    if policy not in aliases:
        raise ValueError(f"policy {path}: unknown policy {policy!r} for {algo}")
    net = aliases[policy](observation_space, action_space, lambda _: 0.0, **policy_kwargs)
    try:
        net.load_state_dict(_weights(path))
    except RuntimeError as err:
        first = str(err).splitlines()[0]
        raise ValueError(
            f"policy {path}: weights do not fit the config's network ({first})"
        ) from None
    net.set_training_mode(False)
    return net
