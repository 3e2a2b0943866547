"""The fuzzer covers 100 % of what users can give: every keyword of every registered env's
constructor, every wrapper parameter and every row of the flag table of ``docs/cli.md``; the
lists are read from those sources, not from the fuzzer's own."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

from agents.commands.cli_table import BEGIN, END
from railgym.registration import ENVS
from tests.fuzz.declarations import entry_class, wrapper_arguments
from tests.fuzz.test_cli_flags import cases as cli_cases
from tests.fuzz.test_env_arguments import CASES as ENV_CASES
from tests.fuzz.values import Files

DOC = Path(__file__).resolve().parents[2] / "docs" / "cli.md"


def test_every_env_keyword_is_fuzzed() -> None:
    """Each keyword of each registered env's constructor (``render_mode`` aside) has cases,
    through an env id of its family's declarations."""
    fuzzed = {(entry_class(env_id).params_class, name) for env_id, name, _ in ENV_CASES}
    declared = set()
    for env_id in ENVS:
        cls = entry_class(env_id)
        for name, p in inspect.signature(cls).parameters.items():
            if p.kind is inspect.Parameter.KEYWORD_ONLY and name != "render_mode":
                declared.add((cls.params_class, name))
    assert declared == fuzzed
    assert len(fuzzed) >= 50  # the three envs: 58 when written


def test_every_wrapper_parameter_is_fuzzed() -> None:
    """Each parameter of each exported wrapper (``env`` aside)."""
    import railgym.wrappers as wrappers

    declared = {
        (getattr(wrappers, w), name)
        for w in wrappers.__all__
        for name in list(inspect.signature(getattr(wrappers, w)).parameters)[1:]
    }
    assert declared == {(a.wrapper, a.name) for a in wrapper_arguments()}


def test_every_flag_of_the_table_is_fuzzed(tmp_path: Path) -> None:
    """Each row (command, flag) of the generated flag table of ``docs/cli.md``."""
    text = DOC.read_text(encoding="utf-8")
    table = text[text.index(BEGIN) : text.index(END)]
    rows = set(re.findall(r"^\| ([\w -]+?) \| `([^`]+)` \|", table, re.M))
    from agents.commands.cli_table import _flag

    fuzzed = {(c.command, _flag(c.action)) for c in cli_cases(Files.make(tmp_path))}
    assert rows == fuzzed
    assert len(rows) > 200
