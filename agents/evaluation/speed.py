"""What the surrogate element costs against the model it replaces, measured in one run
(the speed table of ``railgym demo``).

Env-steps per second of :data:`ENV_ID` on the surrogate backend with the given
element and on the reference backend (the numba model the element replaces), each as a native
vector env of ``n_envs`` sub-envs (one kernel call per step) and as a single env (whole
steps, Python shell included); and the FMU-in-the-loop env of the same vehicle (the reference
exported by :func:`railgym.fmu.reference.export_reference_fmu` into a temporary folder,
``backend="fmu"`` through FMPy, a vector env of :data:`FMU_ENVS` sub-envs: one FMU instance per
sub-env, stepped one after another). Every env takes one step before the timing (the kernels
compile or load from the cache); then ``rounds`` interleaved rounds time a block of steps of
each env in turn, on one numba thread (a per-core cost); a single env is reset outside the
timing before a block that would end its episode. Each figure is the median over the rounds;
the ratios are medians of the per-round ratios, each against the env of the same mode.
:func:`format_speeds` leads with the comparison the paper makes, the surrogate against the FMU in
the loop, then the internal reference beside it (the FMU env takes its track from Python: the
streamed track is the numba envs').
"""

from __future__ import annotations

import importlib
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any, NamedTuple

import numba
import numpy as np

from railgym.envs.vertical.env import (
    VerticalSuspensionEnv,
    VerticalSuspensionEnvV3,
    VerticalSuspensionVectorEnv,
    VerticalSuspensionVectorEnvV3,
)

__all__ = [
    "COMPARISONS",
    "ENV_ID",
    "FMU_ENVS",
    "MODES",
    "SpeedRow",
    "backend_speeds",
    "fmu_unavailable",
    "format_speeds",
]

#: the env every row steps (its newest version)
ENV_ID = "railgym/VerticalSuspension-v3"
#: sub-envs of the FMU-in-the-loop env
FMU_ENVS = 16
#: how the envs are stepped: native vector envs, single envs
MODES = ("vector", "single")


class SpeedRow(NamedTuple):
    """One row of the speed table."""

    model: str  #: what was stepped
    n_envs: int  #: sub-envs of the vector env (1: a single env)
    n_steps: int  #: steps of all sub-envs per round
    steps_per_s: float  #: env-steps per second, median over the rounds
    vs_reference: float  #: its env-steps/s over the reference's, median of per-round ratios
    surrogate_over: float  #: the surrogate's env-steps/s over its, median of per-round ratios
    mode: str = "vector"  #: one of :data:`MODES`; the ratios are against the same mode


class _Timed:
    """An env stepped with zero actions; ``seconds``: the wall time of each round."""

    def __init__(
        self,
        mode: str,
        model: str,
        env: VerticalSuspensionEnv | VerticalSuspensionVectorEnv,
        n_steps: int,
    ) -> None:
        self.mode, self.model, self.env, self.n_steps = mode, model, env, n_steps
        self.n_envs = env.num_envs if isinstance(env, VerticalSuspensionVectorEnv) else 1
        self.action = np.zeros(tuple(env.action_space.shape or ()), np.float32)
        self.seconds: list[float] = []
        if mode == "single" and n_steps > env.cfg.n_steps:
            raise ValueError(
                f"single_steps must be at most an episode's {env.cfg.n_steps} steps, got {n_steps}"
            )
        env.reset(seed=0)
        env.step(self.action)  # compile or load the kernel outside the timing
        self.left = env.cfg.n_steps - 1  # steps left in a single env's episode

    def round(self) -> None:
        env, action = self.env, self.action
        if self.mode == "single" and self.left < self.n_steps:
            env.reset()
            self.left = env.cfg.n_steps
        t0 = time.perf_counter()
        for _ in range(self.n_steps):
            env.step(action)
        self.seconds.append(time.perf_counter() - t0)
        self.left -= self.n_steps

    def rates(self) -> np.ndarray:
        return self.n_envs * self.n_steps / np.array(self.seconds)

    def close(self) -> None:
        self.env.close()


def fmu_unavailable() -> str | None:
    """Why the FMU row cannot be measured (``None`` when it can): FMPy (the ``fmi`` extra)
    or a C compiler missing."""
    try:
        importlib.import_module("fmpy")
    except ImportError:
        return "FMPy is not installed (pip install 'railgym[fmi]')"
    from surrogates.fmi.export import FMUExportError, find_compiler

    try:
        find_compiler()
    except FMUExportError:
        return "no C compiler to build the FMU (install gcc or set CC)"
    return None


def _envs(
    timed: list[_Timed],
    surrogate: Any,
    n_envs: int,
    n_steps: int,
    single_steps: int,
    fmu_steps: int,
    tmp: Path | None,
) -> None:
    """Append the timed envs to ``timed``: vector surrogate, reference (and the FMU exported
    into ``tmp`` unless ``None``), then single surrogate and reference."""
    backends = (
        ("surrogate", {"backend": "surrogate", "surrogate": surrogate}),
        ("reference", {"backend": "reference"}),
    )
    for label, kwargs in backends:
        timed.append(
            _Timed(
                "vector", label, VerticalSuspensionVectorEnvV3(num_envs=n_envs, **kwargs), n_steps
            )
        )
    if tmp is not None:
        from railgym.fmu.reference import export_reference_fmu

        fmu, mapping = export_reference_fmu(tmp / "reference.fmu")
        venv = VerticalSuspensionVectorEnvV3(
            num_envs=min(FMU_ENVS, n_envs), backend="fmu", fmu=fmu, fmu_map=mapping
        )
        timed.append(_Timed("vector", "reference FMU", venv, fmu_steps))
    for label, kwargs in backends:
        timed.append(_Timed("single", label, VerticalSuspensionEnvV3(**kwargs), single_steps))


def backend_speeds(
    surrogate: Any,
    n_envs: int = 256,
    n_steps: int = 200,
    rounds: int = 3,
    fmu_steps: int = 20,
    single_steps: int = 500,
) -> tuple[list[SpeedRow], str | None]:
    """The speed table's rows (vector surrogate, reference, then the FMU if it can be built;
    single surrogate, reference) and the note of a skipped FMU row (``None`` if measured); see
    the module docstring. ``n_steps``, ``fmu_steps``, ``single_steps``: steps per round of the
    numba vector envs, of the FMU env and of the single envs (at most an episode's)."""
    skipped = fmu_unavailable()
    threads = numba.get_num_threads()
    tmp = Path(tempfile.mkdtemp(prefix="railgym-speed-"))
    timed: list[_Timed] = []
    numba.set_num_threads(1)
    try:
        fmu_dir = tmp if skipped is None else None
        _envs(timed, surrogate, n_envs, n_steps, single_steps, fmu_steps, fmu_dir)
        for _ in range(rounds):
            for t in timed:
                t.round()
    finally:
        numba.set_num_threads(threads)
        for t in timed:
            t.close()
        shutil.rmtree(tmp, ignore_errors=True)
    rows = []
    for mode in MODES:
        group = {t.model: t for t in timed if t.mode == mode}
        sur, ref = group["surrogate"].rates(), group["reference"].rates()
        rows += [
            SpeedRow(
                t.model,
                t.n_envs,
                t.n_steps,
                float(np.median(t.rates())),
                float(np.median(t.rates() / ref)),
                float(np.median(sur / t.rates())),
                mode,
            )
            for t in group.values()
        ]
    return rows, skipped


#: what each row stepped, as printed
_WHAT = {
    "surrogate": "surrogate (numba)",
    "reference": "reference (numba)",
    "reference FMU": "reference FMU (FMPy)",
}


#: the comparisons the table leads with: (mode, the other model, what is compared)
COMPARISONS = (
    ("vector", "reference FMU", "surrogate vs reference FMU in the loop, vector envs"),
    ("single", "reference", "surrogate vs internal reference, single env"),
    ("vector", "reference", "surrogate vs internal reference, vector envs"),
)


def format_speeds(rows: list[SpeedRow], skipped: str | None, rounds: int) -> str:
    """The table printed by ``railgym demo``: the comparisons of :data:`COMPARISONS` (what is
    compared, the env id, the surrogate's env-steps/s over the other's; the FMU's how-to line
    in its place where it was skipped), lines saying what was measured, then one line per
    row (mode, sub-envs, steps per round, env-steps/s, ratio to the reference of the same
    mode)."""
    by = {(r.mode, r.model): r for r in rows}
    fmu = by.get(("vector", "reference FMU"))
    single = by.get(("single", "surrogate"))
    lines = [f"{'comparison (env-steps/s)':<52} {'env id':<30} {'surrogate ×':>11}"]
    for mode, model, what in COMPARISONS:
        if (mode, model) in by:
            lines.append(f"{what:<52} {ENV_ID:<30} {by[mode, model].surrogate_over:11.3g}")
        elif model == "reference FMU" and skipped is not None:
            lines.append(f"surrogate vs reference FMU in the loop: not measured: {skipped}")
    per_round = f"{by['vector', 'surrogate'].n_steps} steps per round of the vector envs" + (
        f" ({fmu.n_steps} of the FMU)" if fmu is not None else ""
    )
    if single is not None:
        per_round += f", {single.n_steps} of the single envs"
    lines += [
        f"measured now on this machine: {per_round}, median of {rounds} interleaved "
        "rounds, 1 numba thread, kernels compiled before timing",
        "surrogate: the element fitted above; reference: the model it replaces; FMU: that "
        "model exported to C (FMI 2.0), stepped through FMPy; vector: a native vector env, "
        "single: one env, whole steps",
        f"{'mode':<6} {'model':<24} {'sub-envs':>8} {'steps':>6} {'env-steps/s':>12} "
        f"{'× reference':>12}",
    ]
    for r in rows:
        lines.append(
            f"{r.mode:<6} {_WHAT.get(r.model, r.model):<24} {r.n_envs:8d} {r.n_steps:6d} "
            f"{r.steps_per_s:12.4g} {r.vs_reference:12.3g}"
        )
    return "\n".join(lines)
