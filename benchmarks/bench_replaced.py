"""What the surrogate element buys over the models it replaces (issue 32), measured in one run.

For each env, the surrogate vector env against the reference vector env (``backend=
"reference"``, the model the element replaces), both :data:`N_VEC` sub-envs, :data:`STEPS`
steps per timed call, on :data:`THREADS` numba threads; and for the envs whose reference
exports as an FMU (:data:`railgym.fmu.reference.ENVS`), against the FMU-in-the-loop env of
the same vehicle: ``backend="fmu"`` on the FMU :func:`railgym.fmu.reference.export_reference_fmu`
writes (C, stepped through FMPy), the tool a user would otherwise train on, as a vector env
of :data:`FMU_ENVS` sub-envs (one FMU instance per sub-env, stepped one after another). The
three envs of one vehicle are timed in interleaved rounds (:mod:`benchmarks._timing`); a
ratio's samples are the per-round ratios of env-steps/s. Targets: the surrogate ≥ 5 × the
reference and ≥ 100 × the FMU in the loop.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Any

import gymnasium as gym
import numba
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from agents.evaluation.speed import fmu_unavailable
from benchmarks import measured, row
from benchmarks._stepping import rate, vector_steps
from benchmarks._timing import interleaved
from railgym.fmu.reference import ENVS as EXPORTED
from railgym.fmu.reference import export_reference_fmu

#: env id: the ``env`` of :func:`~railgym.fmu.reference.export_reference_fmu` (``None``: no
#: FMU of its reference)
ENVS: dict[str, str | None] = {
    "railgym/VerticalSuspension-v1": "vertical",
    "railgym/VerticalSuspension-v2": "vertical",
    "railgym/VerticalVehicle-v1": "vehicle",
    "railgym/VerticalVehicle-v2": "vehicle",
    "railgym/VerticalSuspension-v3": "vertical",
    "railgym/VerticalVehicle-v3": "vehicle",
    "railgym/TrainCrash-v1": None,
}
N_VEC = 1024
#: numba threads of every timed call
THREADS = 2
#: vector-env steps per timed call of the surrogate and the reference
STEPS = 10
#: sub-envs and steps per timed call of the FMU-in-the-loop env
FMU_ENVS, FMU_STEPS = 16, 20
TARGET_REFERENCE, TARGET_FMU = "≥ 5", "≥ 100"
_MODE = "vector_entry_point"


def fmu_env(env_id: str, tmp: Path) -> tuple[gym.vector.VectorEnv | None, str]:
    """The FMU-in-the-loop vector env of ``env_id`` on the reference FMU exported into
    ``tmp``, and a note; ``(None, why)`` when there is no FMU of its reference, or FMPy or a C
    compiler is missing."""
    kind = ENVS[env_id]
    if kind is None:
        return None, f"no FMU of its reference (exported: {', '.join(EXPORTED)})"
    why = fmu_unavailable()
    if why is not None:
        return None, why
    fmu, mapping = export_reference_fmu(tmp / f"{env_id.split('/')[1]}.fmu", env=kind)
    venv = gym.make_vec(
        env_id, num_envs=FMU_ENVS, vectorization_mode=_MODE, backend="fmu", fmu=fmu, fmu_map=mapping
    )
    return venv, f"{FMU_ENVS} FMU instances in turn, FMPy, {FMU_STEPS} steps per call"


def ratio_rows(
    name: str, rates: dict[str, np.ndarray], fmu_note: str, threads: int = THREADS
) -> list[dict]:
    """Rows of one env from its env-steps/s samples, one per round (``"surrogate"``,
    ``"reference"`` and, if measured, ``"fmu"``) on ``threads`` numba threads: the rates, the
    surrogate over the reference and over the FMU env (per-round ratios,
    :data:`TARGET_REFERENCE`, :data:`TARGET_FMU`), or a row saying why the FMU env was not
    measured (``fmu_note``)."""
    sur, ref = rates["surrogate"], rates["reference"]
    same = f"{N_VEC} sub-envs each, {STEPS} steps per call, {threads} numba threads"
    rows = [
        measured(f"{name} surrogate vector ({N_VEC})", sur / 1e6, "M steps/s", context=same),
        measured(f"{name} reference vector ({N_VEC})", ref / 1e6, "M steps/s", context=same),
        measured(
            f"  surrogate / reference ({name})",
            sur / ref,
            "×",
            TARGET_REFERENCE,
            "env-steps/s, per-round ratios",
        ),
    ]
    if "fmu" not in rates:
        return rows + [row(f"  surrogate / FMU env ({name})", np.nan, "×", context=fmu_note)]
    fmu = rates["fmu"]
    return rows + [
        measured(f"{name} FMU in the loop ({FMU_ENVS})", fmu / 1e3, "k steps/s", context=fmu_note),
        measured(
            f"  surrogate / FMU env ({name})",
            sur / fmu,
            "×",
            TARGET_FMU,
            "env-steps/s, per-round ratios",
        ),
    ]


def _zero(venv: gym.vector.VectorEnv) -> np.ndarray:
    return np.zeros(tuple(venv.action_space.shape or ()), np.float32)


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``)."""
    threads = numba.get_num_threads()
    tmp = Path(tempfile.mkdtemp(prefix="bench-replaced-"))
    rows: list[dict] = []
    try:
        used = min(THREADS, threads)
        numba.set_num_threads(used)
        for env_id in ENVS:
            envs: list[Any] = []
            try:
                fns = {}
                for backend in ("surrogate", "reference"):
                    venv = gym.make_vec(
                        env_id, num_envs=N_VEC, vectorization_mode=_MODE, backend=backend
                    )
                    envs.append(venv)
                    fns[backend] = vector_steps(venv, _zero(venv), STEPS)
                fmu, note = fmu_env(env_id, tmp)
                if fmu is not None:
                    envs.append(fmu)
                    fns["fmu"] = vector_steps(fmu, _zero(fmu), FMU_STEPS)
                rates = {k: rate(fns[k], w.seconds) for k, w in interleaved(fns).items()}
            finally:
                for env in envs:
                    env.close()
            rows += ratio_rows(env_id.split("/")[1], rates, note, used)
    finally:
        numba.set_num_threads(threads)
        shutil.rmtree(tmp, ignore_errors=True)
    return rows


if __name__ == "__main__":
    for r in run():
        print(r)
