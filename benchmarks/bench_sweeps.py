"""Sweep throughput of :func:`railgym.sweeps.vertical_sweep` by backend and worker count.

The sweep: dynamic reference model, FRA classes 1-6 × 2 speed factors × 16 track seeds, 20 s
per run (192 runs). Each backend runs it once, timed including its start (process-pool spawn,
``ray.init``), and once with 1 task per worker to show that start alone; Ray also on an instance
already running (workers warm, as on a cluster joined with ``address=``). Ray rows appear where
the ``ray`` extra is installed. Every backend returns the same results (checked here too).
"""

from __future__ import annotations

import time

from railgym.parallel import ray_available, run_tasks
from railgym.sweeps import vertical_run, vertical_tasks

CONTEXT = "192 runs of 20 s, dynamic reference"


def _timed(tasks: list, workers: int, backend: str) -> tuple[float, list]:
    t0 = time.perf_counter()
    out = run_tasks(vertical_run, tasks, workers, backend=backend)
    return time.perf_counter() - t0, out


def run() -> list[dict]:
    """Rows ``{"name", "value", "unit", "target", "context"}``."""
    tasks = vertical_tasks(range(1, 7), (0.7, 1.0), n_seeds=16, root_seed=0)
    vertical_run(tasks[0])  # compile in this process
    t_serial, reference = _timed(tasks, 1, "serial")
    rows = [
        {
            "name": "sweep_serial_runs_per_s",
            "value": len(tasks) / t_serial,
            "unit": "runs/s",
            "context": CONTEXT,
        }
    ]
    backends = ["process"] + (["ray"] if ray_available() else [])
    for backend in backends:
        t_start, _ = _timed(tasks[:2], 2, backend)
        t_all, out = _timed(tasks, 2, backend)
        if out != reference:
            raise RuntimeError(f"backend {backend} changed the sweep's results")
        rows += [
            {
                "name": f"sweep_{backend}_2_workers_runs_per_s",
                "value": len(tasks) / t_all,
                "unit": "runs/s",
                "target": "2x serial",
                "context": f"{CONTEXT}, start included",
            },
            {
                "name": f"sweep_{backend}_2_workers_speedup",
                "value": t_serial / t_all,
                "unit": "x",
                "target": "2",
                "context": "serial time / parallel time",
            },
            {
                "name": f"sweep_{backend}_start_2_tasks",
                "value": t_start,
                "unit": "s",
                "context": "2 runs on 2 workers: mostly the start",
            },
        ]
    if ray_available():
        import ray

        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        try:
            _timed(tasks[:2], 2, "ray")  # workers started and kernels loaded
            t_warm, out = _timed(tasks, 2, "ray")
        finally:
            ray.shutdown()
        if out != reference:
            raise RuntimeError("backend ray changed the sweep's results")
        rows.append(
            {
                "name": "sweep_ray_2_workers_warm_runs_per_s",
                "value": len(tasks) / t_warm,
                "unit": "runs/s",
                "target": "2x serial",
                "context": f"{CONTEXT}, Ray already running (as with --address)",
            }
        )
    return rows
