"""The user's FMUs for tests: a quarter car "a user would bring", written without railgym.

Two FMI 2.0 co-simulation FMUs of the same car, built at test time into a temporary folder:

* ``user_c_fmu``: hand-written C (``user_models/quarter_car.c``, the FMI glue the user's
  models share, ``user_fmi2_glue.h`` and ``user_quarter_car.h``, and the
  ``quarter_car.modelDescription.xml`` template), compiled with the system C compiler
  (``$CC``, ``cc`` or ``gcc``) against the FMI 2.0 standard headers of
  ``surrogates/fmi/c/third_party``;
* ``user_py_fmu``: a pythonfmu 0.7.0 slave (``user_models/quarter_car_py.py``), built with
  ``python -m pythonfmu build``.

Both skip with the reason when their tool is missing. The car (:data:`USER_CAR`): bogie
1 800 kg, carbody share 8 000 kg, linear primary, a nonlinear secondary without bump stops
(:func:`user_secondary_force`); inputs ``zr`` (m), ``zr_dot`` (m/s), ``Fact`` (N, upwards on
the carbody); outputs only the states ``x1, v1, x2, v2`` and ``a2`` (m/s²), from the static
equilibrium, positive upwards. ``fmi2DoStep`` integrates with RK4 in
:data:`USER_CAR`.n_substeps substeps, the inputs held over the communication step.

The fixtures are registered for ``tests/fmu/`` by its ``conftest.py``; a test elsewhere
imports them (``from tests.fmu.user_fmu import user_c_fmu  # noqa: F401``).
:data:`USER_VEHICLE_YAML` (the ``vehicle:`` block of the car, linearised) and
:data:`USER_MAPPING_YAML` (the ``vertical`` env's mapping on the states, with expressions)
are strings for tests to write where they need them.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import uuid
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pytest

__all__ = [
    "OUTPUTS",
    "USER_CAR",
    "USER_MAPPING_YAML",
    "USER_VEHICLE_YAML",
    "UserQuarterCar",
    "build_c_fmu",
    "build_user_c_fmu",
    "build_user_py_fmu",
    "run_user_fmu",
    "simulate_user_car",
    "user_c_fmu",
    "user_py_fmu",
    "user_secondary_force",
]

MODELS = Path(__file__).parent / "user_models"
FMI2_HEADERS = Path(__file__).parents[2] / "surrogates" / "fmi" / "c" / "third_party"
INPUTS = ("zr", "zr_dot", "Fact")
OUTPUTS = ("x1", "v1", "x2", "v2", "a2")


class UserQuarterCar(NamedTuple):
    """Parameters of the user's quarter car (SI), as compiled into both FMUs."""

    m1: float = 1800.0  #: kg, bogie
    m2: float = 8000.0  #: kg, carbody share
    k1: float = 2.4e6  #: N/m, primary
    c1: float = 3.0e4  #: N·s/m, primary
    k2: float = 4.3e5  #: N/m, secondary, linear term
    progression: float = 30.0  #: 1/m², secondary spring k2·δ·(1 + progression·δ²)
    c_compression: float = 2.0e4  #: N·s/m, δ̇ > 0
    c_rebound: float = 1.4e4  #: N·s/m, δ̇ < 0
    v_blend: float = 0.01  #: m/s, tanh blend of the two damper slopes
    n_substeps: int = 4  #: RK4 substeps per communication step
    gravity: float = 9.81  #: m/s², balanced by the static preload (not in the equations)


USER_CAR = UserQuarterCar()

#: the car's ``vehicle:`` block, linearised about the static equilibrium (k2, c2: tangents
#: at δ = 0, δ̇ = 0; the tanh blend gives the mean of the two damper slopes there)
USER_VEHICLE_YAML = """\
# The user's quarter car of tests/fmu/user_models, linearised about static equilibrium.
vehicle:
  name: user_quarter_car
  m1: 1800.0          # kg, bogie
  m2: 8000.0          # kg, carbody share
  k1: 2.4e+6          # N/m, primary
  c1: 3.0e+4          # N·s/m, primary
  k2: 4.3e+5          # N/m, tangent of k2·δ·(1 + 30 δ²) at δ = 0
  c2: 1.7e+4          # N·s/m, tangent at δ̇ = 0: mean of 2.0e4 (compression), 1.4e4 (rebound)
  gravity: 9.81       # m/s², balanced by the secondary preload
"""

#: mapping of ``VerticalSuspension-v1`` on the user's FMUs (the FMU given as ``fmu=``); the
#: deflection, its rate and the bogie acceleration are expressions of the states
USER_MAPPING_YAML = """\
version: 1
env: vertical
fmi_type: CoSimulation
inputs:
  track:
    - {displacement: zr, rate: zr_dot}
  actuator_force: [Fact]
outputs:
  carbody_acc: a2
  bogie_acc: der(v1)
  deflection: x1 - x2
  deflection_rate: v1 - v2
  carbody_vel: v2
  carbody_disp: x2
"""


def user_secondary_force(delta: Any, delta_dot: Any, car: UserQuarterCar = USER_CAR) -> Any:
    """The FMUs' secondary force (N, compression positive, no bump stops) at deflection
    ``delta = x1 − x2`` (m) and its rate ``delta_dot`` (m/s); scalars or arrays."""
    delta, delta_dot = np.asarray(delta, float), np.asarray(delta_dot, float)
    w = 0.5 * (1.0 + np.tanh(delta_dot / car.v_blend))
    c = car.c_rebound + (car.c_compression - car.c_rebound) * w
    return car.k2 * delta * (1.0 + car.progression * delta * delta) + c * delta_dot


def _rates(x: list[float], u: Sequence[float], car: UserQuarterCar) -> list[float]:
    fs = float(user_secondary_force(x[0] - x[2], x[1] - x[3], car))
    f1 = car.k1 * (u[0] - x[0]) + car.c1 * (u[1] - x[1])
    return [x[1], (f1 - fs - u[2]) / car.m1, x[3], (fs + u[2]) / car.m2]


def simulate_user_car(
    zr: np.ndarray,
    zr_dot: np.ndarray,
    fact: np.ndarray,
    dt: float,
    car: UserQuarterCar = USER_CAR,
) -> np.ndarray:
    """The car in plain Python as its FMUs integrate it: from rest, communication steps of
    ``dt`` (s) with the inputs of row ``k`` held over step ``k`` (RK4 in ``n_substeps``).
    Returns (len(zr) + 1, 5): ``x1, v1, x2, v2, a2`` at t = 0, dt, …; ``a2`` of row ``k + 1``
    with the force of input row ``k`` (what a master reads after ``fmi2DoStep``)."""
    x = [0.0, 0.0, 0.0, 0.0]
    h = dt / car.n_substeps
    out = np.empty((len(zr) + 1, 5))

    def row(f: float) -> list[float]:
        fs = float(user_secondary_force(x[0] - x[2], x[1] - x[3], car))
        return [*x, (fs + f) / car.m2]

    out[0] = row(0.0)
    for k in range(len(zr)):
        u = (float(zr[k]), float(zr_dot[k]), float(fact[k]))
        for _ in range(car.n_substeps):
            k1 = _rates(x, u, car)
            k2 = _rates([a + 0.5 * h * b for a, b in zip(x, k1, strict=True)], u, car)
            k3 = _rates([a + 0.5 * h * b for a, b in zip(x, k2, strict=True)], u, car)
            k4 = _rates([a + h * b for a, b in zip(x, k3, strict=True)], u, car)
            x = [
                a + h / 6.0 * (p + 2.0 * q + 2.0 * r + s)
                for a, p, q, r, s in zip(x, k1, k2, k3, k4, strict=True)
            ]
        out[k + 1] = row(u[2])
    return out


def run_user_fmu(
    fmu: str | Path, zr: np.ndarray, zr_dot: np.ndarray, fact: np.ndarray, dt: float
) -> np.ndarray:
    """A plain FMPy co-simulation master: from rest, set the inputs of row ``k``, one
    ``fmi2DoStep`` of ``dt`` (s), read the outputs. Returns (len(zr) + 1, 5) in the order of
    :data:`OUTPUTS` (row 0 after initialisation), as :func:`simulate_user_car`. The instance
    is terminated, freed and its library unloaded before returning."""
    import tempfile

    from fmpy import extract, read_model_description  # type: ignore[import-untyped, unused-ignore]
    from fmpy.fmi2 import FMU2Slave  # type: ignore[import-untyped, unused-ignore]

    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    path = list(sys.path)  # a pythonfmu slave puts its resources folder on it
    vr_in, vr_out = [vr[n] for n in INPUTS], [vr[n] for n in OUTPUTS]
    out = np.empty((len(zr) + 1, len(OUTPUTS)))
    with tempfile.TemporaryDirectory(prefix="user-fmu-") as unzipdir:
        extract(str(fmu), unzipdir=unzipdir)
        slave = FMU2Slave(
            guid=md.guid,
            unzipDirectory=unzipdir,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName="user",
        )
        slave.instantiate()
        try:
            slave.setupExperiment(startTime=0.0)
            slave.enterInitializationMode()
            slave.setReal(vr_in, [0.0, 0.0, 0.0])
            slave.exitInitializationMode()
            out[0] = slave.getReal(vr_out)
            for k in range(len(zr)):
                slave.setReal(vr_in, [float(zr[k]), float(zr_dot[k]), float(fact[k])])
                slave.doStep(currentCommunicationPoint=k * dt, communicationStepSize=dt)
                out[k + 1] = slave.getReal(vr_out)
            slave.terminate()
        finally:
            slave.freeInstance()  # also unloads the shared library
            sys.path[:] = path
    return out


# ---------------------------------------------------------------------------- building
def _compiler() -> str | None:
    for cand in (os.environ.get("CC") or "cc", "gcc"):
        if found := shutil.which(cand):
            return found
    return None


def build_user_c_fmu(dest: Path, model: str = "quarter_car") -> Path:
    """Compile ``user_models/MODEL.c`` (its GUID macro ``MODEL_GUID`` in capitals) and zip
    it with its model description into ``dest/MODEL.fmu``; ``pytest.skip`` without a C
    compiler. ``model``: ``quarter_car`` or ``air_spring_car``."""
    return build_c_fmu(dest, model, f"{model.upper()}_GUID")


def build_c_fmu(dest: Path, stem: str, guid_macro: str) -> Path:
    """Compile ``user_models/STEM.c`` (its GUID given by ``-DGUID_MACRO``) and zip it with
    ``STEM.modelDescription.xml`` into ``dest/STEM.fmu``; ``pytest.skip`` without a C
    compiler."""
    import fmpy  # type: ignore[import-untyped, unused-ignore]

    cc = _compiler()
    if cc is None:
        pytest.skip(f"no C compiler ($CC, cc or gcc) to build the user's C FMU {stem}")
    source = MODELS / f"{stem}.c"
    template = (MODELS / f"{stem}.modelDescription.xml").read_text(encoding="utf-8")
    headers = sorted(MODELS.glob("*.h"))  # the user's FMI glue, #included
    glue = b"".join(h.read_bytes() for h in headers)
    digest = hashlib.sha256(source.read_bytes() + glue + template.encode()).hexdigest()
    guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, f"{stem}:" + digest)) + "}"
    build = dest / f"{stem}_build"
    lib = build / "binaries" / fmpy.platform / f"{stem}{fmpy.sharedLibraryExtension}"
    lib.parent.mkdir(parents=True)
    cmd = [
        cc,
        "-shared",
        "-fPIC",
        "-O2",
        "-std=c99",
        "-ffp-contract=off",
        f"-I{FMI2_HEADERS}",
        f'-D{guid_macro}="{guid}"',
        "-o",
        str(lib),
        str(source),
        "-lm",
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{done.stderr}")
    fmu = dest / f"{stem}.fmu"
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("modelDescription.xml", template.replace("@GUID@", guid))
        zf.write(lib, f"binaries/{fmpy.platform}/{lib.name}")
        zf.write(source, f"sources/{stem}.c")
        for h in headers:
            zf.write(h, f"sources/{h.name}")
    return fmu


def build_user_py_fmu(dest: Path) -> Path:
    """Build ``quarter_car_py.py`` with ``python -m pythonfmu build`` into
    ``dest/QuarterCar.fmu``; ``pytest.skip`` without pythonfmu or its binary."""
    try:
        from pythonfmu import FmuBuilder  # type: ignore[import-untyped, unused-ignore]
    except ImportError:
        pytest.skip("pythonfmu is not installed (pip install pythonfmu==0.7.0; in the dev extra)")
    if not FmuBuilder.has_binary():
        pytest.skip("pythonfmu has no binary for this platform")
    work = dest / "quarter_car_py_build"
    work.mkdir()
    script = work / "quarter_car_py.py"  # a copy: no __pycache__ in the source tree
    shutil.copy2(MODELS / "quarter_car_py.py", script)
    cmd = [sys.executable, "-m", "pythonfmu", "build", "-f", str(script), "-d", str(dest)]
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=work, check=False)
    fmu = dest / "QuarterCar.fmu"
    if done.returncode != 0 or not fmu.is_file():
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{done.stdout}\n{done.stderr}")
    return fmu


@pytest.fixture(scope="session")
def user_c_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Path of the user's C quarter-car FMU (``quarter_car.fmu``), built once per session."""
    return build_user_c_fmu(tmp_path_factory.mktemp("user_c_fmu"))


@pytest.fixture(scope="session")
def user_py_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Path of the user's pythonfmu quarter-car FMU (``QuarterCar.fmu``), built once per
    session."""
    return build_user_py_fmu(tmp_path_factory.mktemp("user_py_fmu"))
