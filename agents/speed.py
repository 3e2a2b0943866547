"""What the surrogate element costs against the model it replaces, measured in one run
(the speed table of ``railgym demo``).

Env-steps per second of ``VerticalSuspension-v1`` as native vector envs: the surrogate backend
with the given element and the reference backend (the numba model the element replaces), each
``n_envs`` sub-envs, and the FMU-in-the-loop env of the same vehicle (the reference exported by
:func:`railgym.fmu.reference.export_reference_fmu` into a temporary folder, ``backend="fmu"``
through FMPy, :data:`FMU_ENVS` sub-envs: one FMU instance per sub-env, stepped one after another,
so its rate does not grow with the sub-envs). Every env takes one step before the timing (the
kernels compile or load from the cache); then ``rounds`` interleaved rounds time ``n_steps``
steps of each env in turn, on one numba thread (a per-core cost: the reference kernel runs one
sub-env after another on any number of threads). Each figure is the median over the rounds; the
ratios are medians of the per-round ratios.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path
from typing import Any, NamedTuple

import numba
import numpy as np

from railgym.envs.vertical import VerticalSuspensionVectorEnv

__all__ = ["FMU_ENVS", "SpeedRow", "backend_speeds", "format_speeds"]

#: sub-envs of the FMU-in-the-loop env
FMU_ENVS = 16


class SpeedRow(NamedTuple):
    """One row of the speed table."""

    model: str  #: what was stepped
    n_envs: int  #: sub-envs of the vector env
    n_steps: int  #: steps of all sub-envs per round
    steps_per_s: float  #: env-steps per second, median over the rounds
    vs_reference: float  #: its env-steps/s over the reference's, median of per-round ratios
    surrogate_over: float  #: the surrogate's env-steps/s over its, median of per-round ratios


class _Timed:
    """A vector env stepped with zero actions; ``seconds``: the wall time of each round."""

    def __init__(self, model: str, venv: VerticalSuspensionVectorEnv, n_steps: int) -> None:
        self.model, self.venv, self.n_steps = model, venv, n_steps
        self.action = np.zeros((venv.num_envs, 1), np.float32)
        self.seconds: list[float] = []
        venv.reset(seed=0)
        venv.step(self.action)  # compile or load the kernel outside the timing

    def round(self) -> None:
        venv, action = self.venv, self.action
        t0 = time.perf_counter()
        for _ in range(self.n_steps):
            venv.step(action)
        self.seconds.append(time.perf_counter() - t0)

    def rates(self) -> np.ndarray:
        return self.venv.num_envs * self.n_steps / np.array(self.seconds)


def fmu_unavailable() -> str | None:
    """Why the FMU row cannot be measured (``None`` when it can): FMPy (the ``fmi`` extra)
    or a C compiler missing."""
    try:
        import fmpy  # noqa: F401
    except ImportError:
        return "FMPy is not installed (pip install 'railgym[fmi]')"
    from surrogates.fmi.export import FMUExportError, find_compiler

    try:
        find_compiler()
    except FMUExportError:
        return "no C compiler to build the FMU (install gcc or set CC)"
    return None


def backend_speeds(
    surrogate: Any,
    n_envs: int = 256,
    n_steps: int = 200,
    rounds: int = 3,
    fmu_steps: int = 20,
) -> tuple[list[SpeedRow], str | None]:
    """The speed table's rows (surrogate, reference, then the FMU if it can be built) and the
    note of a skipped FMU row (``None`` if measured); see the module docstring. ``fmu_steps``:
    steps of the FMU env per round (it is about a hundred times slower)."""
    skipped = fmu_unavailable()
    threads = numba.get_num_threads()
    tmp = Path(tempfile.mkdtemp(prefix="railgym-speed-"))
    timed: list[_Timed] = []
    numba.set_num_threads(1)
    try:
        for label, kwargs in (
            ("surrogate", {"backend": "surrogate", "surrogate": surrogate}),
            ("reference", {"backend": "reference"}),
        ):
            venv = VerticalSuspensionVectorEnv(num_envs=n_envs, **kwargs)
            timed.append(_Timed(label, venv, n_steps))
        if skipped is None:
            from railgym.fmu.reference import export_reference_fmu

            fmu, mapping = export_reference_fmu(tmp / "reference.fmu")
            venv = VerticalSuspensionVectorEnv(
                num_envs=min(FMU_ENVS, n_envs), backend="fmu", fmu=fmu, fmu_map=mapping
            )
            timed.append(_Timed("reference FMU", venv, fmu_steps))
        for _ in range(rounds):
            for t in timed:
                t.round()
    finally:
        numba.set_num_threads(threads)
        for t in timed:
            t.venv.close()
        shutil.rmtree(tmp, ignore_errors=True)
    sur, ref = timed[0].rates(), timed[1].rates()
    rows = [
        SpeedRow(
            t.model,
            t.venv.num_envs,
            t.n_steps,
            float(np.median(t.rates())),
            float(np.median(t.rates() / ref)),
            float(np.median(sur / t.rates())),
        )
        for t in timed
    ]
    return rows, skipped


#: what each row stepped, as printed
_WHAT = {
    "surrogate": "surrogate (numba)",
    "reference": "reference (numba)",
    "reference FMU": "reference FMU (FMPy)",
}


def format_speeds(rows: list[SpeedRow], skipped: str | None, rounds: int) -> str:
    """The table printed by ``railgym demo``: a line saying what was measured, one line per
    row (sub-envs, steps per round, env-steps/s, ratio to the reference) and a summary."""
    by = {r.model: r for r in rows}
    fmu = by.get("reference FMU")
    per_round = f"{by['surrogate'].n_steps} steps per round" + (
        f" ({fmu.n_steps} of the FMU)" if fmu is not None else ""
    )
    lines = [
        f"VerticalSuspension-v1 as native vector envs, measured now: {per_round}, median of "
        f"{rounds} interleaved rounds, 1 numba thread, kernels compiled before timing",
        "surrogate: the element fitted above; reference: the model it replaces; FMU: that "
        "model exported to C (FMI 2.0), stepped through FMPy",
        f"{'model':<32} {'sub-envs':>8} {'steps':>6} {'env-steps/s':>12} {'× reference':>12}",
    ]
    for r in rows:
        lines.append(
            f"{_WHAT.get(r.model, r.model):<32} {r.n_envs:8d} {r.n_steps:6d} "
            f"{r.steps_per_s:12.4g} {r.vs_reference:12.3g}"
        )
    if skipped is not None:
        lines.append(f"reference FMU: not measured: {skipped}")
    summary = f"the surrogate steps {by['surrogate'].vs_reference:.3g} × as fast as the reference"
    if fmu is not None:
        summary += f" and {fmu.surrogate_over:.3g} × as fast as the reference FMU in the loop"
    lines.append(summary + " (this machine, this run)")
    return "\n".join(lines)
