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
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from benchmarks import row

ID = "railgym/VerticalSuspension-v1"
N_VEC = 1024


def _rate(env: gym.Env, n: int) -> float:
    """Env-steps/s of a single env over ``n`` steps with zero action (after a warm-up)."""
    zero = np.zeros(1, np.float32)
    env.reset(seed=0)
    for _ in range(20):
        env.step(zero)
    t0 = time.perf_counter()
    for _ in range(n):
        _, _, term, trunc, _ = env.step(zero)
        if term or trunc:
            env.reset()
    return n / (time.perf_counter() - t0)


def _vector_rate(n: int) -> float:
    venv = gym.make_vec(ID, num_envs=N_VEC, vectorization_mode="vector_entry_point")
    action = np.zeros((N_VEC, 1), np.float32)
    venv.reset(seed=0)
    for _ in range(5):
        venv.step(action)
    t0 = time.perf_counter()
    for _ in range(n):
        venv.step(action)
    rate = N_VEC * n / (time.perf_counter() - t0)
    venv.close()
    return rate


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``)."""
    try:
        import fmpy  # noqa: F401

        from railgym.fmu.reference import export_reference_fmu
        from surrogates.fmi.export import find_compiler

        find_compiler()
    except Exception as err:  # noqa: BLE001 - no fmpy or no compiler: no FMU rows
        return [row("FMU env (skipped)", float("nan"), "", context=str(err)[:60])]
    tmp = Path(tempfile.mkdtemp(prefix="bench-fmu-"))
    try:
        fmu, mapping = export_reference_fmu(tmp / "vehicle.fmu")
        rates = {}
        for fmi_type in ("CoSimulation", "ModelExchange"):
            path = tmp / f"{fmi_type}.yaml"
            path.write_text(mapping.read_text() + f"fmi_type: {fmi_type}\n")
            env = gym.make(ID, backend="fmu", fmu=fmu, fmu_map=path)
            rates[fmi_type] = _rate(env, 400 if fmi_type == "CoSimulation" else 150)
            env.close()
        reference = _rate(gym.make(ID, backend="reference"), 4000)
        surrogate = _vector_rate(200)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    cs = rates["CoSimulation"]
    return [
        row("VerticalSuspension fmu CS (single)", cs, "steps/s", context="FMPy, 10 doStep"),
        row(
            "VerticalSuspension fmu ME (single)",
            rates["ModelExchange"],
            "steps/s",
            context="FMPy, railgym RK4",
        ),
        row("VerticalSuspension reference (single)", reference, "steps/s", context="numba"),
        row(
            f"VerticalSuspension surrogate vec ({N_VEC})",
            surrogate,
            "steps/s",
            context="numba lanes, default threads",
        ),
        row(
            "surrogate vec / fmu CS",
            surrogate / cs,
            "×",
            "≥ 50",
            "env-steps/s, same run",
        ),
    ]
