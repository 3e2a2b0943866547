"""0.5.0 removed the old module paths: the modules are gone, the packages re-export nothing, and
nothing of the project (code, tests, docs, configs, examples, benchmarks, CI) names them.

The removed paths are read from the migration tables of ``CHANGELOG.md`` (section 0.5.0), the
one list of them."""

import ast
import importlib.metadata
import os
import re
import tomllib
from pathlib import Path

import pytest

import railgym
import surrogates

ROOT = Path(__file__).resolve().parents[1]
CHANGELOG = ROOT / "CHANGELOG.md"

#: packages whose ``__init__`` re-exported moved names up to 0.4.0: now their docstring only
PACKAGES = (
    "railgym.envs.vertical",
    "railgym.envs.vehicle",
    "railgym.envs.crash",
    "railgym.vehicles.vertical",
    "railgym.vehicles.vehicle",
    "railgym.vehicles.crash",
    "agents.controllers",
    "agents.policies",
)
#: what the scan reads: project text that may name a module
SCANNED = {".py", ".md", ".yaml", ".yml", ".toml", ".sh", ".h", ".c", ".txt", ".cfg", ".ini"}
#: records of the past, left as they were written: the changelog (it holds the tables), the
#: clone detector's log of earlier rounds, the provenance of the packaged data files
HISTORY = {Path("CHANGELOG.md"), Path("docs/duplicates.md"), Path("railgym/data")}


def migration_section() -> str:
    text = CHANGELOG.read_text()
    start = text.index("## [0.5.0]")
    end = text.index("\n## [", start + 1)
    return text[start:end]


def removed_paths() -> tuple[list[str], list[str]]:
    """``(modules, python -m spellings)`` of the 0.5.0 migration tables."""
    section = migration_section()
    modules = re.findall(r"^\| `((?:agents|railgym)\.[\w.]+)` \|", section, re.M)
    commands = re.findall(r"^\| `python -m ((?:agents|railgym)\.[\w.]+)` \|", section, re.M)
    return modules, commands


MODULES, COMMANDS = removed_paths()


def test_the_changelog_lists_every_removed_module_and_command():
    assert len(MODULES) == len(set(MODULES)) == 51
    # the spellings of modules that remain (their API; a physics module's ``__main__`` is an
    # error naming the ``railgym`` subcommand, an agents module has none):
    # tests/test_moved_commands.py
    moved = [c for c in COMMANDS if c not in MODULES]
    assert len(COMMANDS) == len(set(COMMANDS)) == 28 and len(moved) == 17
    assert {"railgym.vehicles.collect", "railgym.fmu.collect"} <= set(moved)
    assert {"agents.lqg", "railgym.envs.vertical_batch", "railgym.vehicles.collect_vehicle"} <= set(
        MODULES
    )


@pytest.mark.parametrize("module", MODULES)
def test_removed_module_is_gone(module):
    relative = Path(*module.split("."))
    assert not (ROOT / relative.with_suffix(".py")).exists(), module
    assert not (ROOT / relative / "__init__.py").exists(), module


@pytest.mark.parametrize("package", PACKAGES)
def test_package_init_holds_its_docstring_only(package):
    tree = ast.parse((ROOT / Path(*package.split(".")) / "__init__.py").read_text())
    assert len(tree.body) == 1 and ast.get_docstring(tree), package


def _scanned_files() -> list[Path]:
    found = []
    for folder, dirs, files in os.walk(ROOT):
        here = Path(folder)
        dirs[:] = [
            d
            for d in dirs
            if (not d.startswith(".") or d == ".ci")
            and d != "__pycache__"
            and not d.endswith(".egg-info")
            and not (here / d / "pyvenv.cfg").exists()
            and (here / d).relative_to(ROOT) not in HISTORY
        ]
        for name in files:
            path = here / name
            relative = path.relative_to(ROOT)
            if relative in HISTORY or path == Path(__file__).resolve():
                continue
            if path.suffix in SCANNED or relative.parent == Path(".ci"):
                found.append(path)
    return found


def _pattern(modules: list[str]) -> re.Pattern[str]:
    """A dotted name ``a.b.c`` (not part of a longer one) or its file ``a/b/c.py``."""
    dotted = "|".join(re.escape(m) for m in sorted(modules, key=len, reverse=True))
    files = "|".join(re.escape(m.replace(".", "/")) + r"\.py" for m in modules)
    return re.compile(rf"(?<![\w./])(?:{dotted})(?!\w)|(?<![\w./])(?:{files})")


def _command_pattern(modules: list[str]) -> re.Pattern[str]:
    """``python -m a.b.c`` or ``"-m", "a.b.c"`` (a subprocess's argv) of a module that remains."""
    dotted = "|".join(re.escape(m) for m in sorted(modules, key=len, reverse=True))
    return re.compile(rf"""(?:python -m |"-m", ")(?:{dotted})(?![\w.])""")


def test_command_pattern_finds_the_spelling_not_the_module():
    pattern = _command_pattern(["railgym.vehicles.collect"])
    for text in (
        "python -m railgym.vehicles.collect --x",
        '[sys.executable, "-m", "railgym.vehicles.collect"]',
    ):
        assert pattern.search(text), text
    for text in ("railgym.vehicles.collect.main", "python -m railgym.vehicles.collect_vehicle"):
        assert not pattern.search(text), text


def test_pattern_finds_a_removed_path_and_spares_the_new_ones():
    pattern = _pattern(["agents.train", "railgym.envs.crash_step"])
    for text in ("python -m agents.train x", "`agents.train.main`", "agents/train.py"):
        assert pattern.search(text), text
    for text in ("agents.training.train", "agents.train_config", "railgym.envs.crash.step"):
        assert not pattern.search(text), text


def test_nothing_of_the_project_names_a_removed_path():
    files = _scanned_files()
    assert ROOT / "README.md" in files and ROOT / "agents" / "commands" / "cli.py" in files
    patterns = (_pattern(MODULES), _command_pattern([c for c in COMMANDS if c not in MODULES]))
    named = [
        f"{path.relative_to(ROOT)}:{number}: {match.group(0)}"
        for path in files
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1)
        for pattern in patterns
        for match in pattern.finditer(line)
    ]
    assert named == []


def test_version_is_the_installed_distributions():
    assert railgym.__version__ == importlib.metadata.version("railgym")
    assert surrogates.__version__ == railgym.__version__


def test_changelog_heads_with_the_version_of_pyproject():
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert re.search(r"^## \[(.+?)\]", CHANGELOG.read_text(), re.M).group(1) == version
