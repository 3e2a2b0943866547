"""The ``python -m`` spellings of the physics modules' commands are one error naming the
``railgym`` subcommand (exit 2, nothing run or written), and ``railgym collect-vehicle
--fmu-map`` points to ``railgym collect``."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from agents.commands.cli import MODULE_COMMANDS
from tests.test_no_old_paths import COMMANDS, MODULES, migration_section

ROOT = Path(__file__).resolve().parents[1]
#: the ``python -m`` spellings of physics modules that remain (their API), not their command:
#: an error naming the subcommand
MOVED = [c for c in COMMANDS if c not in MODULES and c.startswith("railgym.")]
#: the ``python -m`` spellings of agents modules that remain (their logic), without a ``__main__``
AGENTS = [c for c in COMMANDS if c not in MODULES and c.startswith("agents.")]
#: module → its ``railgym`` subcommand, as the changelog's table names it
SUBCOMMAND = dict(
    re.findall(r"^\| `python -m ([\w.]+)` \| `(railgym [\w-]+)`", migration_section(), re.M)
)


def _run(argv: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, *argv], capture_output=True, text=True, cwd=cwd, env=env, timeout=120
    )


def test_every_physics_main_is_listed():
    """Each ``__main__`` of ``railgym/`` is a moved spelling of the changelog's table (an
    error naming its subcommand), and each such subcommand is a ``railgym`` command."""
    mains = {
        ".".join(p.relative_to(ROOT).with_suffix("").parts)
        for p in (ROOT / "railgym").rglob("*.py")
        if 'if __name__ == "__main__":' in p.read_text()
    }
    assert mains == set(MOVED)
    assert set(MOVED) <= set(SUBCOMMAND)
    assert {SUBCOMMAND[m].split()[1] for m in MOVED} <= set(MODULE_COMMANDS)


def test_agents_modules_hold_no_main_and_name_a_subcommand():
    """The agents modules whose command moved to :mod:`agents.commands` hold no ``__main__``
    and no parser; the changelog names the ``railgym`` subcommand of each."""
    for module in AGENTS:
        text = (ROOT / Path(*module.split("."))).with_suffix(".py").read_text()
        assert "__main__" not in text and "argparse" not in text, module
        assert SUBCOMMAND[module].split()[1] in MODULE_COMMANDS, module


def test_old_collect_spelling_exits_2_naming_railgym_collect(tmp_path):
    module = "railgym.vehicles.collect"  # (spelled so that the scan of old paths spares it)
    (tmp_path / "x.yaml").write_text("version: 1\nenv: vertical\n")
    done = _run(["-m", module, "--fmu-map", "x.yaml", "-o", "y.json"], tmp_path)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.strip().splitlines() == [
        f"python -m {module}: error: this spelling is no longer a command (0.5.0); run "
        "`railgym collect` (the same arguments)"
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.yaml"]


@pytest.mark.parametrize("module", [m for m in MOVED if m != "railgym.vehicles.collect"])
def test_every_moved_spelling_names_its_subcommand(tmp_path, module):
    done = _run(["-m", module, "-o", "y.json"], tmp_path)
    assert done.returncode == 2 and done.stdout == "" and list(tmp_path.iterdir()) == []
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and f"run `{SUBCOMMAND[module]}`" in lines[0], lines


def test_collect_vehicle_fmu_map_points_to_railgym_collect(tmp_path, capsys, monkeypatch):
    from agents.commands.collect_vehicle import main

    monkeypatch.chdir(tmp_path)
    for argv in (["--fmu-map", "m.yaml", "-o", "y.json"], ["--fmu-map=m.yaml"]):
        with pytest.raises(SystemExit) as info:
            main(argv)
        assert info.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()[-1]
        assert err.startswith("railgym collect-vehicle: error: --fmu-map is not an option")
        assert "`railgym collect --fmu-map MAP.yaml`" in err and "env: vehicle" in err
    assert not (tmp_path / "y.json").exists()
