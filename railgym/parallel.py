"""Run independent tasks serially, on a local process pool, or as Ray tasks.

:func:`run_tasks` maps a function over a list of tasks and returns the results in task order:

==============================  ===========================================================
``workers=1``                   in this process, one task after the other
``workers=N`` (no Ray)          ``concurrent.futures.ProcessPoolExecutor`` with N processes
``workers=N`` (extra ``ray``)   a local Ray instance, ``ray.init(num_cpus=N)``
``address="HOST:PORT"``         joins an existing Ray cluster, ``ray.init(address=...)``;
                                the cluster's CPUs decide the parallelism
==============================  ===========================================================

``backend=`` forces one of ``"serial"``, ``"process"``, ``"ray"``. Every task carries its own
seed (:func:`spawn_seeds` derives them from one root seed), so the results do not depend on the
number of workers nor on which worker ran a task. For the process pool and Ray, ``fn`` must be
importable by name (a module-level function) and tasks and results picklable. Ray is imported
only when it is used.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from importlib.util import find_spec
from typing import TypeVar

import numpy as np

from railgym import _checks as val
from railgym.progress import bar

T = TypeVar("T")
R = TypeVar("R")

BACKENDS = ("serial", "process", "ray")
RAY_HINT = "pip install 'railgym[ray]'"


def spawn_seeds(root_seed: int, n: int) -> list[int]:
    """``n`` independent 64-bit seeds from one root seed (``numpy.random.SeedSequence.spawn``).

    Seed ``i`` depends only on ``root_seed`` and ``i``: extending a sweep keeps the seeds of
    its first tasks.
    """
    root_seed = val.integer(root_seed, "root_seed", min=0)
    n = val.integer(n, "n", min=0)
    children = np.random.SeedSequence(root_seed).spawn(n)
    return [int(c.generate_state(1, np.uint64)[0]) for c in children]


def ray_available() -> bool:
    """Whether the optional ``ray`` package is installed (a module, not a bare folder named
    ``ray`` on the path, such as Ray's own session folder in the working directory)."""
    spec = find_spec("ray")
    return spec is not None and spec.origin is not None


def choose_backend(workers: int = 1, address: str | None = None, backend: str | None = None) -> str:
    """The backend :func:`run_tasks` uses for these arguments (see the module docstring)."""
    workers = val.integer(workers, "workers", min=1)
    if address is not None and (not isinstance(address, str) or not address):
        raise ValueError(f"address must be a Ray cluster address 'HOST:PORT', got {address!r}")
    if backend is not None:
        backend = val.choice(backend, "backend", BACKENDS)
    if address is not None:
        if backend not in (None, "ray"):
            raise ValueError(f"address={address!r} joins a Ray cluster: backend must be 'ray'")
        backend = "ray"
    elif backend is None:
        backend = "serial" if workers == 1 else "ray" if ray_available() else "process"
    if backend == "ray" and not ray_available():
        what = f"address={address!r}" if address is not None else "backend='ray'"
        raise ValueError(f"{what} needs Ray, which is not installed: {RAY_HINT}")
    return backend


def _run_ray(fn: Callable[[T], R], tasks: Sequence[T], workers: int, address: str | None) -> list:
    import ray

    started = not ray.is_initialized()
    if started:
        if address is None:
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, log_to_driver=False)
    try:
        remote = ray.remote(num_cpus=1)(fn)
        return list(ray.get([remote.remote(t) for t in tasks]))
    finally:
        if started:
            ray.shutdown()


def run_tasks(
    fn: Callable[[T], R],
    tasks: Sequence[T],
    workers: int = 1,
    address: str | None = None,
    backend: str | None = None,
    desc: str = "tasks",
) -> list[R]:
    """``[fn(t) for t in tasks]``, computed by the backend :func:`choose_backend` picks, with
    a progress bar ``desc`` over the finished tasks (:func:`railgym.progress.bar`).

    Parameters
    ----------
    fn : function of one task; module-level for the process pool and Ray.
    tasks : the tasks, each with its own seed where ``fn`` draws random numbers.
    workers : processes of the local pool or CPUs of the local Ray instance (>= 1).
    address : Ray cluster to join (``"HOST:PORT"`` or ``"auto"``); needs the ``ray`` extra.
    backend : ``"serial"``, ``"process"`` or ``"ray"`` (default: chosen from the above).

    Returns
    -------
    list of the results in task order. The first exception raised by a task is raised here.
    """
    tasks = list(tasks)
    backend = choose_backend(workers, address, backend)
    if backend == "serial" or not tasks:
        return list(bar(map(fn, tasks), desc=desc, total=len(tasks)))
    if backend == "ray":
        return _run_ray(fn, tasks, workers, address)
    # spawn: workers start clean (no forked threads); numba kernels come from its disk cache
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(min(workers, len(tasks)), mp_context=ctx) as pool:
        return list(bar(pool.map(fn, tasks), desc=desc, total=len(tasks)))


__all__ = ["BACKENDS", "choose_backend", "ray_available", "run_tasks", "spawn_seeds"]
