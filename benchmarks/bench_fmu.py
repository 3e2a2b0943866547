"""What the surrogate buys over an FMU in the loop (issue 20), measured in one run.

``VerticalSuspension-v1`` with ``backend="fmu"`` on the exported reference FMU (C, stepped
through FMPy: 10 ``fmi2DoStep`` of 1 ms per control step in co-simulation, 10 RK4 steps of 4
``fmi2GetDerivatives`` in model exchange) — how fmugym-style tools train — against the
surrogate vector env (1024 sub-envs, the way railgym trains). Target: the surrogate vector
env ≥ 50 × the env-steps/s of the FMU-in-the-loop env.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from agents.evaluation.speed import fmu_unavailable
from benchmarks import measured, row
from benchmarks._stepping import rate, steps, vector_steps
from benchmarks._timing import interleaved
from railgym.fmu.reference import export_reference_fmu

ID = "railgym/VerticalSuspension-v1"
N_VEC = 1024


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``)."""
    why = fmu_unavailable()
    if why is not None:
        return [row("FMU env (skipped)", float("nan"), "", context=why)]
    tmp = Path(tempfile.mkdtemp(prefix="bench-fmu-"))
    envs: list = []
    try:
        fmu, mapping = export_reference_fmu(tmp / "vehicle.fmu")
        zero = np.zeros(1, np.float32)
        fns = {}
        for fmi_type in ("CoSimulation", "ModelExchange"):
            path = tmp / f"{fmi_type}.yaml"
            path.write_text(mapping.read_text() + f"fmi_type: {fmi_type}\n")
            envs.append(gym.make(ID, backend="fmu", fmu=fmu, fmu_map=path))
            fns[fmi_type] = steps(envs[-1], lambda k: zero, 20)
        fns["reference"] = steps(gym.make(ID, backend="reference"), lambda k: zero)
        venv = gym.make_vec(ID, num_envs=N_VEC, vectorization_mode="vector_entry_point")
        envs.append(venv)
        fns["surrogate"] = vector_steps(venv, np.zeros((N_VEC, 1), np.float32), 10)
        w = interleaved(fns)
    finally:
        for env in envs:
            env.close()
        shutil.rmtree(tmp, ignore_errors=True)
    r = {k: rate(fns[k], w[k].seconds) for k in fns}
    cs = r["CoSimulation"]
    return [
        measured("VerticalSuspension fmu CS (single)", cs, "steps/s", context="FMPy, 10 doStep"),
        measured(
            "VerticalSuspension fmu ME (single)",
            r["ModelExchange"],
            "steps/s",
            context="FMPy, railgym RK4",
        ),
        measured(
            "VerticalSuspension reference (single)", r["reference"], "steps/s", context="numba"
        ),
        measured(
            f"VerticalSuspension surrogate vec ({N_VEC})",
            r["surrogate"],
            "steps/s",
            context="numba lanes, default threads",
        ),
        measured(
            "surrogate vec / fmu CS",
            r["surrogate"] / cs,
            "×",
            "≥ 50",
            "env-steps/s, same run, interleaved rounds",
        ),
    ]
