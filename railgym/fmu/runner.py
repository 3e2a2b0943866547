"""Stepping an FMU as an env's reference model through FMPy.

:class:`FMURunner` instantiates the FMU of a checked :class:`~railgym.fmu.mapping.Mapping`
once and advances it by one env control step at a time (:meth:`FMURunner.advance`), in
substeps of the mapping's ``step`` (default: the env's integration step ``dt``):

* co-simulation: one ``fmi2DoStep`` per substep with the track input of the substep's start;
  when the FMU can interpolate its inputs (``canInterpolateInputs``), also their time
  derivatives of the cubic Hermite interpolant of the track samples the env's kernels use, so
  that an FMU integrating with the kernels' RK4 receives the same stage inputs;
* model exchange: FMPy's FMU2Model with railgym's fixed-step RK4 at ``step`` (the kernels'
  scheme and track interpolation), states and derivatives through the FMU.

Each control step runs in a worker thread and must finish within the mapping's ``timeout``
(wall clock), so a hanging FMU raises :class:`~railgym.fmu.mapping.FMUError` instead of
blocking the caller; a failing FMI call raises it with FMPy's message and the FMU's log.
"""

from __future__ import annotations

import ctypes
import queue
import shutil
import tempfile
import threading
import weakref
from collections.abc import Callable
from typing import Any

import numpy as np

from railgym.fmu.mapping import FMUError, Mapping

__all__ = ["FMUInstances", "FMURunner", "hermite_derivatives"]

_P_DOUBLE = ctypes.POINTER(ctypes.c_double)


def hermite_derivatives(
    za: float, zda: float, zb: float, zdb: float, h: float
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """Time derivatives (orders 1–3) at the start of a step of length ``h`` (s) of the cubic
    Hermite interpolant of displacement samples ``za, zb`` (m) with rates ``zda, zdb``
    (m/s), and of its derivative (the rate input)."""
    dz = (zb - za) / h
    c2 = (3.0 * dz - 2.0 * zda - zdb) / h
    c3 = (zda + zdb - 2.0 * dz) / (h * h)
    return (zda, 2.0 * c2, 6.0 * c3), (2.0 * c2, 6.0 * c3, 0.0)


class _Worker:
    """A daemon thread running one job at a time, waited for with a timeout."""

    def __init__(self) -> None:
        self.jobs: queue.Queue[Callable[[], Any]] = queue.Queue()
        self.results: queue.Queue[tuple[bool, Any]] = queue.Queue()
        threading.Thread(target=self._loop, daemon=True).start()

    def _loop(self) -> None:
        while True:
            job = self.jobs.get()
            try:
                self.results.put((True, job()))
            except BaseException as exc:  # handed to the caller
                self.results.put((False, exc))

    def run(self, job: Callable[[], Any], timeout: float) -> Any:
        self.jobs.put(job)
        try:
            ok, value = self.results.get(timeout=timeout)
        except queue.Empty:
            raise TimeoutError from None
        if not ok:
            raise value
        return value


class _Input:
    """The ``input`` object CVodeSolver calls (``apply(t)``) before its root function."""

    def __init__(self, apply: Callable[[float], None]) -> None:
        self.apply = apply


class FMURunner:
    """One FMU instance stepped as the reference model of an env (module docstring)."""

    def __init__(self, mapping: Mapping, dt: float, n_sub: int) -> None:
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import (
            FMU2Model,
            FMU2Slave,
            fmi2CallbackFunctions,
            fmi2CallbackLoggerTYPE,
        )
        from fmpy.logging import addLoggerProxy

        self.map = mapping
        self.dt = dt
        self.n_sub = n_sub
        step = mapping.step if mapping.step is not None else dt
        if abs(step - dt) > 1e-12 * dt:
            raise FMUError(
                "step",
                f"{mapping.source}: step = {step} s must equal the env's dt = {dt} s "
                "(the track samples); pass dt= to the env",
                full=True,
            )
        self.log: list[str] = []
        self._broken: str | None = None
        md = read_model_description(str(mapping.fmu))
        self._dir = tempfile.mkdtemp(prefix="railgym-fmu-")
        weakref.finalize(self, shutil.rmtree, self._dir, True)  # unpacked files, at the latest
        self._worker = _Worker()
        cs = mapping.fmi_type == "CoSimulation"
        unit = md.coSimulation if cs else md.modelExchange
        cls = FMU2Slave if cs else FMU2Model

        def logger(component: Any, name: Any, status: int, category: Any, message: Any) -> None:
            text = message.decode("utf-8", "replace") if isinstance(message, bytes) else message
            self.log.append(str(text))

        self._callbacks = fmi2CallbackFunctions()
        self._logger = fmi2CallbackLoggerTYPE(logger)
        self._callbacks.logger = self._logger
        addLoggerProxy(ctypes.byref(self._callbacks))

        def load() -> Any:
            extract(str(mapping.fmu), unzipdir=self._dir)
            fmu = cls(
                guid=md.guid,
                unzipDirectory=self._dir,
                modelIdentifier=unit.modelIdentifier,
                instanceName="railgym",
            )
            fmu.instantiate(callbacks=self._callbacks)
            return fmu

        self.fmu = self._call(load, "instantiate")
        self.nx = md.numberOfContinuousStates if not cs else 0
        m = mapping
        self.vr_in = [s.vr for pair in m.track for s in pair] + [s.vr for s in m.forces]
        self.in_factor = np.array(
            [1.0 / s.factor for pair in m.track for s in pair] + [1.0 / s.factor for s in m.forces]
        )
        self.out_keys = list(m.outputs)
        self.vr_out = [m.outputs[k].vr for k in self.out_keys]
        self.out_factor = np.array([m.outputs[k].factor for k in self.out_keys])
        self.time = 0.0
        self._started = False

    # ------------------------------------------------------------------ helpers
    def _call(self, job: Callable[[], Any], what: str) -> Any:
        if self._broken is not None:
            raise FMUError("fmu", self._broken, full=True)
        self.log.clear()
        try:
            return self._worker.run(job, self.map.timeout)
        except TimeoutError:
            self._broken = (
                f"{self.map.fmu}: {what} took longer than the timeout of {self.map.timeout} s "
                f"(mapping {self.map.source}, field timeout); the FMU instance is abandoned"
            )
            raise FMUError("fmu", self._broken, full=True) from None
        except FMUError:
            raise
        except Exception as exc:
            log = "; ".join(self.log[-3:])
            raise FMUError(
                "fmu",
                f"{self.map.fmu}: {what} failed: {exc}" + (f" (FMU log: {log})" if log else ""),
                full=True,
            ) from None

    def reset(self) -> dict[str, float]:
        """Start a new run at t = 0 with zero inputs; return the outputs (SI)."""

        def job() -> Any:
            f = self.fmu
            if self._started:
                f.reset()
            self._started = True
            f.setupExperiment(startTime=0.0)
            f.enterInitializationMode()
            f.setReal(self.vr_in, [0.0] * len(self.vr_in))
            f.exitInitializationMode()
            if self.map.fmi_type == "ModelExchange":
                while f.newDiscreteStates()[0]:  # (newDiscreteStatesNeeded, …)
                    pass
                f.enterContinuousTimeMode()
                if self.map.solver == "cvode":
                    self._solver = self._cvode()
            return f.getReal(self.vr_out)

        self.time = 0.0
        return self._outputs(self._call(job, "initialisation"))

    def outputs_at(self, z: np.ndarray, zdot: np.ndarray, forces: np.ndarray) -> np.ndarray:
        """Outputs (SI) at the current time with the inputs ``z, zdot`` (wheelsets,) m, m/s
        and ``forces`` (N) set."""

        def job() -> Any:
            self.fmu.setReal(self.vr_in, self._inputs(z[:, None], zdot[:, None], forces, 0))
            return self.fmu.getReal(self.vr_out)

        return np.asarray(self._call(job, "fmi2GetReal"), float) * self.out_factor

    def _outputs(self, values: Any) -> dict[str, float]:
        y = np.asarray(values, float) * self.out_factor
        return dict(zip(self.out_keys, y.tolist(), strict=True))

    def advance(
        self,
        z: np.ndarray,
        zdot: np.ndarray,
        forces: np.ndarray,
        mid: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """Advance one control step: ``z, zdot`` (wheelsets, n_sub + 1) the track samples
        of the step (m, m/s), ``forces`` the actuator forces (N), held; ``mid`` the track at
        the substeps' midpoints ((wheelsets, n_sub) each; default the cubic Hermite midpoint
        of the samples), used by model exchange. Returns the outputs (n_sub, len(out_keys))
        at the end of every substep, SI."""
        forces = np.asarray(forces, float)
        t0 = self.time
        if self.map.fmi_type == "CoSimulation":
            y = self._call(lambda: self._cs_job(z, zdot, forces, t0), "fmi2DoStep")
        else:
            job = self._cvode_job if self.map.solver == "cvode" else self._me_job
            y = self._call(lambda: job(z, zdot, forces, t0, mid), "model exchange step")
        self.time = t0 + self.n_sub * self.dt
        return y * self.out_factor

    def _inputs(self, z: np.ndarray, zd: np.ndarray, forces: np.ndarray, k: int) -> list[float]:
        u = np.empty(len(self.vr_in))
        w = z.shape[0]
        u[0 : 2 * w : 2] = z[:, k]
        u[1 : 2 * w : 2] = zd[:, k]
        u[2 * w :] = forces
        return (u * self.in_factor).tolist()

    def _cs_job(self, z: np.ndarray, zd: np.ndarray, forces: np.ndarray, t0: float) -> Any:
        f, dt, w = self.fmu, self.dt, z.shape[0]
        out = np.empty((self.n_sub, len(self.vr_out)))
        dvr = [vr for vr in self.vr_in[: 2 * w] for _ in range(3)]
        orders = [1, 2, 3] * (2 * w)
        fac = np.repeat(self.in_factor[: 2 * w], 3)
        for m in range(self.n_sub):
            f.setReal(self.vr_in, self._inputs(z, zd, forces, m))
            if self.map.interpolate:
                der = []
                for i in range(w):
                    dz, dzd = hermite_derivatives(z[i, m], zd[i, m], z[i, m + 1], zd[i, m + 1], dt)
                    der.extend((*dz, *dzd))
                f.setRealInputDerivatives(dvr, orders, (np.asarray(der) * fac).tolist())
            f.doStep(currentCommunicationPoint=t0 + m * dt, communicationStepSize=dt)
            out[m] = f.getReal(self.vr_out)
        return out

    def _me_job(
        self,
        z: np.ndarray,
        zd: np.ndarray,
        forces: np.ndarray,
        t0: float,
        mid: tuple[np.ndarray, np.ndarray] | None,
    ) -> Any:
        f, dt, nx = self.fmu, self.dt, self.nx
        out = np.empty((self.n_sub, len(self.vr_out)))
        x = self._states()
        dt8, c3, h6 = 0.125 * dt, 1.5 / dt, dt / 6.0

        def rate(t: float, xs: np.ndarray, u: list[float]) -> np.ndarray:
            f.setTime(t)
            f.setContinuousStates(np.ascontiguousarray(xs).ctypes.data_as(_P_DOUBLE), nx)
            f.setReal(self.vr_in, u)
            dx = np.empty(nx)
            f.getDerivatives(dx.ctypes.data_as(_P_DOUBLE), nx)
            return dx

        for m in range(self.n_sub):
            t = t0 + m * dt
            za, zda, zb, zdb = z[:, m], zd[:, m], z[:, m + 1], zd[:, m + 1]
            if mid is None:
                zm = 0.5 * (za + zb) + dt8 * (zda - zdb)
                zdm = c3 * (zb - za) - 0.25 * (zda + zdb)
            else:
                zm, zdm = mid[0][:, m], mid[1][:, m]
            ua = self._inputs(z, zd, forces, m)
            ub = self._inputs(z, zd, forces, m + 1)
            um = self._inputs(zm[:, None], zdm[:, None], forces, 0)
            r1 = rate(t, x, ua)
            r2 = rate(t + 0.5 * dt, x + 0.5 * dt * r1, um)
            r3 = rate(t + 0.5 * dt, x + 0.5 * dt * r2, um)
            r4 = rate(t + dt, x + dt * r3, ub)
            x = x + h6 * (r1 + 2.0 * r2 + 2.0 * r3 + r4)
            f.setTime(t + dt)
            f.setContinuousStates(np.ascontiguousarray(x).ctypes.data_as(_P_DOUBLE), nx)
            f.setReal(self.vr_in, ub)
            f.completedIntegratorStep()
            out[m] = f.getReal(self.vr_out)
        return out

    def _cvode(self) -> Any:
        """FMPy's CVode solver (BDF) on the FMU, the inputs set at each time it asks for."""
        from fmpy.sundials import CVodeSolver

        f, w = self.fmu, len(self.map.track)
        zero = (np.zeros(3), np.zeros(3))
        self._poly = (0.0, np.zeros(w), np.zeros(w), [zero] * w, np.zeros(len(self.map.forces)))
        return CVodeSolver(
            nx=self.nx,
            nz=0,
            get_x=f.getContinuousStates,
            set_x=f.setContinuousStates,
            get_dx=f.getDerivatives,
            get_z=f.getEventIndicators,
            get_nominals=f.getNominalsOfContinuousStates,
            set_time=self._set_time,
            input=_Input(self._set_time),
            startTime=0.0,
            maxStep=self.dt,
            relativeTolerance=self.map.tolerance,
            maxNumSteps=100000,
        )

    def _set_time(self, t: float) -> None:
        """CVode's callback: time ``t`` (s) and the inputs at ``t`` (the substep's cubic
        Hermite track, the held forces)."""
        t0, z0, zd0, coef, forces = self._poly
        s = t - t0
        w = len(z0)
        u = np.empty(len(self.vr_in))
        for i, (dz, dzd) in enumerate(coef):
            u[2 * i] = z0[i] + s * (dz[0] + s * (0.5 * dz[1] + s * (dz[2] / 6.0)))
            u[2 * i + 1] = zd0[i] + s * (dzd[0] + s * (0.5 * dzd[1]))
        u[2 * w :] = forces
        self.fmu.setTime(t)
        self.fmu.setReal(self.vr_in, (u * self.in_factor).tolist())

    def _cvode_job(
        self, z: np.ndarray, zd: np.ndarray, forces: np.ndarray, t0: float, mid: Any
    ) -> Any:
        f, dt = self.fmu, self.dt
        out = np.empty((self.n_sub, len(self.vr_out)))
        self._solver.reset(t0)  # the actuator force jumps here: restart the BDF history
        for m in range(self.n_sub):
            coef = [
                hermite_derivatives(z[i, m], zd[i, m], z[i, m + 1], zd[i, m + 1], dt)
                for i in range(z.shape[0])
            ]
            t = t0 + m * dt
            self._poly = (t, z[:, m], zd[:, m], coef, forces)
            self._solver.step(t, t + dt)
            f.setTime(t + dt)
            f.setReal(self.vr_in, self._inputs(z, zd, forces, m + 1))
            f.completedIntegratorStep()
            out[m] = f.getReal(self.vr_out)
        return out

    def _states(self) -> np.ndarray:
        x = np.empty(self.nx)
        self.fmu.getContinuousStates(x.ctypes.data_as(_P_DOUBLE), self.nx)
        return x

    def close(self) -> None:
        """Free the FMU instance and its unpacked files (when it is not stuck in a call)."""
        if self._broken is None and getattr(self, "fmu", None) is not None:
            try:
                self._worker.run(self._free, 5.0)
            except Exception:  # noqa: BLE001 - closing a failed FMU must not raise
                pass
        shutil.rmtree(self._dir, ignore_errors=True)

    def _free(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()


class FMUInstances:
    """Mixin of an env batch that steps one :class:`FMURunner` per vehicle (``runners``): the
    FMU instances cannot be copied, and each is reset with its vehicle."""

    runners: list[FMURunner]

    def __getstate__(self) -> dict[str, Any]:
        raise TypeError("an env with backend='fmu' cannot be copied or pickled (FMU instance)")

    def reset_state(self, i: int) -> None:
        """Vehicle ``i`` at rest, its FMU instance reset to t = 0."""
        super().reset_state(i)  # the env batch after this mixin in the MRO
        if hasattr(self, "runners"):
            self.runners[i].reset()
