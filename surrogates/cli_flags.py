"""The shared vocabulary of every command (``railgym`` and its subcommands, ``surrogates``):
one spelling and one meaning per flag (``docs/cli.md``).

- ``-o/--out``: where the command writes (a file or a folder, as the command needs), with
  ``--overwrite`` to replace what is there (:func:`add_out`).
- ``--quiet``: no progress bars and notes on stderr; ``--debug``: tracebacks instead of the
  one-line errors (:func:`add_common`, every command).
- ``--seed``: the seed of what the command draws (tracks, samples, weights) (:func:`add_seed`).

Every parser is a :class:`Parser` with :class:`HelpFormatter`: each option's help shows its
default; the old spellings of 0.4 are gone (an unrecognized argument). :func:`error_status` is
the exit status and one-line error of a failed command, :func:`moved_command` that of a
``python -m`` spelling removed for a ``railgym`` subcommand.
"""

from __future__ import annotations

import argparse
import sys
import textwrap
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from surrogates.checks import seed_number

__all__ = [
    "HelpFormatter",
    "Parser",
    "RawHelpFormatter",
    "add_common",
    "add_out",
    "add_seed",
    "error_status",
    "moved_command",
    "shown_default",
]


def shown_default(value: Any) -> str:
    """A default as the help and ``docs/cli.md`` show it: lists space-separated."""
    if isinstance(value, list | tuple):
        return " ".join(shown_default(v) for v in value)
    return str(value)


class _DefaultsMixin:
    """Every option's help ends with ``(default: X)``, unless it names its default itself or
    has none (``None``, a switch that is off, an empty list, a positional)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (
            not action.option_strings
            or "default" in text
            or default is None
            or default is False
            or default == []
            or default is argparse.SUPPRESS
            or text is argparse.SUPPRESS
        ):
            return action.help
        return f"{text} (default: {shown_default(default).replace('%', '%%')})"

    def _split_lines(self, text: str, width: int) -> list[str]:
        """Help lines wrapped at spaces only: a name like ``speed-adaptive`` or
        ``clipped-lqg`` is never split at its hyphen."""
        return textwrap.wrap(" ".join(text.split()), width, break_on_hyphens=False)


class HelpFormatter(_DefaultsMixin, argparse.HelpFormatter):
    """Wrapped description and helps, defaults shown."""


class RawHelpFormatter(_DefaultsMixin, argparse.RawDescriptionHelpFormatter):
    """Description and epilog as written (line breaks kept), defaults shown."""


class Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` with :class:`HelpFormatter` that refuses an empty value.
    ``elsewhere``: flags this command does not take, each with the command that does;
    one of them given is an error naming the flag and that command (never another meaning).
    No abbreviations: ``--fmu`` is not ``--fmu-kind`` where a command has no ``--fmu``."""

    def __init__(self, *args: Any, elsewhere: dict[str, str] | None = None, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)
        self.elsewhere = dict(elsewhere or {})

    def _get_value(self, action: argparse.Action, arg_string: str) -> Any:
        """An empty value (``--out ""``, an unset shell variable) is refused naming the
        flag: no flag takes one (``Path("")`` would be the working directory)."""
        nested = action.nargs in (argparse.PARSER, argparse.REMAINDER)  # a subcommand's own
        if arg_string == "" and not nested:
            raise argparse.ArgumentError(action, "is empty; give a value")
        return super()._get_value(action, arg_string)

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        """``ArgumentParser.parse_known_args``, a flag of :attr:`elsewhere` refused first."""
        for arg in sys.argv[1:] if args is None else args:
            if arg == "--":
                break
            flag = str(arg).split("=", 1)[0]
            if flag in self.elsewhere:
                self.error(f"{flag} is not an option of {self.prog}: {self.elsewhere[flag]}")
        return super().parse_known_args(args, namespace)


def add_common(
    parser: argparse.ArgumentParser,
    debug_default: Any = False,
    quiet_help: str = "no progress bars or notes on stderr",
) -> None:
    """``--quiet`` (``quiet_help``: its help) and ``--debug`` (``debug_default=
    argparse.SUPPRESS``: a subcommand whose parent parser has ``--debug`` too)."""
    parser.add_argument("--quiet", action="store_true", help=quiet_help)
    parser.add_argument(
        "--debug",
        action="store_true",
        default=debug_default,
        help="show the traceback of an error instead of its one line",
    )


def add_out(
    parser: argparse.ArgumentParser,
    what: str,
    *,
    default: Any = None,
    required: bool = False,
    overwrite: str = "replace an existing -o/--out",
    type: Callable[[str], Any] = Path,
) -> None:
    """``-o/--out`` (``what``: its help, the file or folder written) and ``--overwrite``
    (``overwrite``: its help)."""
    parser.add_argument("-o", "--out", type=type, default=default, required=required, help=what)
    parser.add_argument("--overwrite", action="store_true", help=overwrite)


def add_seed(parser: argparse.ArgumentParser, what: str, default: int | None = 0) -> None:
    """``--seed`` (0 … ``MAX_SEED``): ``what`` is the help."""
    parser.add_argument("--seed", type=seed_number, default=default, help=what)


def error_status(prog: str, err: Exception, debug: bool = False) -> int:
    """Exit status of the command ``prog`` that raised ``err``, after its one line on stderr:
    ``prog: error: …`` and 2 for a user error (``ValueError``, ``OSError``), else ``prog:
    Type: … (--debug shows the traceback)`` and 1; ``debug`` (``--debug``) re-raises ``err``."""
    if debug:
        raise err
    if isinstance(err, ValueError | OSError):
        print(f"{prog}: error: {err}", file=sys.stderr)
        return 2
    print(f"{prog}: {type(err).__name__}: {err} (--debug shows the traceback)", file=sys.stderr)
    return 1


def moved_command(module: str, command: str) -> int:
    """Exit status (2) of ``python -m MODULE`` where ``command`` (``railgym collect``) is the
    one spelling: one line on stderr naming it; nothing runs, nothing is written."""
    print(
        f"python -m {module}: error: this spelling is no longer a command (0.5.0); run `{command}` "
        "(the same arguments)",
        file=sys.stderr,
    )
    return 2
