"""One command, one vocabulary (docs/cli.md): the flag table is the parsers', a flag means the
same in every command, every subcommand has a described ``--help``, and the shared flags are
wherever the rule of docs/cli.md puts them."""

from __future__ import annotations

import argparse
from collections import defaultdict

import pytest

pytest.importorskip("stable_baselines3")  # railgym train's parser names SB3's algorithms

from agents.commands.cli import main  # noqa: E402
from agents.commands.cli_table import DOC, command_parsers, documented, flag_rows, markdown  # noqa: E402

#: the rule of docs/cli.md, per command: what it does with its results
WRITES = {
    "demo",
    "paper",
    "refine",
    "export-reference-fmu",
    "export-policy",
    "train",
    "train-rllib",
    "benchmark",
    "collect",
    "collect-vehicle",
    "crash-fe",
    "crash-elements",
    "combine",
    "damper-element",
    "surrogates build",
    "surrogates export-fmu",
}
PRINTS = {
    "evaluate",
    "validate",
    "validity",
    "crash-report",
    "crash-limits",
    "leaderboard",
    "semi-active-bound",
}
#: writes into the installed package, where its NAME says: --overwrite, no -o
FIXED_PLACE = {"pretrained"}
#: rewrites files of the source checkout (the docs' generated tables): no -o, no --overwrite
CHECKOUT = {"env-tables"}
#: commands whose result depends on nothing drawn at random
UNSEEDED = {
    "export-reference-fmu",
    "export-policy",
    "surrogates export-fmu",
    "crash-report",
    "crash-limits",
    "pretrained",
    "leaderboard",
    "env-tables",
}


@pytest.fixture(scope="module")
def parsers() -> dict[str, argparse.ArgumentParser]:
    return command_parsers()


def _options(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    """Option string → action, ``-h/--help`` left out."""
    return {
        flag: action
        for action in parser._actions
        for flag in action.option_strings
        if flag not in ("-h", "--help")
    }


def _kind(value: object) -> str:
    """The kind of value an argparse ``type`` gives: integer, real or text."""
    if value is None or value is str or getattr(value, "__name__", "") == "Path":
        return "text"
    probe = {"int": "integer", "float": "real"}.get(getattr(value, "__name__", ""))
    if probe is not None:
        return probe
    try:
        out = value("1")  # type: ignore[operator]
    except (argparse.ArgumentTypeError, ValueError, TypeError):
        out = value("0.5")  # type: ignore[operator]
    return "integer" if isinstance(out, int) else "real" if isinstance(out, float) else "text"


def _count(nargs: object) -> str:
    return {None: "one", "?": "one", 0: "none"}.get(nargs, "many")  # type: ignore[arg-type]


def test_docs_table_is_the_parsers_table(parsers):
    """(a) docs/cli.md holds the table generated from the parsers now."""
    assert documented(DOC.read_text(encoding="utf-8")) == markdown(flag_rows(parsers))


def test_no_flag_has_two_meanings(parsers):
    """(b) Wherever a flag string is taken it has one destination, action, value kind
    (integer, real, text) and count (none, one, several), and its choices overlap."""
    seen: dict[str, dict[tuple, list[str]]] = defaultdict(lambda: defaultdict(list))
    choices: dict[str, list[tuple[str, set]]] = defaultdict(list)
    for command, parser in parsers.items():
        for flag, action in _options(parser).items():
            meaning = (action.dest, type(action).__name__, _kind(action.type), _count(action.nargs))
            seen[flag][meaning].append(command)
            if action.choices is not None:
                choices[flag].append((command, set(map(str, action.choices))))
    clashes = {flag: dict(m) for flag, m in seen.items() if len(m) > 1}
    assert not clashes, clashes
    for flag, sets in choices.items():
        for (a, first), (b, second) in zip(sets, sets[1:], strict=False):
            assert first & second, f"{flag}: {a} {sorted(first)} vs {b} {sorted(second)}"
    # the real numbers behind the check: the common flags are in many commands, one meaning
    assert len(seen["--seed"][("seed", "_StoreAction", "integer", "one")]) == 17
    assert len(seen["-o"][("out", "_StoreAction", "text", "one")]) == len(WRITES)


#: the crash-fe arguments it requires, -o/--out aside
CRASH_FE = [
    *("--nodout", "n", "--rcforc", "r", "--unit-system", "mm-ms-kg-kN", "--car-nodes", "1"),
    *("--wall-contact", "1", "--interface-contacts", "2", "--scenario", "paper"),
]
#: the deprecated spellings removed in 0.5.0 → their one spelling (CHANGELOG.md, migration
#: table)
REMOVED = {"--output": "-o", "--speed": "--speed-kmh", "--first-seed": "--seed"}
REMOVED["--no-progress"] = "--quiet"


def test_the_removed_spellings_are_refused(parsers, capsys):
    """Removed as they had another meaning elsewhere: an unrecognized argument."""
    for command, argv in (
        ("surrogates build", ["d.csv", "--inputs", "a", "--target", "F", "-o", "m", "--model"]),
        ("surrogates export-fmu", ["m.json", "-o", "x.fmu", "--fmu", "y.fmu"]),
        ("refine", ["passive", "--model", "m.json"]),
    ):
        with pytest.raises(SystemExit) as exc:
            parsers[command].parse_args(argv)
        assert exc.value.code == 2
        assert "unrecognized arguments" in capsys.readouterr().err.strip().splitlines()[-1]


@pytest.mark.parametrize(
    ("command", "base", "old", "value"),
    [
        ("collect", [], "--output", ["m.json"]),
        ("collect-vehicle", [], "--output", ["m.json"]),
        ("crash-fe", CRASH_FE, "--output", ["e.json"]),
        ("export-reference-fmu", [], "--output", ["v.fmu"]),
        ("export-policy", ["passive"], "--output", ["p.fmu"]),
        ("evaluate", ["passive", "--env", "crash"], "--speed", ["36", "40"]),
        ("benchmark", ["ppo_vertical"], "--first-seed", ["3"]),
        ("train", ["ppo_vertical"], "--no-progress", []),
    ],
)
def test_the_deprecated_spellings_are_removed(parsers, capsys, command, base, old, value):
    """A deprecated spelling of 0.4 is refused (exit status 2, naming it, or naming its one
    spelling where that is required), no command takes it as a flag, and the one spelling
    with the same value parses without a word on stderr."""
    parser = parsers[command]
    with pytest.raises(SystemExit) as exc:
        parser.parse_args([*base, old, *value])
    assert exc.value.code == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    named = f"unrecognized arguments: {old}" in last or f"required: {REMOVED[old]}" in last
    assert named, last
    assert old not in _options(parser)
    new = parser.parse_args([*base, REMOVED[old], *value])
    assert capsys.readouterr().err == ""
    assert vars(new)[_options(parser)[REMOVED[old]].dest] is not None
    assert not any(old in _options(p) for p in parsers.values())


@pytest.mark.parametrize(
    "argv",
    [
        "demo",
        "paper",
        "evaluate",
        "refine",
        "export-reference-fmu",
        "export-policy",
        "train",
        "train-rllib",
        "benchmark",
        "pretrained",
        "collect",
        "collect-vehicle",
        "validate",
        "validity",
        "crash-report",
        "crash-limits",
        "crash-fe",
        "crash-elements",
        "combine",
        "damper-element",
        "env-tables",
        "leaderboard",
        "semi-active-bound",
        "surrogates build",
        "surrogates export-fmu",
    ],
)
def test_every_subcommand_help_exits_0_with_a_description(parsers, capsys, argv):
    """(c) ``railgym CMD --help``: status 0, the usage, the description and every visible
    option's help with its default."""
    with pytest.raises(SystemExit) as exc:
        main([*argv.split(), "--help"])
    out = capsys.readouterr().out
    parser = parsers[argv]
    assert exc.value.code == 0 and out.startswith(f"usage: {parser.prog}")
    assert parser.description and parser.description.split()[0] in out
    for flag, action in _options(parser).items():
        assert action.help, f"{argv} {flag}: no help"
        shown = action.default not in (None, False, [], argparse.SUPPRESS)
        if shown and action.nargs != 0 and "default" not in action.help:
            assert "(default: " in out, f"{argv} {flag}"


def test_train_rllib_parser_needs_no_ray(parsers):
    assert parsers["train-rllib"].prog == "railgym train-rllib"
    assert {"-o", "--seed", "--quiet", "--debug"} <= set(_options(parsers["train-rllib"]))


def test_shared_flags_are_where_the_rule_puts_them(parsers):
    """(d) docs/cli.md, *The vocabulary*: every command --quiet and --debug; a command that
    writes -o/--out and --overwrite; a seeded one --seed; --track-class several values;
    speeds in km/h with the unit in the flag."""
    assert set(parsers) == WRITES | PRINTS | FIXED_PLACE | CHECKOUT
    for command, parser in parsers.items():
        flags = _options(parser)
        assert {"--quiet", "--debug"} <= set(flags), command
        writes = {"-o", "--out", "--overwrite"} <= set(flags)
        assert writes == (command in WRITES), command
        if command in PRINTS | CHECKOUT:
            assert not {"-o", "--out", "--overwrite"} & set(flags), command
        if command in FIXED_PLACE:
            assert "--overwrite" in flags and "-o" not in flags
        assert ("--seed" in flags) == (command not in UNSEEDED), command
        if "--track-class" in flags:
            assert flags["--track-class"].nargs == "+", command
        for flag in flags:
            if "speed" in flag:
                assert flag.endswith("-kmh"), f"{command} {flag}"


def test_packaged_config_by_name_from_any_folder(tmp_path, monkeypatch, capsys):
    """``railgym train ppo_vertical`` in a folder without configs: the packaged config is
    read (envs and model built), then the file given as -o is refused — not the name."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "file").write_text("x")
    for command in ("train", "benchmark"):
        assert main([command, "ppo_vertical", "-o", "file", "--quiet"]) == 2
        err = capsys.readouterr().err
        assert err == f"railgym {command}: error: --out file: exists and is not a folder\n"


def test_version(capsys):
    """(e) ``railgym --version``: the installed distribution's version."""
    from importlib.metadata import version

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"railgym {version('railgym')}"
