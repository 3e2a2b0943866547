"""Optional dependencies (the extras of ``pyproject.toml``): a missing one is one clear error
that names the extra to install, exit status 2 on the command line."""

from __future__ import annotations

import importlib
import sys

__all__ = ["MissingExtraError", "extra_error", "report_missing", "require"]

#: top-level module → extra of ``pyproject.toml`` that installs it
EXTRAS = {
    "torch": "agents",
    "stable_baselines3": "agents",
    "ray": "rllib",
    "rl_zoo3": "zoo",
    "matplotlib": "plot",
    "fmpy": "fmi",
}
#: how to install an extra, where ``pip install`` alone is not enough
NOTES = {"rllib": " in its own virtual environment (RLlib pins gymnasium: see .ci/rllib.sh)"}


class MissingExtraError(ImportError):
    """A module of an optional extra is not installed; the message names the extra."""


def extra_error(err: ImportError, what: str) -> ImportError:
    """``err`` as a :class:`MissingExtraError` naming the extra of the missing module, for
    ``what`` (the feature that needs it); ``err`` itself when the module is of no extra."""
    module = (err.name or "").split(".")[0]
    extra = EXTRAS.get(module)
    if extra is None or isinstance(err, MissingExtraError):
        return err
    return MissingExtraError(
        f"{what} needs the '{extra}' extra (no module named {module!r}): "
        f"pip install 'railgym[{extra}]'{NOTES.get(extra, '')}",
        name=err.name,
    )


def require(what: str, *modules: str) -> None:
    """Import ``modules``; a missing one raises :class:`MissingExtraError` naming its extra."""
    for module in modules:
        try:
            importlib.import_module(module)
        except ImportError as err:
            raise extra_error(err, what) from err


def report_missing(err: ImportError, prog: str, what: str) -> int:
    """Print the one-line error of a missing extra for the command ``prog``; exit status 2."""
    print(f"{prog}: error: {extra_error(err, what)}", file=sys.stderr)
    return 2
