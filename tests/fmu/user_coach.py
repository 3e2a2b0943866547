"""The user's whole coach for tests: a whole-vehicle FMU "a user would bring", written without
railgym (``user_models/coach.c`` and its ``coach.modelDescription.xml`` template), built at
test time with the system C compiler (:func:`tests.fmu.user_fmu.build_c_fmu`).

Another coach than railgym's (carbody 38 t, 24.5 m, bending 9.2 Hz; bogies 3.1 t, 17.2 m
apart) in the user's own conventions: displacements in mm, pitch positive nose down, the
bending coordinate normalised to the carbody ends, actuator forces in kN; a nonlinear
secondary with a Maxwell damper and no bump stops; outputs only the bodies' displacements,
rates and accelerations (no forces). :data:`COACH_MAPPING_YAML` maps it on
``VerticalVehicle``'s signals with expressions; :data:`COACH_YAML` and
:data:`COACH_BASE_YAML` are the user's whole-vehicle file and its one-bogie ``base:`` in
railgym's conventions (the secondary linearised: k2, c2 the tangents at rest, low
frequency). The fixture ``user_coach_fmu`` is registered for ``tests/fmu/`` by its
``conftest.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.fmu.user_fmu import build_c_fmu

__all__ = [
    "COACH_BASE_YAML",
    "COACH_MAPPING_YAML",
    "COACH_YAML",
    "build_user_coach_fmu",
    "coach_secondary_force",
    "user_coach_fmu",
    "write_coach_project",
]

#: the coach's mode shape over the bogies and at the centre, end-normalised (coach.c)
PHI_BOGIE = 0.316503867672641
PHI_CENTRE = -0.6078222294162603
A = 8.6

#: the one-bogie base of the whole-vehicle file: primary per bogie, secondary linearised
COACH_BASE_YAML = """\
vehicle:
  name: user_coach_bogie
  m1: 3100.0          # kg, bogie (the whole-vehicle file's bogie_mass is used)
  m2: 19000.0         # kg, half the carbody
  k1: 2.8e+6          # N/m, primary per bogie (1.4e6 per wheelset)
  c1: 4.0e+4          # N·s/m
  k2: 5.0e+5          # N/m, spring tangent at rest (the Maxwell mount adds 1.5e6 at speed)
  c2: 2.55e+4         # N·s/m, mean of 1.6e4 and 1.1e4 plus the Maxwell damper's 1.2e4
  gravity: 9.81
"""

#: the whole-vehicle file (``base:`` filled in by :func:`write_coach_project`); the bending
#: modal mass is the centre-normalised one of a uniform 24.5 m beam (railgym's convention)
COACH_YAML = """\
base: {base}
whole_vehicle:
  carbody_mass: 38000.0
  carbody_pitch_inertia: 2.3e+6
  carbody_length: 24.5
  bending_frequency: 9.2
  bending_damping: 0.025
  bending_modal_mass: 25714.05
  bogie_mass: 3100.0
  bogie_pitch_inertia: 1900.0
  bogie_semi_spacing: 8.6
  semi_wheelbase: 1.25
"""


def _floor(prefix: str, sign: str, phi: float, suffix: str) -> str:
    """The expression of the carbody's vertical motion at x = ``sign`` A (``suffix``: ``""``,
    ``"_d"``, ``"_dd"``) in the coach's variables (pitch nose down: ``z − x·phi``)."""
    pitch = f" {'-' if sign == '+' else '+'} {A} * phiK{suffix}" if sign else ""
    bend = f" + {phi}" if phi > 0 else f" - {-phi}"
    return f"{prefix}zK{suffix}{pitch}{bend} * eta{suffix}"


COACH_MAPPING_YAML = f"""\
version: 1
env: vehicle
fmi_type: CoSimulation
inputs:
  track:
    - {{displacement: zr1, rate: zr1_dot}}
    - {{displacement: zr2, rate: zr2_dot}}
    - {{displacement: zr3, rate: zr3_dot}}
    - {{displacement: zr4, rate: zr4_dot}}
  actuator_force: [Fa1, Fa2]
outputs:
  acc_front: {_floor("", "+", PHI_BOGIE, "_dd")}
  acc_centre: {_floor("", "", PHI_CENTRE, "_dd")}
  acc_rear: {_floor("", "-", PHI_BOGIE, "_dd")}
  bogie_acc_front: zB1_dd
  bogie_acc_rear: zB2_dd
  deflection_front: zB1 - ({_floor("", "+", PHI_BOGIE, "")})
  deflection_rear: zB2 - ({_floor("", "-", PHI_BOGIE, "")})
  deflection_rate_front: zB1_d - ({_floor("", "+", PHI_BOGIE, "_d")})
  deflection_rate_rear: zB2_d - ({_floor("", "-", PHI_BOGIE, "_d")})
  carbody_vel_front: {_floor("", "+", PHI_BOGIE, "_d")}
  carbody_vel_rear: {_floor("", "-", PHI_BOGIE, "_d")}
"""


def coach_secondary_force(delta: np.ndarray, delta_dot: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The coach's secondary force per bogie (N) at deflection ``delta`` (m), its rate (m/s)
    and the Maxwell damper's internal displacement ``u`` (m), as ``coach.c``."""
    w = 0.5 * (1.0 + np.tanh(delta_dot / 0.02))
    c = 1.1e4 + (1.6e4 - 1.1e4) * w
    return 5.0e5 * delta * (1.0 + 40.0 * delta**2) + c * delta_dot + 1.5e6 * (delta - u)


def build_user_coach_fmu(dest: Path) -> Path:
    """Compile ``coach.c`` into ``dest/coach.fmu``; ``pytest.skip`` without a C compiler."""
    return build_c_fmu(dest, "coach", "COACH_GUID")


def write_coach_project(folder: Path, fmu: Path) -> Path:
    """The user's folder: ``coach_base.yaml``, ``coach.yaml`` and the mapping ``coach_map.yaml``
    (``fmu:`` the built FMU, ``vehicle: coach.yaml``); returns the mapping's path."""
    (folder / "coach_base.yaml").write_text(COACH_BASE_YAML)
    (folder / "coach.yaml").write_text(COACH_YAML.format(base=folder / "coach_base.yaml"))
    path = folder / "coach_map.yaml"
    path.write_text(f"fmu: {fmu}\nvehicle: coach.yaml\n" + COACH_MAPPING_YAML)
    return path


@pytest.fixture(scope="session")
def user_coach_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Path of the user's whole-coach FMU (``coach.fmu``), built once per session."""
    return build_user_coach_fmu(tmp_path_factory.mktemp("user_coach_fmu"))
