"""Fixtures of the vertical env tests: the user's quarter-car FMUs (:mod:`tests.fmu.user_fmu`)."""

from tests.fmu.user_fmu import user_c_fmu, user_py_fmu

__all__ = ["user_c_fmu", "user_py_fmu"]
