"""Fixtures of the FMU tests: the user's quarter-car FMUs (:mod:`tests.fmu.user_fmu`),
whole coach (:mod:`tests.fmu.user_coach`) and a fresh Python process (``fresh_python``)."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.fmu.user_coach import user_coach_fmu
from tests.fmu.user_fmu import user_c_fmu, user_py_fmu

__all__ = ["fresh_python", "user_c_fmu", "user_coach_fmu", "user_py_fmu"]

ROOT = Path(__file__).parents[2]


def _fresh_python(
    script: str, *args: str, timeout: float = 300.0
) -> subprocess.CompletedProcess[str]:
    """``python -c script args…`` in a fresh process from the repository root (faulthandler
    on, ``timeout`` s at most); its exit status and output, whatever the status."""
    return subprocess.run(
        [sys.executable, "-c", script, *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONFAULTHANDLER": "1"},
        timeout=timeout,
        check=False,
    )


@pytest.fixture
def fresh_python() -> Callable[..., subprocess.CompletedProcess[str]]:
    """``run(script, *args, timeout=300)``: ``python -c script args…`` in a fresh process
    from the repository root, faulthandler on; the completed process, whatever its status."""
    return _fresh_python
