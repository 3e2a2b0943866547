"""The paper report: the analogues of the paper's tables and figures on our models.

:func:`make_report` runs :func:`~railgym.report.compute.compute` (runs and indices), writes
the PNG figures (:mod:`~railgym.report.figures`, needs matplotlib) and ``report.md``
(:mod:`~railgym.report.tables`) and returns the tables as plain data. The ``railgym paper``
command is a thin shell around it.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from railgym.progress import bar as progress_bar
from railgym.progress import quiet
from railgym.report.compute import FULL, QUICK, Plan, compute, n_steps
from railgym.report.figures import FIGURE_FILES, write_figures
from railgym.report.output import prepare_output_dir, write_text_atomic
from railgym.report.published import PAPER, PAPER_LABEL
from railgym.report.tables import markdown
from railgym.report.validation import check_targets, validation_matrix
from railgym.vehicles.collect import default_vertical_surrogate

__all__ = [
    "FULL",
    "PAPER",
    "PAPER_LABEL",
    "QUICK",
    "REPORT_FILES",
    "Plan",
    "check_targets",
    "make_report",
    "validation_matrix",
]

#: the files :func:`make_report` writes into its folder (a re-run replaces them)
REPORT_FILES = ("report.md", *FIGURE_FILES)


def make_report(
    out: str | Path,
    quick: bool = False,
    seed: int = 0,
    progress: bool = True,
    overwrite: bool = False,
    workers: int = 1,
    address: str | None = None,
) -> dict[str, Any]:
    """Regenerate the paper's tables 3, 5, 6, 8, 10, 11, figures 7–15 and the validation
    matrix on our models.

    Parameters
    ----------
    out : folder for ``report.md`` and the PNG figures (:data:`REPORT_FILES`); created, or an
        existing one that is empty or holds only these files (a re-run replaces them).
    quick : reduced sizes (:data:`QUICK`) instead of :data:`FULL`.
    seed : seed of the training track, the sampling and the CV folds; the vertical test
        simulations run on track seed ``seed + 1``.
    progress : show a progress bar (stderr, only on a terminal; see :mod:`railgym.progress`).
    overwrite : allow an ``out`` that holds other files too (its report files are replaced,
        the others kept).
    workers, address : run the validation matrix's tracks on ``workers`` processes (a local
        Ray instance with the ``ray`` extra) or on the Ray cluster at ``address``
        (:func:`railgym.parallel.run_tasks`); the report does not depend on them.

    Returns
    -------
    dict of plain data: ``plan``, ``table3``, ``table5``, ``table6``, ``table8``, ``table10``,
    ``table11`` (each with the paper's numbers under ``"published"`` where the text has them),
    ``validation`` (:func:`~railgym.report.validation.validation_matrix` of the packaged
    static and memory elements, ``plan.validation_seeds`` tracks per class),
    ``figures`` (file names), ``elapsed_s``.
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    out = prepare_output_dir(out, overwrite, own=REPORT_FILES)
    plan = QUICK if quick else FULL
    t0 = time.perf_counter()
    with quiet(not progress):
        bar = progress_bar(desc="railgym paper", total=n_steps(plan) + 1)

    def step(label: str) -> None:
        bar.set_postfix_str(label, refresh=False)
        bar.update(1)

    result, art = compute(plan, seed, step)
    elements = {
        "static": default_vertical_surrogate("static"),
        "memory": default_vertical_surrogate("maxwell"),
    }
    result["validation"] = validation_matrix(
        elements,
        n_seeds=plan.validation_seeds,
        duration=plan.duration,
        progress=step,
        workers=workers,
        address=address,
    )
    result["plan"]["quick"] = quick
    result["figures"] = write_figures(out, art, plan, result["table5"])
    step("figures")
    bar.close()
    result["elapsed_s"] = time.perf_counter() - t0
    write_text_atomic(out / "report.md", markdown(result))
    return result
