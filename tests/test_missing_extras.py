"""A missing optional extra is one line naming the extra to install and exit status 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: runs module argv[2] as __main__ with the top-level modules in argv[1] not installed
BLOCKED_RUN = """
import runpy, sys
blocked = set(sys.argv[1].split(","))
class NotInstalled:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in blocked:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
sys.meta_path.insert(0, NotInstalled())
sys.argv = sys.argv[2:]
runpy.run_module(sys.argv[0], run_name="__main__", alter_sys=True)
"""


def run_without(blocked: str, *argv: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", BLOCKED_RUN, blocked, *argv],
        capture_output=True,
        text=True,
        cwd=cwd,
        env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
        timeout=300,
    )


@pytest.mark.parametrize(
    ("blocked", "argv", "message"),
    [
        (
            "torch",
            ("agents.commands.cli", "evaluate", "model.zip"),
            "railgym evaluate: error: loading a stable-baselines3 policy needs the 'agents' "
            "extra (no module named 'torch'): pip install 'railgym[agents]'",
        ),
        (
            "ray",
            ("agents.commands.cli", "train-rllib", "config.yaml"),
            "railgym train-rllib: error: RLlib training (agents.training.train_rllib) needs the "
            "'rllib' extra (no module named 'ray'): pip install 'railgym[rllib]' in its own "
            "virtual environment",
        ),
        (
            "stable_baselines3",
            ("agents.commands.cli", "train", "config.yaml"),
            "railgym train: error: training (agents.training.train) needs the 'agents' extra "
            "(no module named 'stable_baselines3'): pip install 'railgym[agents]'",
        ),
    ],
)
def test_missing_extra_names_it_and_exits_2(tmp_path, blocked, argv, message):
    (tmp_path / "model.zip").write_bytes(b"PK")
    out = run_without(blocked, *argv, cwd=tmp_path)
    assert out.returncode == 2, out.stderr
    assert out.stderr.startswith(message) and len(out.stderr.splitlines()) == 1
    assert "Traceback" not in out.stderr


def test_import_of_a_module_without_its_extra_is_an_import_error():
    """Imported (not run), the module raises an ImportError that names the extra, so callers
    such as ``railgym evaluate`` of an RLlib checkpoint can catch it."""
    code = (
        BLOCKED_RUN.split("sys.argv = ")[0]
        + "try:\n    import agents.training.train_rllib\n"
        + "except ImportError as err:\n    print(err)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, "ray"],
        capture_output=True,
        text=True,
        env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
        timeout=300,
    )
    assert "needs the 'rllib' extra" in out.stdout, out.stderr
