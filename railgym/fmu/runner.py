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

The outputs: the runner reads the distinct FMU variables the mapping's outputs need
(``vr_read``) at the end of every substep and evaluates each output's expression on them,
vectorised over the substeps (:mod:`railgym.fmu.expression`; a plain variable is its value
times its unit factor, as read). ``der(·)`` terms are differentiated at the substep ``dt``
from those samples: 0 at the reset, first order at the first substep after it, then the
second-order backward difference ``(3y_k − 4y_{k−1} + y_{k−2})/(2·dt)``; :meth:`FMURunner.reset`
starts their history again, :meth:`FMURunner.outputs_at` re-reads the current sample.

Each control step runs in a worker thread and must finish within the mapping's ``timeout``
(wall clock), so a hanging FMU raises :class:`~railgym.fmu.mapping.FMUError` instead of
blocking the caller; a failing FMI call raises it with FMPy's message and the FMU's log.

The worker thread also loads the FMU's shared library and instantiates it, and it frees the
instance — ``fmi2Terminate`` → ``fmi2FreeInstance`` → unload the library, once each — at
:meth:`FMURunner.close` (``env.close()``, which returns once they are done), when the runner
is garbage-collected, or at interpreter exit, whichever comes first. An FMU left loaded to
the process exit runs its library destructors after the interpreter has finalised:
pythonfmu 0.7.0 FMUs instantiated from a thread then corrupt the heap (exit status 134).

Every instance of one FMU file in a process shares one unpacked folder, kept to the exit, so
that the dynamic loader maps one copy of its library (:func:`_unpacked`); an FMU that
declares ``canBeInstantiatedOnlyOncePerProcess`` gets a folder per instance.
"""

from __future__ import annotations

import contextlib
import ctypes
import itertools
import os
import queue
import shutil
import tempfile
import threading
import weakref
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from railgym.fmu.expression import Derivatives, Evaluator, compile_expression
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
    """A daemon thread running one job at a time, waited for with a timeout; ``None`` as a
    job ends the thread. ``abandoned``: a job took longer than its timeout (the thread may
    still be inside the FMU)."""

    def __init__(self) -> None:
        self.jobs: queue.Queue[Callable[[], Any] | None] = queue.Queue()
        self.results: queue.Queue[tuple[bool, Any]] = queue.Queue()
        self.abandoned = False
        self.thread = threading.Thread(target=self._loop, daemon=True, name="railgym-fmu")
        self.thread.start()

    def _loop(self) -> None:
        while True:
            job = self.jobs.get()
            if job is None:
                return
            try:
                self.results.put((True, job()))
            except BaseException as exc:  # handed to the caller
                self.results.put((False, exc))
            job = None  # the job's closure (its runner) is not kept alive while waiting

    def run(self, job: Callable[[], Any], timeout: float) -> Any:
        self.jobs.put(job)
        try:
            ok, value = self.results.get(timeout=timeout)
        except queue.Empty:
            self.abandoned = True
            raise TimeoutError from None
        if not ok:
            raise value
        return value


class _Instance:
    """What one FMU instance holds, released once and in order (:meth:`release`): FMPy's FMU
    object, the worker thread that loaded the shared library and instantiated the FMU, and the
    folder of the unpacked FMU when it owns it (:func:`_unpacked`; the callbacks live for the
    process: :func:`_callbacks`).

    It holds no reference to its :class:`FMURunner`, so that a ``weakref.finalize`` of the
    runner can release it when the runner is garbage-collected or, at the latest, at
    interpreter exit (while the interpreter and the worker thread are still alive).
    """

    def __init__(self, folder: str, own: bool) -> None:
        self.dir = folder  #: the unpacked FMU (:func:`_unpacked`)
        self.own_dir = own  #: removed at release (else shared, removed at interpreter exit)
        self.worker = _Worker()
        self.fmu: Any = None  #: FMPy's FMU2Slave / FMU2Model, once the library is loaded
        self.loaded = False  #: the shared library is loaded
        self.instantiated = False  #: fmi2Instantiate succeeded, not yet freed
        self.initialised = False  #: initialised since then (fmi2Terminate is allowed)
        self._lock = threading.Lock()
        self._released = False

    def free(self) -> None:
        """``fmi2Terminate`` (if initialised) → ``fmi2FreeInstance`` → unload the shared
        library, each at most once; on the worker thread, which made the calls before."""
        f = self.fmu
        try:
            if self.instantiated:
                self.instantiated = False
                if self.initialised:
                    self.initialised = False
                    with contextlib.suppress(Exception):  # a failed FMU may refuse to terminate
                        f.terminate()
                f.fmi2FreeInstance(f.component)
        finally:
            if self.loaded:
                self.loaded = False
                f.freeLibrary()

    def release(self, timeout: float = 10.0) -> None:
        """Free the instance and unload its library on the worker thread (waiting at most
        ``timeout`` s; not at all when a call was abandoned, then it runs if the call ever
        returns), end that thread, remove the unpacked files it owns. Runs once; never
        raises."""
        with self._lock:
            if self._released:
                return
            self._released = True
        worker = self.worker

        def job() -> None:
            with contextlib.suppress(Exception):  # releasing a failed FMU must not raise
                self.free()
            done.set()

        done = threading.Event()
        if threading.current_thread() is worker.thread:  # a finalizer run on the worker
            job()
        else:
            worker.jobs.put(job)
        worker.jobs.put(None)
        if not worker.abandoned and threading.current_thread() is not worker.thread:
            if done.wait(timeout):
                worker.thread.join(timeout)
        if self.own_dir:
            shutil.rmtree(self.dir, ignore_errors=True)


#: the folder of each FMU file unpacked by this process, by (path, size, modification time)
_UNPACKED: dict[tuple[str, int, int], str] = {}
_UNPACK_LOCK = threading.Lock()


class _Process:
    """Owner of the shared unpacked folders: never collected, so their ``weakref.finalize``
    runs at interpreter exit, after the finalizers of the instances made later."""


_PROCESS = _Process()


def _unpacked(fmu: Any, once_per_process: bool) -> tuple[str, bool]:
    """The folder the FMU file ``fmu`` is unpacked to and whether the instance owns it.

    Every instance of one FMU file shares one folder for the life of the process, so that
    the dynamic loader maps one copy of its shared library, whatever the number of
    instances open, closed and made again: each fresh copy of a pythonfmu 0.7.0 library
    binds its GNU-unique C++ symbols to the first copy's, and two live copies corrupted the heap
    (docs/fmi.md, *FMU lifetime*). An FMU that ``canBeInstantiatedOnlyOncePerProcess``
    gets a folder (and a copy of its library) of its own per instance, as the standard
    asks."""
    from fmpy import extract

    if once_per_process:
        folder = tempfile.mkdtemp(prefix="railgym-fmu-")
        extract(str(fmu), unzipdir=folder)
        return folder, True
    path = Path(fmu).resolve()
    st = path.stat()
    key = (str(path), st.st_size, st.st_mtime_ns)
    with _UNPACK_LOCK:
        folder = _UNPACKED.get(key, "")
        if not os.path.isdir(folder):
            folder = tempfile.mkdtemp(prefix="railgym-fmu-")
            extract(str(path), unzipdir=folder)
            _UNPACKED[key] = folder
            weakref.finalize(_PROCESS, shutil.rmtree, folder, True)
    return folder, False


#: the log of each live runner's instance, by instance name (:func:`_callbacks`)
_LOGS: dict[str, list[str]] = {}
_INSTANCE_IDS = itertools.count()
_CALLBACKS: list[Any] = []


def _callbacks() -> Any:
    """The FMI callbacks of every runner's instance, made once per process and never freed.

    FMPy's logger proxy (``fmpy.logging.addLoggerProxy``, which formats the variadic message)
    keeps *one* process-wide pointer to the Python logger of the callbacks it was last given,
    for every FMU of the process: a logger per runner would leave that pointer dangling once
    the runner is freed (a crash at the next message of any FMU). This one logger appends a
    message to the log of the instance that sent it (:data:`_LOGS`, by instance name) and
    hands any other instance's message to FMPy's own printer. FMI 2.0 requires the memory
    functions too: an FMU may allocate its instance with them.
    """
    if not _CALLBACKS:
        from fmpy.fmi1 import printLogMessage
        from fmpy.fmi2 import defaultCallbacks, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
        from fmpy.logging import addLoggerProxy

        def logger(component: Any, name: Any, status: int, category: Any, message: Any) -> None:
            key = name.decode("utf-8", "replace") if isinstance(name, bytes) else str(name)
            log = _LOGS.get(key)
            if log is None:
                printLogMessage(component, name, status, category, message)
                return
            text = message.decode("utf-8", "replace") if isinstance(message, bytes) else message
            log.append(str(text))

        callbacks = fmi2CallbackFunctions()
        proxy = fmi2CallbackLoggerTYPE(logger)
        callbacks.logger = proxy
        callbacks.allocateMemory = defaultCallbacks.allocateMemory
        callbacks.freeMemory = defaultCallbacks.freeMemory
        addLoggerProxy(ctypes.byref(callbacks))
        _CALLBACKS.extend((callbacks, proxy))
    return _CALLBACKS[0]


class _Input:
    """The ``input`` object CVodeSolver calls (``apply(t)``) before its root function."""

    def __init__(self, apply: Callable[[float], None]) -> None:
        self.apply = apply


class FMURunner:
    """One FMU instance stepped as the reference model of an env (module docstring)."""

    def __init__(self, mapping: Mapping, dt: float, n_sub: int) -> None:
        from fmpy import read_model_description
        from fmpy.fmi2 import FMU2Model, FMU2Slave

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
        cs = mapping.fmi_type == "CoSimulation"
        unit = md.coSimulation if cs else md.modelExchange
        cls = FMU2Slave if cs else FMU2Model
        # the instance's lifetime: released by close(), when the runner is collected, or at
        # interpreter exit, whichever comes first (weakref.finalize runs it once)
        inst = self._inst = _Instance(
            *_unpacked(mapping.fmu, unit.canBeInstantiatedOnlyOncePerProcess)
        )
        self._release = weakref.finalize(self, inst.release)
        self._dir = inst.dir
        self._worker = inst.worker
        name = f"railgym-{next(_INSTANCE_IDS)}"
        _LOGS[name] = self.log  # the list, not self: the logger must not keep the runner alive
        weakref.finalize(self, _LOGS.pop, name, None)

        def load() -> Any:  # on the worker thread, which also frees the instance
            fmu = cls(
                guid=md.guid,
                unzipDirectory=inst.dir,
                modelIdentifier=unit.modelIdentifier,
                instanceName=name,
            )
            inst.fmu, inst.loaded = fmu, True
            fmu.instantiate(callbacks=_callbacks())
            inst.instantiated = True
            return fmu

        self.fmu = self._call(load, "instantiate")
        self.nx = md.numberOfContinuousStates if not cs else 0
        m = mapping
        self.vr_in = [s.vr for pair in m.track for s in pair] + [s.vr for s in m.forces]
        self.in_factor = np.array(
            [1.0 / s.factor for pair in m.track for s in pair] + [1.0 / s.factor for s in m.forces]
        )
        self.out_keys = list(m.outputs)
        #: value references of the distinct FMU variables the outputs read
        self.vr_read = list(dict.fromkeys(s.vr for o in m.outputs.values() for s in o.signals))
        col = {vr: j for j, vr in enumerate(self.vr_read)}
        self._programs: list[tuple[Evaluator, float]] = []
        n_der = 0
        for key in self.out_keys:
            out = m.outputs[key]
            columns = {s.name: col[s.vr] for s in out.signals}
            factors = {s.name: s.factor for s in out.signals}
            self._programs.append(
                (compile_expression(out.expr, columns, factors, n_der), out.factor)
            )
            n_der += out.expr.n_der
        self._ders = Derivatives(n_der, dt)
        self.time = 0.0
        self._started = False

    # ------------------------------------------------------------------ helpers
    def _call(self, job: Callable[[], Any], what: str) -> Any:
        if self._broken is None and not self._release.alive:  # released at interpreter exit
            self._broken = f"{self.map.fmu}: the FMU instance is closed"
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
            return f.getReal(self.vr_read)

        self.time = 0.0
        self._ders.reset()
        y = self._evaluate(self._call(job, "initialisation"), replace=False)[0]
        return dict(zip(self.out_keys, y.tolist(), strict=True))

    def outputs_at(self, z: np.ndarray, zdot: np.ndarray, forces: np.ndarray) -> np.ndarray:
        """Outputs (SI) at the current time with the inputs ``z, zdot`` (wheelsets,) m, m/s
        and ``forces`` (N) set."""

        def job() -> Any:
            self.fmu.setReal(self.vr_in, self._inputs(z[:, None], zdot[:, None], forces, 0))
            return self.fmu.getReal(self.vr_read)

        return self._evaluate(self._call(job, "fmi2GetReal"), replace=True)[0]

    def _evaluate(self, values: Any, replace: bool) -> np.ndarray:
        """The outputs (n, len(out_keys)), SI, of the read variables ``values`` (n samples,
        or one); ``replace``: the first sample is the current time's again (``der``)."""
        raw = np.asarray(values, float)
        if raw.ndim == 1:
            raw = raw[None, :]
        self._ders.replace = replace
        y = np.empty((raw.shape[0], len(self._programs)))
        for j, (program, scale) in enumerate(self._programs):
            v = program(raw, self._ders)
            y[:, j] = v if scale == 1.0 else v * scale
        return y

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
        return self._evaluate(y, replace=False)

    def _inputs(self, z: np.ndarray, zd: np.ndarray, forces: np.ndarray, k: int) -> list[float]:
        u = np.empty(len(self.vr_in))
        w = z.shape[0]
        u[0 : 2 * w : 2] = z[:, k]
        u[1 : 2 * w : 2] = zd[:, k]
        u[2 * w :] = forces
        return (u * self.in_factor).tolist()

    def _cs_job(self, z: np.ndarray, zd: np.ndarray, forces: np.ndarray, t0: float) -> Any:
        f, dt, w = self.fmu, self.dt, z.shape[0]
        out = np.empty((self.n_sub, len(self.vr_read)))
        dvr = [vr for vr in self.vr_in[: 2 * w] for _ in range(3)]
        orders = [1, 2, 3] * (2 * w)
        fac = np.repeat(self.in_factor[: 2 * w], 3)
        for m in range(self.n_sub):
            f.setReal(self.vr_in, self._inputs(z, zd, forces, m))
            if self.map.interpolate:
                der: list[float] = []
                for i in range(w):
                    dz, dzd = hermite_derivatives(z[i, m], zd[i, m], z[i, m + 1], zd[i, m + 1], dt)
                    der.extend((*dz, *dzd))
                f.setRealInputDerivatives(dvr, orders, (np.asarray(der) * fac).tolist())
            f.doStep(currentCommunicationPoint=t0 + m * dt, communicationStepSize=dt)
            out[m] = f.getReal(self.vr_read)
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
        out = np.empty((self.n_sub, len(self.vr_read)))
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
            out[m] = f.getReal(self.vr_read)
        return out

    def _cvode(self) -> Any:
        """FMPy's CVode solver (BDF) on the FMU, the inputs set at each time it asks for."""
        from fmpy.sundials import CVodeSolver

        f, w = self.fmu, len(self.map.track)
        zero = (np.zeros(3), np.zeros(3))
        self._poly: tuple[Any, ...] = (
            0.0,
            np.zeros(w),
            np.zeros(w),
            [zero] * w,
            np.zeros(len(self.map.forces)),
        )
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
        out = np.empty((self.n_sub, len(self.vr_read)))
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
            out[m] = f.getReal(self.vr_read)
        return out

    def _states(self) -> np.ndarray:
        x = np.empty(self.nx)
        self.fmu.getContinuousStates(x.ctypes.data_as(_P_DOUBLE), self.nx)
        return x

    @property
    def _started(self) -> bool:
        """The instance has been initialised (by :meth:`reset`) since it was instantiated."""
        return self._inst.initialised

    @_started.setter
    def _started(self, value: bool) -> None:
        self._inst.initialised = value

    def close(self) -> None:
        """Free the FMU instance: ``fmi2Terminate``, ``fmi2FreeInstance``, unload its shared
        library (on the thread that loaded it; skipped when a call is stuck in the FMU), end
        that thread (the unpacked files of the FMU stay for its next instance, to the
        interpreter exit: :func:`_unpacked`). Idempotent; later calls raise
        :class:`~railgym.fmu.mapping.FMUError`. Also done when the runner is garbage-collected
        and at interpreter exit, for runners not closed."""
        if self._broken is None:
            self._broken = f"{self.map.fmu}: the FMU instance is closed"
        self._release()


class FMUInstances:
    """Mixin of an env batch that steps one :class:`FMURunner` per vehicle (``runners``): the
    FMU instances cannot be copied, and each is reset with its vehicle."""

    runners: list[FMURunner]

    def __getstate__(self) -> dict[str, Any]:
        raise TypeError("an env with backend='fmu' cannot be copied or pickled (FMU instance)")

    def reset_state(self, i: int) -> None:
        """Vehicle ``i`` at rest, its FMU instance reset to t = 0."""
        super().reset_state(i)  # type: ignore[misc]  # the env batch after this mixin in the MRO
        if hasattr(self, "runners"):
            self.runners[i].reset()
