"""The fuzzer of the command lines, generated from the flag table: every flag and positional
of every ``railgym`` and ``surrogates`` subcommand
(:func:`agents.commands.cli_table.flag_rows`) gets the texts users get wrong
(:func:`tests.fuzz.values.command_line`).

Two tiers, in process (no subprocess per case):

1. every (flag, value) through the subcommand's own parser: a refusal is exit status 2 with
   a one-line error naming the flag;
2. the values the parser lets through, through ``railgym`` 's ``main`` (the user's door) under
   a deadline: a value that no flag can take must be refused (exit 2, the flag or the file
   named) before the job starts; of the values that may be correct for some flag (0, a
   negative, ints for floats …) a seeded sample runs, which must not end in a traceback or
   exit status 1 (one that is still working at its deadline has passed its checks).

``RAILGYM_FUZZ_SEED`` changes the sample (default 0). A new flag is fuzzed with no new test
code; a new subcommand with required arguments needs its valid base in :data:`BASE`."""

from __future__ import annotations

import argparse
import functools
import importlib
import io
import os
import random
import shutil
import warnings
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

from agents._extras import MissingExtraError
from agents.commands.cli import MODULE_COMMANDS, build_parser, module_parser
from agents.commands.cli import main as railgym_main
from agents.commands.cli_table import command_parsers, flag_rows
from tests.fuzz.runner import Hang, deadline
from tests.fuzz.values import MUST_REFUSE, Bad, Files, command_line

ROOT = Path(__file__).resolve().parents[2]
#: a valid command line of each subcommand with required arguments: (flag or positional's
#: dest, values); ``{tmp}``, ``{cfg}``, ``{csv}``, ``{model}``: files of the test, ``{out}``:
#: a new folder for each run (a command that writes without ``-o`` writes into the package)
BASE: dict[str, list[tuple[str, list[str]]]] = {
    "evaluate": [("policy", ["passive"])],
    "refine": [("policy", ["passive"])],
    "export-reference-fmu": [("--out", ["{out}/out.fmu"])],
    "export-policy": [("policy", ["passive"]), ("--out", ["{out}/out.fmu"])],
    "train": [("config", ["{cfg}"])],
    "train-rllib": [("config", ["{cfg}"])],
    "benchmark": [("config", ["{cfg}"])],
    "pretrained": [("name", ["ppo-vertical"]), ("benchmark_dir", ["{tmp}/no_benchmark"])],
    "collect": [("--out", ["{out}/out.json"])],
    "collect-vehicle": [("--out", ["{out}/out.json"])],
    "crash-elements": [("--out", ["{out}/out.json"])],
    "damper-element": [("--out", ["{out}/out.json"])],
    "crash-fe": [
        ("--nodout", ["{tmp}/nodout"]),
        ("--rcforc", ["{tmp}/rcforc"]),
        ("--unit-system", ["mm-ms-kg-kN"]),
        ("--car-nodes", ["1"]),
        ("--wall-contact", ["1"]),
        ("--interface-contacts", ["2"]),
        ("--scenario", ["paper"]),
        ("--out", ["{out}/out.json"]),
    ],
    "combine": [
        ("data", ["{csv}"]),
        ("--vehicle", ["manchester"]),
        ("--units", ["du=m", "dv=m/s", "F=N"]),
        ("--out", ["{out}/out.json"]),
    ],
    "surrogates build": [
        ("data", ["{csv}"]),
        ("--inputs", ["du", "dv"]),
        ("--target", ["F"]),
        ("--out", ["{out}/out.json"]),
    ],
    "surrogates export-fmu": [("model", ["{model}"]), ("--out", ["{out}/out.fmu"])],
}
#: subcommands whose base cannot run here (their inputs are FE results or the package's own
#: pretrained folder): fuzzed by their parser (tier 1) only
PARSE_ONLY = {
    "crash-fe": "needs LS-DYNA results",
    "pretrained": "writes into the package",
    "env-tables": "rewrites the docs of the checkout",
}
#: flags whose value is written (a file or folder) or read as a folder: only an empty value
#: must be refused there (a folder or a missing path may be correct)
OUTPUTS = {"out", "report", "benchmark_dir", "fmu_dir", "results"}
#: sampled runs of values that may be correct (tier 2), and the deadlines, s
SAMPLE = 12
REFUSE_DEADLINE_S = 8.0
SAMPLE_DEADLINE_S = 4.0


#: the placeholder of ``{out}`` until a run gets its folder
OUT = "<out>"


@functools.cache
def parse_only_commands() -> frozenset[str]:
    """:data:`PARSE_ONLY` and the module commands whose extra is not installed here."""
    out = set(PARSE_ONLY)
    for name, (module, _) in MODULE_COMMANDS.items():
        try:
            importlib.import_module(module)
        except MissingExtraError:
            out.update(c for c in parsers() if c.split()[0] == name)
    return frozenset(out)


class Case(NamedTuple):
    """One fuzz case: the subcommand, the flag's action, its key in :data:`BASE`, the value."""

    command: str
    action: argparse.Action
    key: str
    bad: Bad


def key_of(action: argparse.Action) -> str:
    """The flag's key in :data:`BASE`: its longest spelling, a positional's dest."""
    return max(action.option_strings, key=len) if action.option_strings else action.dest


def names_of(action: argparse.Action) -> list[str]:
    """How an error may name the flag: its spellings, or a positional's dest and metavar."""
    if not action.option_strings:
        return [action.dest, str(action.metavar or action.dest)]
    return [*action.option_strings, action.dest]


def must_refuse(action: argparse.Action, kind: str) -> bool:
    """Whether no correct command line gives ``kind`` to this flag: every class of
    :data:`MUST_REFUSE` for a number; for text, an empty one and a file-like value where a
    file belongs (but a folder or a missing path where a folder or output belongs)."""
    if kind not in MUST_REFUSE:
        return False
    if action.type is not None and action.type not in (str, Path):
        return True  # int, float, bounded numbers, seeds
    if action.dest in OUTPUTS:
        return kind == "empty string"
    return kind in ("empty string", "folder", "folder.yaml") or (
        kind in ("missing file", "unreadable file", "not utf-8", "wrong format")
        and action.choices is None
        and _is_file_flag(action)
    )


def _is_file_flag(action: argparse.Action) -> bool:
    """A flag whose help says it reads a file (a path, a YAML, a JSON …)."""
    text = f"{action.help} {action.dest}".lower()
    return any(w in text for w in ("file", "path", "yaml", "json", "csv", "config", "fmu"))


def cases(files: Files) -> list[Case]:
    """Every flag of every subcommand with every value (a switch: one given a value)."""
    out = []
    for row in flag_rows(parsers()):
        action = row.action
        if action.nargs == 0:
            out.append(Case(row.command, action, key_of(action), Bad("value for a switch", "yes")))
            continue
        for bad in command_line(files):
            out.append(Case(row.command, action, key_of(action), bad))
    return out


def argv_of(case: Case, places: dict[str, str]) -> list[str]:
    """The subcommand's base command line with the case's flag given the case's value."""
    items = {k: [v.format(**places) for v in vs] for k, vs in BASE.get(case.command, [])}
    value = str(case.bad.value)
    positional = not case.action.option_strings
    if case.action.nargs == 0:
        items.pop(case.key, None)
        flags = [f"{case.key}={value}"]
    elif positional:
        items[case.key] = [value]
        flags = []
    else:
        items.pop(case.key, None)
        flags = [case.key, value]
    positionals = [v for k, vs in items.items() if not k.startswith("-") for v in vs]
    options = [t for k, vs in items.items() if k.startswith("-") for t in (k, *vs)]
    return [*case.command.split(), *positionals, *options, *flags]


def _names(case: Case, err: str) -> bool:
    """Whether the one-line error ``err`` names the case's flag, the file it was given, or
    the option-like value that argparse took for an option (``--units -inf``:
    ``unrecognized arguments: -inf``)."""
    value = str(case.bad.value)
    option_like = value.startswith("-") and f"unrecognized arguments: {value}" in err
    return (
        any(n in err for n in names_of(case.action))
        or ("/" in value and value in err)
        or (option_like)
    )


@functools.cache
def parsers() -> dict[str, argparse.ArgumentParser]:
    """The parser of every subcommand, built once."""
    return command_parsers()


@functools.cache
def door(name: str) -> argparse.ArgumentParser:
    """The parser ``railgym NAME …`` reads with: ``railgym``'s own, or a module command's."""
    return module_parser(name) if name in MODULE_COMMANDS else build_parser()


def _error_line(stderr: str) -> str:
    """The error line of ``stderr`` (the last; the usage above it lists every flag)."""
    lines = stderr.strip().splitlines()
    return lines[-1] if lines else ""


def parse_only(case: Case, argv: list[str]) -> tuple[str | None, bool]:
    """Tier 1: ``(failure, accepted)`` of the case's command line through the parser that
    ``railgym`` hands it to (its own for a built-in subcommand, the module's otherwise)."""
    name = argv[0]
    parser, rest = door(name), (argv[1:] if name in MODULE_COMMANDS else argv)
    err = io.StringIO()
    try:
        with redirect_stderr(err), redirect_stdout(io.StringIO()), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            parser.parse_args(rest)
    except SystemExit as exc:
        if exc.code != 2:
            return f"parser exit status {exc.code}: {err.getvalue()!r}", False
        line = _error_line(err.getvalue())
        if not _names(case, line):
            return f"parser error does not name the flag: {line!r}", False
        return None, False
    except Exception as exc:  # noqa: BLE001  (what the fuzzer looks for)
        return f"traceback in the parser: {type(exc).__name__}: {exc}", False
    return None, True


def run_main(case: Case, argv: list[str], seconds: float) -> str | None:
    """Tier 2: the failure of ``railgym ARGV`` run in process, or ``None``."""
    err = io.StringIO()
    refuse = must_refuse(case.action, case.bad.kind)
    try:
        with deadline(seconds), redirect_stderr(err), redirect_stdout(io.StringIO()):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                status = railgym_main(argv)
    except SystemExit as exc:
        status = exc.code
    except Hang:
        return "not refused before the job started" if refuse else None
    except Exception as exc:  # noqa: BLE001
        return f"traceback: {type(exc).__name__}: {exc}"
    text = _error_line(err.getvalue())
    if status == 2 and (_names(case, text) or not refuse):
        return None
    if status == 0 and not refuse:
        return None
    if status == 0:
        return "accepted silently"
    return f"exit status {status}: {text.strip()[-300:]!r}"


@pytest.fixture(scope="module")
def places(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """The files of :data:`BASE`."""
    tmp = tmp_path_factory.mktemp("fuzz_cli")
    cfg = tmp / "ppo_vertical.yaml"
    shutil.copy(ROOT / "configs" / "agents" / "ppo_vertical.yaml", cfg)
    rng = np.random.default_rng(0)
    du, dv = rng.uniform(-0.02, 0.02, 200), rng.uniform(-0.2, 0.2, 200)
    csv = tmp / "data.csv"
    np.savetxt(
        csv,
        np.column_stack([du, dv, 1e5 * du + 2e4 * dv]),
        delimiter=",",
        header="du,dv,F",
        comments="",
    )
    model = ROOT / "railgym" / "data" / "vertical_lpr.json"
    return {"tmp": str(tmp), "cfg": str(cfg), "csv": str(csv), "model": str(model), "out": OUT}


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> Files:
    """The file-like values."""
    return Files.make(tmp_path_factory.mktemp("fuzz_cli_files"))


def test_cli_flags(files: Files, places: dict[str, str], monkeypatch: pytest.MonkeyPatch) -> None:
    """Every case of tier 1, the accepted ones that must be refused and a sample of the
    others through tier 2; the failures listed together."""
    monkeypatch.chdir(places["tmp"])
    failures, refuse, maybe = [], [], []
    for case in cases(files):
        argv = argv_of(case, places)
        wrong, accepted = parse_only(case, argv)
        if wrong is not None:
            failures.append(f"railgym {' '.join(argv)} ({case.bad.kind}): {wrong}")
        elif accepted and case.command not in parse_only_commands():
            (refuse if must_refuse(case.action, case.bad.kind) else maybe).append((case, argv))
    seed = int(os.environ.get("RAILGYM_FUZZ_SEED", "0"))
    sample = random.Random(seed).sample(maybe, min(SAMPLE, len(maybe)))
    runs = [(c, a, REFUSE_DEADLINE_S) for c, a in refuse]
    runs += [(c, a, SAMPLE_DEADLINE_S) for c, a in sample]
    for n, (case, argv, seconds) in enumerate(runs):
        out = Path(places["tmp"]) / f"run{n}"
        out.mkdir()
        wrong = run_main(case, [a.replace(OUT, str(out)) for a in argv], seconds)
        if wrong is not None:
            failures.append(f"railgym {' '.join(argv)} ({case.bad.kind}): {wrong}")
    assert not failures, f"{len(failures)} failures:\n" + "\n".join(failures)
