"""Fixtures of the FMU tests: the user's quarter-car FMUs (:mod:`tests.fmu.user_fmu`) and
whole coach (:mod:`tests.fmu.user_coach`)."""

from tests.fmu.user_coach import user_coach_fmu
from tests.fmu.user_fmu import user_c_fmu, user_py_fmu

__all__ = ["user_c_fmu", "user_coach_fmu", "user_py_fmu"]
