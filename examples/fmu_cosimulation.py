"""Co-simulation of an exported surrogate FMU with railgym's vertical vehicle model, FMPy as master.

The paper runs its surrogate element inside Simpack/Simulink by co-simulation. Here FMPy hosts
the exported element (``surrogates export-fmu``) as an FMI 2.0 co-simulation slave, and the
bogie + carbody of :mod:`railgym.vehicles.vertical` is the other subsystem, integrated by
railgym's own RK4 kernel (:func:`~railgym.vehicles.vertical.kernels.advance_linear` with the linear
secondary suspension switched off, ``k2 = c2 = 0``, so that the FMU's force enters as the
force between bogie and carbody). Explicit (Jacobi) coupling with zero-order hold, at every
communication point ``t_n = n·H``:

1. ``fmi2DoStep(t_{n−1}, H)`` brings the slave to ``t_n``;
2. the master sets the FMU inputs ``δ = x1 − x2`` and ``δ̇ = ẋ1 − ẋ2`` from the vehicle
   state and reads the element force ``F_n`` (``fmi2SetReal``, ``fmi2GetReal``);
3. the vehicle advances over ``[t_n, t_n + H]`` by ``H / dt`` RK4 steps with ``F_n`` held.

The native embedded simulation (``simulate("surrogate", ...)``) evaluates the element at every
RK4 stage instead; the difference is the coupling error of the zero-order hold, first order in
``H``. Run ``python examples/fmu_cosimulation.py`` for the table of ``docs/fmi.md``.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from railgym.track import track_time_input
from railgym.vehicles.vertical.kernels import advance_linear, step_outputs, surrogate_arrays
from railgym.vehicles.vertical.params import VerticalVehicle, load_vehicle
from railgym.vehicles.vertical.simulate import simulate


def cosimulate(
    fmu_path: str | Path,
    vehicle: VerticalVehicle,
    z: np.ndarray,
    zdot: np.ndarray,
    dt: float,
    every: int,
) -> dict[str, np.ndarray]:
    """Run the vehicle coupled with the FMU slave at the communication step ``H = every·dt``.

    Parameters
    ----------
    fmu_path : exported element with inputs ``(δ, δ̇)`` (m, m/s) and the force output (N).
    vehicle : the vertical vehicle (read only).
    z, zdot : track displacement (m) and velocity (m/s) on ``t_k = k·dt``, (N+1,), with
        ``N`` a multiple of ``every``.
    dt : RK4 step of the vehicle, s. every : RK4 steps per communication step.

    Returns
    -------
    ``t`` (s), ``x2`` (m), ``a2 = F/m2`` (m/s²) and ``F`` (N) at the communication points.
    """
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu_path))
    ins = sorted(
        (v for v in md.modelVariables if v.causality == "input"), key=lambda v: v.valueReference
    )
    (out,) = [v for v in md.modelVariables if v.causality == "output"]
    vr_in = [v.valueReference for v in ins]
    unzipped = extract(str(fmu_path), unzipdir=tempfile.mkdtemp(prefix="fmu-cosim-"))
    slave = FMU2Slave(
        guid=md.guid,
        unzipDirectory=unzipped,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="element",
    )
    p = vehicle.kernel_params()._replace(k2=0.0, c2=0.0).record()  # the FMU is the suspension
    lpr = surrogate_arrays(None)
    n_comm = (z.size - 1) // every
    H = every * dt
    state = np.zeros((1, 4))
    zz, zd = z[None, :], zdot[None, :]
    res = step_outputs(1)
    t, x2, F = np.arange(n_comm + 1) * H, np.zeros(n_comm + 1), np.zeros(n_comm + 1)
    try:
        slave.instantiate()
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        for n in range(n_comm + 1):
            if n > 0:
                slave.doStep(currentCommunicationPoint=(n - 1) * H, communicationStepSize=H)
            x = state[0]
            slave.setReal(vr_in, [x[0] - x[2], x[1] - x[3]])
            F[n] = slave.getReal([out.valueReference])[0]
            x2[n] = x[2]
            if n == n_comm:
                break
            k0 = np.array([n * every], np.int64)
            advance_linear(state, zz, zd, k0, every, dt, F[n : n + 1], p, lpr, res)
            if res.div[0]:
                raise RuntimeError(f"the co-simulation diverged at t = {(n + 1) * H} s")
        slave.terminate()
    finally:
        slave.freeInstance()
        shutil.rmtree(unzipped, ignore_errors=True)
    return {"t": t, "x2": x2, "a2": F / vehicle.m2, "F": F}


def coupling_errors(
    fmu_path: str | Path,
    model: Any,
    steps: tuple[int, ...] = (16, 8, 4, 2, 1),
    track_class: int = 5,
    speed: float = 40.0,
    duration: float = 4.0,
    dt: float = 1e-3,
    seed: int = 1,
) -> list[dict[str, float]]:
    """Co-simulation against the native embedded run, one row per communication step.

    Each row: ``H`` (s), ``x2`` and ``a2`` — the RMS difference of the carbody displacement (m)
    and acceleration (m/s²) at the common sample times ``k·max(steps)·dt``, relative to the
    native signal's RMS.
    """
    vehicle = load_vehicle("manchester")
    _, z, zdot = track_time_input(track_class, speed, duration, dt, seed)
    native = simulate("surrogate", vehicle, z, zdot, dt, surrogate=model)
    coarse = max(steps)
    rows = []
    for every in steps:
        co = cosimulate(fmu_path, vehicle, z, zdot, dt, every)
        k = coarse // every
        row = {"H": every * dt}
        for name in ("x2", "a2"):
            ref = native[name][::coarse][: co[name][::k].size]
            diff = co[name][::k] - ref
            row[name] = float(np.sqrt(np.mean(diff**2)) / np.sqrt(np.mean(ref**2)))
        rows.append(row)
    return rows


def main() -> int:
    """Export the packaged vertical element, co-simulate it and print the convergence table."""
    from railgym.vehicles.collect import default_vertical_surrogate
    from surrogates.fmi import export_fmu

    model = default_vertical_surrogate("static")  # the exported element is memoryless
    with tempfile.TemporaryDirectory() as tmp:
        fmu = export_fmu(model, Path(tmp) / "vertical_element.fmu", kind="cs")
        rows = coupling_errors(fmu, model)
    print("H (ms)   rel. RMS error x2   rel. RMS error a2   a2 error ratio to 2H")
    for i, r in enumerate(rows):
        ratio = rows[i - 1]["a2"] / r["a2"] if i else float("nan")
        print(f"{r['H'] * 1e3:6.1f}   {r['x2']:17.3e}   {r['a2']:17.3e}   {ratio:8.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
