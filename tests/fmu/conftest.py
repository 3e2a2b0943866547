"""Fixtures of the FMU tests: the user's quarter-car FMUs (:mod:`tests.fmu.user_fmu`),
whole coach (:mod:`tests.fmu.user_coach`) and a fresh Python process (``fresh_python``)."""

from __future__ import annotations

import os
import subprocess
from collections.abc import Callable

import pytest

from tests.fmu.user_coach import user_coach_fmu
from tests.fmu.user_fmu import user_c_fmu, user_py_fmu
from tests.fresh_process import ROOT, run_python

__all__ = ["fresh_python", "user_c_fmu", "user_coach_fmu", "user_py_fmu"]


def _fresh_python(
    script: str, *args: str, timeout: float = 300.0
) -> subprocess.CompletedProcess[str]:
    """``python -c script args…`` in a fresh process from the repository root (faulthandler
    on, ``timeout`` s at most); its exit status and output, whatever the status."""
    env = {**os.environ, "PYTHONFAULTHANDLER": "1"}
    return run_python("-c", script, *args, cwd=ROOT, timeout=timeout, env=env)


@pytest.fixture
def fresh_python() -> Callable[..., subprocess.CompletedProcess[str]]:
    """``run(script, *args, timeout=300)``: ``python -c script args…`` in a fresh process
    from the repository root, faulthandler on; the completed process, whatever its status."""
    return _fresh_python
