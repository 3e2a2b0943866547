"""Marks shared by the test files."""

import shutil

import pytest

#: skips a test (or, as ``pytestmark``, a whole file) where no C compiler builds an FMU
needs_cc = pytest.mark.skipif(
    shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler"
)
