"""Python in a fresh process, as a user starts it: ``python ARGV`` and the command line
``railgym ARGS``."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

#: the checkout these tests run from
ROOT = Path(__file__).resolve().parents[1]
#: a bare environment: this checkout importable, the system's programs, nothing else of the
#: caller's (no user site, no extras' variables)
BARE_ENV = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}


def run_python(
    *argv: str, cwd: Path | None = None, timeout: float = 600, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """``python ARGV`` (this interpreter) in a fresh process in ``cwd``: the finished
    process with its text output, whatever its exit status. ``timeout`` in s; ``env``: the
    process's environment (``None``: this one's)."""
    return subprocess.run(
        [sys.executable, *argv],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
        check=False,
    )


def run_cli(
    *args: str, cwd: Path | None = None, timeout: float = 600, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """``railgym ARGS`` (``python -m agents.commands.cli``) as :func:`run_python`."""
    return run_python("-m", "agents.commands.cli", *args, cwd=cwd, timeout=timeout, env=env)
