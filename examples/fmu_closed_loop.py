"""The engineer's loop, FMPy as master: a controller FMU drives a vehicle FMU.

A trained policy exported by ``railgym export-policy`` (the controller) and the vertical
reference model exported by ``railgym export-reference-fmu`` (standing in for the user's
Simpack / Simulink / Modelica model) are both FMI 2.0 co-simulation slaves; this master
connects them by name (the vehicle's outputs ``carbody_acc, bogie_acc, deflection,
deflection_rate, carbody_vel`` are the controller's inputs, the controller's
``actuator_force`` the vehicle's input) and steps them as the env does:

1. every control step (``control_dt``): read the vehicle's outputs, set them as the
   controller's inputs, read the controller's force (direct feedthrough) and ``fmi2DoStep``
   the controller;
2. hold the force over the control step while the vehicle advances in communication steps
   of ``dt`` with the track samples ``z, ż``; with ``interpolate=True`` the master also passes
   the time derivatives of the track's cubic Hermite interpolant
   (``fmi2SetRealInputDerivatives``, the vehicle FMU has ``canInterpolateInputs``), else it
   holds the track over each ``dt`` (a plain master).

:func:`env_episode` runs the same policy on ``VerticalSuspension-v1`` with
``backend="reference"`` and gives the track it rode, so the two can be compared. Run
``python examples/fmu_closed_loop.py POLICY.zip`` for the table of ``docs/fmi.md``.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the envs)
from railgym.fmu.runner import hermite_derivatives

ID = "railgym/VerticalSuspension-v1"


class _Slave:
    """An FMU2Slave with its variables by name."""

    def __init__(self, path: str | Path, name: str) -> None:
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.inputs = [v.name for v in md.modelVariables if v.causality == "input"]
        self.dir = extract(str(path), unzipdir=tempfile.mkdtemp(prefix="fmu-loop-"))
        self.fmu = FMU2Slave(
            guid=md.guid,
            unzipDirectory=self.dir,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=name,
        )
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def get(self, names: list[str]) -> list[float]:
        return self.fmu.getReal([self.vr[n] for n in names])

    def set(self, names: list[str], values: list[float]) -> None:
        self.fmu.setReal([self.vr[n] for n in names], values)

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def closed_loop(
    vehicle_fmu: str | Path,
    controller_fmu: str | Path,
    z: np.ndarray,
    zdot: np.ndarray,
    dt: float,
    n_sub: int,
    interpolate: bool = True,
) -> dict[str, np.ndarray]:
    """Co-simulate the controller FMU with the vehicle FMU over the track ``z, zdot`` (m, m/s
    on ``k·dt``); ``n_sub`` vehicle steps of ``dt`` (s) per control step.

    Returns ``carbody_acc`` (m/s²) at the end of every control step and the ``force`` (N)
    applied over it.
    """
    vehicle, ctrl = _Slave(vehicle_fmu, "vehicle"), _Slave(controller_fmu, "controller")
    try:
        n_steps = (z.size - 1) // n_sub
        acc, force = np.zeros(n_steps), np.zeros(n_steps)
        zd_vr = [vehicle.vr["z"]] * 3 + [vehicle.vr["zdot"]] * 3
        for n in range(n_steps):
            ctrl.set(ctrl.inputs, vehicle.get(ctrl.inputs))
            (f,) = ctrl.get(["actuator_force"])
            ctrl.fmu.doStep(
                currentCommunicationPoint=n * n_sub * dt, communicationStepSize=n_sub * dt
            )
            for m in range(n * n_sub, (n + 1) * n_sub):
                vehicle.set(["z", "zdot", "actuator_force"], [z[m], zdot[m], f])
                if interpolate:
                    dz, dzd = hermite_derivatives(z[m], zdot[m], z[m + 1], zdot[m + 1], dt)
                    vehicle.fmu.setRealInputDerivatives(zd_vr, [1, 2, 3] * 2, [*dz, *dzd])
                vehicle.fmu.doStep(currentCommunicationPoint=m * dt, communicationStepSize=dt)
            acc[n], force[n] = vehicle.get(["carbody_acc"])[0], f
        return {"carbody_acc": acc, "force": force}
    finally:
        vehicle.close()
        ctrl.close()


def env_episode(policy: Any, seed: int = 0, **env_kwargs: Any) -> dict[str, Any]:
    """One ``backend="reference"`` episode of ``policy`` (:func:`run_episode`)."""
    return run_episode(gym.make(ID, backend="reference", **env_kwargs), policy, seed)


def run_episode(env: gym.Env, policy: Any, seed: int = 0) -> dict[str, Any]:
    """One episode of ``policy`` (an object with SB3's ``predict``) in the vertical ``env``
    from ``reset(seed=seed)``, then ``env`` is closed: ``carbody_acc`` (m/s²) and ``force`` (N)
    per step, the track ``z, zdot`` and the env's ``dt``, ``n_sub``."""
    obs, _ = env.reset(seed=seed)
    base: Any = env.unwrapped
    z, zdot = base.track()
    acc, force = [], []
    while True:
        action, _ = policy.predict(obs, deterministic=True)
        obs, _, term, trunc, info = env.step(np.asarray(action, np.float32))
        acc.append(info["carbody_acc"])
        force.append(info["actuator_force"])
        if term or trunc:
            break
    env.close()
    return {
        "carbody_acc": np.array(acc),
        "force": np.array(force),
        "z": z,
        "zdot": zdot,
        "dt": base.cfg.dt,
        "n_sub": base.cfg.n_sub,
    }


def rms_difference(a: np.ndarray, ref: np.ndarray) -> float:
    """RMS of ``a − ref`` relative to the RMS of ``ref``."""
    return float(np.sqrt(np.mean((a - ref) ** 2)) / np.sqrt(np.mean(ref**2)))


def main(argv: list[str]) -> int:
    """``python examples/fmu_closed_loop.py POLICY.zip``: export both FMUs, co-simulate."""
    from agents.policies.loading import load_policy
    from agents.policies.policy_fmu import export_policy
    from railgym.fmu.reference import export_reference_fmu

    if len(argv) != 1:
        print(__doc__.split("\n\n")[0] + "\nusage: fmu_closed_loop.py POLICY.zip")
        return 2
    factory, env_kwargs, label = load_policy(argv[0], ID)
    with tempfile.TemporaryDirectory() as tmp:
        vehicle, _ = export_reference_fmu(Path(tmp) / "vehicle.fmu", kind="cs")
        controller, _ = export_policy(argv[0], Path(tmp) / "controller.fmu")
        ep = env_episode(factory(None), seed=0, **env_kwargs)
        args = (vehicle, controller, ep["z"], ep["zdot"], ep["dt"], ep["n_sub"])
        print(f"policy {label}: controller FMU + vehicle FMU vs the env's reference episode")
        for interp in (True, False):
            co = closed_loop(*args, interpolate=interp)
            err = rms_difference(co["carbody_acc"], ep["carbody_acc"])
            print(
                f"  track input {'Hermite' if interp else 'held'}: RMS carbody acc "
                f"difference {100 * err:.2g} %"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
