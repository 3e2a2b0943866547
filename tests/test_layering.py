"""Imports flow one way: surrogates ← railgym physics ← railgym.report, railgym.envs ← wrappers
← agents."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(
                node.module.split(".")[0]
                if node.module.split(".")[0] != "railgym"
                else ".".join(node.module.split(".")[:2])
            )
    return names


PHYSICS = [
    ROOT / "railgym" / "track.py",
    ROOT / "railgym" / "comfort.py",
    ROOT / "railgym" / "_validation.py",
    *(ROOT / "railgym" / "vehicles").rglob("*.py"),
]


@pytest.mark.parametrize("path", sorted((ROOT / "surrogates").rglob("*.py")), ids=str)
def test_surrogates_need_neither_railgym_nor_gymnasium_nor_torch(path):
    bad = _imports(path) & {"railgym", "railgym.envs", "gymnasium", "torch", "stable_baselines3"}
    assert not bad, f"{path} imports {bad}"


@pytest.mark.parametrize("path", PHYSICS, ids=str)
def test_physics_does_not_use_gymnasium_or_envs(path):
    bad = _imports(path) & {
        "gymnasium",
        "torch",
        "stable_baselines3",
        "railgym.envs",
        "railgym.wrappers",
        "agents",
    }
    assert not bad, f"{path} imports {bad}"


@pytest.mark.parametrize("path", sorted((ROOT / "railgym" / "report").glob("*.py")), ids=str)
def test_report_uses_physics_only(path):
    outer = {"gymnasium", "torch", "stable_baselines3", "railgym.envs", "railgym.wrappers"}
    bad = _imports(path) & (outer | {"agents"})
    assert not bad, f"{path} imports {bad}"


def test_core_imports_without_torch():
    code = (
        "import sys, surrogates, railgym, railgym.envs.vertical, railgym.envs.crash, "
        "railgym.wrappers, railgym.report, agents.controllers, agents.cli; "
        "print('torch' in sys.modules or 'stable_baselines3' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
