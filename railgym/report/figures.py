"""PNG figures of the paper report (paper figs. 7–15); matplotlib is an optional dependency."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from railgym.report.compute import Artifacts, Plan
from railgym.report.tables import LABEL, QUANTITIES
from railgym.vehicles.crash.surrogate import crash_training_data

__all__ = ["FIGURE_FILES", "write_figures"]

#: the PNG files :func:`write_figures` writes, in that order
FIGURE_FILES = (
    "fig07_samples.png",
    "fig08_oob.png",
    "fig09_time_histories.png",
    "fig11_errors.png",
    "fig13_14_crash_elements.png",
    "fig15_crash_time_histories.png",
)


def _samples(plt: Any, art: Artifacts, plan: Plan) -> Any:
    """Figs. 7 / 10: training samples among all data, one panel per M."""
    U = art.data["U"]
    n = len(plan.sizes)
    fig, axes = plt.subplots(1, n, figsize=(4.6 * n, 4), squeeze=False)
    for ax, m in zip(axes[0], plan.sizes, strict=True):
        tr = art.reports["lpr", m].train_idx
        ax.plot(U[:, 0] * 1e3, U[:, 1], ".", ms=2, color="tab:blue", label=f"all data ({len(U)})")
        ax.plot(U[tr, 0] * 1e3, U[tr, 1], "o", ms=4, color="tab:red", label=f"training ({m})")
        ax.set(xlabel="x1 − x2 (mm)", ylabel="ẋ1 − ẋ2 (m/s)", title=f"Samples, M = {m}")
        ax.legend(loc="lower left", fontsize=8)
    fig.suptitle("Training samples vs all data (paper figs. 7, 10)")
    return fig


def _oob(plt: Any, art: Artifacts, plan: Plan) -> Any:
    """Fig. 8: out-of-bag predictions of both models against the reference force, one panel
    per model on the same axes (in one panel the markers of one model hide the other's).

    The output is the secondary suspension force ``F_s = m2·ẍ2`` of the passive training
    run (:func:`railgym.vehicles.collect.collect_vertical`), in kN."""
    U, V = art.data["U"], art.data["V"]
    m = plan.table3_m
    oob = art.reports["lpr", m].oob_idx
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.6), sharex=True, sharey=True)
    lim = [V.min() / 1e3, V.max() / 1e3]
    for ax, (kind, mk, color) in zip(
        axes, (("lpr", ".", "tab:blue"), ("kriging", "x", "tab:orange")), strict=True
    ):
        rel = art.reports[kind, m].oob_nrms
        pred = art.models[kind, m].predict(U[oob]) / 1e3
        ax.plot(lim, lim, "k-", lw=0.8, label="prediction = reference")
        ax.plot(
            V[oob] / 1e3,
            pred,
            mk,
            ms=3,
            color=color,
            label=f"{LABEL[kind]} ({len(oob)} points, rel. RMS {rel:.3f})",
        )
        ax.set(
            xlabel=r"reference secondary force $F_s = m_2 \ddot{x}_2$ (kN)",
            ylabel=r"predicted secondary force $\hat{F}_s$ (kN)",
            title=LABEL[kind],
        )
        ax.legend(loc="upper left", fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle(f"Out-of-bag predictions of the secondary force, M = {m} (paper fig. 8)")
    return fig


def _time_histories(plt: Any, art: Artifacts, plan: Plan) -> Any:
    """Fig. 9: carbody response of the reference and the LPR element, class 5; under each
    channel the difference LPR − reference (the curves overlap at plotting scale)."""
    ref = art.case5.reference
    m = plan.table3_m if f"lpr_{plan.table3_m}" in art.records else plan.sizes[-1]
    sim = art.records[f"lpr_{m}"]
    fig, axes = plt.subplots(
        6, 1, figsize=(11, 11), sharex=True, gridspec_kw={"height_ratios": [3, 1] * 3}
    )
    channels = (("x2", "m"), ("v2", "m/s"), ("a2", "m/s²"))
    pairs = zip(axes[::2], axes[1::2], strict=True)
    for (ax, dax), (ch, unit) in zip(pairs, channels, strict=True):
        ax.plot(ref["t"], ref[ch], lw=0.9, color="k", label="reference (dynamic)")
        ax.plot(sim["t"], sim[ch], lw=0.8, ls="--", label=f"LPR M={m}")
        ax.set_ylabel(f"{ch} ({unit})")
        ax.legend(loc="upper right", fontsize=8)
        diff = np.interp(ref["t"], sim["t"], sim[ch]) - ref[ch]
        rms = float(np.sqrt(np.mean(diff**2)))
        dax.plot(ref["t"], diff, lw=0.7, color="tab:red", label=f"RMS {rms:.3g} {unit}")
        dax.axhline(0.0, color="k", lw=0.5)
        dax.set_ylabel(f"Δ{ch} ({unit})")
        dax.legend(loc="upper right", fontsize=8)
    axes[0].set_title(
        "Carbody response, class 5, 144 km/h, unseen track (paper fig. 9); Δ: LPR − reference"
    )
    axes[-1].set_xlabel("t (s)")
    return fig


def _errors(plt: Any, table5: dict[str, Any], plan: Plan) -> Any:
    """Fig. 11: eq. 9 errors of the LPR and Kriging elements vs the sample size M, ours beside
    the paper's (table 5, Simpack source) where it gives that M.

    One legend for the three panels, below them (inside a panel it covers bars); on a log
    axis the floor lies a factor below the smallest bar and the top above the tallest, so no
    bar is cut at the axis (a bar starts at the floor)."""
    published = table5.get("published", {})
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.4), layout="constrained")
    x = np.arange(len(plan.sizes))
    for i, (ax, (q, label)) in enumerate(zip(axes, QUANTITIES, strict=True)):
        bars = []
        for kind in ("lpr", "kriging"):
            paper = published.get(kind, {})
            bars.append((f"{LABEL[kind]}, ours", None, [table5[kind][m][q] for m in plan.sizes]))
            bars.append(
                (
                    f"{LABEL[kind]}, paper (Simpack)",
                    "tab:gray" if kind == "lpr" else "silver",
                    [paper[m][i] if m in paper else np.nan for m in plan.sizes],
                )
            )
        width = 0.8 / len(bars)
        for j, (name, color, vals) in enumerate(bars):
            ax.bar(
                x + width * (j - (len(bars) - 1) / 2), vals, width=width, color=color, label=name
            )
        ax.set_xticks(x, [f"{m} samples" for m in plan.sizes])
        shown = [v for _, _, vals in bars for v in vals if np.isfinite(v) and v > 0]
        if max(shown) > 10 * min(shown):
            ax.set_yscale("log")
            ax.set_ylim(min(shown) / 3.0, max(shown) * 3.0)
        else:
            ax.set_ylim(0.0, max(shown) * 1.1)
        ax.set_title(label)
        ax.grid(axis="y", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), fontsize=9)
    fig.suptitle("Simulation errors vs sample size, ours and the paper's (paper fig. 11)")
    return fig


def _crash_elements(plt: Any, art: Artifacts, plan: Plan) -> Any:
    """Figs. 13–14: force–crush data of the reference and the LPR branches, each branch
    drawn only where its own data lie (within 1 % of the crush range), not across gaps."""
    train = crash_training_data(art.crash["reference"])
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for ax, name in zip(axes, ("wall", "interface"), strict=True):
        u, f, _, loading, _ = train[name]
        ax.plot(u[loading], f[loading] / 1e3, ".", ms=2, color="tab:blue", label="loading data")
        ax.plot(
            u[~loading], f[~loading] / 1e3, ".", ms=2, color="tab:orange", label="unloading data"
        )
        for variant in plan.crash_variants:
            el = art.crash[variant][0].elements[name]
            for branch, mdl, ls in (("loading", el.loading, "-"), ("unloading", el.unloading, ":")):
                if mdl is None:
                    continue
                mine = loading if branch == "loading" else ~loading
                if not np.any(mine):
                    continue
                grid = np.linspace(mdl.lower_[0], mdl.upper_[0], 800)
                lo, hi = el.force_range[branch]
                curve = np.clip(mdl.predict(grid[:, None]), lo, hi) / 1e3
                curve[~_near(grid, u[mine], 0.01 * np.ptp(u))] = np.nan  # gaps: no data
                ax.plot(
                    grid,
                    curve,
                    ls,
                    lw=1.2,
                    label=f"{variant} LPR {branch} (deg {el.degrees[branch]})",
                )
        ax.set(
            xlabel="crush u (m)", ylabel="force (kN)", title=f"{name}: f = G(u) (paper figs. 13–14)"
        )
        ax.legend(fontsize=7)
    return fig


def _near(x: np.ndarray, data: np.ndarray, tol: float) -> np.ndarray:
    """Where ``x`` lies within ``tol`` of a value of ``data``."""
    ref = np.sort(data)
    j = np.clip(np.searchsorted(ref, x), 0, ref.size - 1)
    i = np.clip(j - 1, 0, ref.size - 1)
    return np.minimum(np.abs(x - ref[i]), np.abs(x - ref[j])) <= tol


def _crash_histories(plt: Any, art: Artifacts, plan: Plan) -> Any:
    """Fig. 15: crash time histories of the reference and each surrogate variant."""
    cref = art.crash["reference"]
    fig, axes = plt.subplots(3, 2, figsize=(12, 9), sharex=True)
    for col, car in enumerate(("lead car", "passenger car")):
        for row, (key, unit) in enumerate((("x", "m"), ("v", "m/s"), ("a", "m/s²"))):
            ax = axes[row, col]
            ax.plot(cref.t, getattr(cref, key)[:, col], color="k", lw=1, label="reference")
            for variant in plan.crash_variants:
                res = art.crash[variant][1]
                ax.plot(
                    res.t, getattr(res, key)[:, col], ls="--", lw=1, label=f"surrogate ({variant})"
                )
            ax.set_ylabel(f"{key} ({unit})")
            ax.set_title(car if row == 0 else "")
            ax.legend(fontsize=7)
        axes[-1, col].set_xlabel("t (s)")
    fig.suptitle("Crash, paper scenario: surrogate vs reference (paper fig. 15)")
    return fig


def write_figures(out: Path, art: Artifacts, plan: Plan, table5: dict[str, Any]) -> list[str]:
    """Write the PNG figures into ``out``; returns their file names ([] without matplotlib)."""
    try:
        import matplotlib
    except ImportError:
        return []
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    draws = (
        lambda: _samples(plt, art, plan),
        lambda: _oob(plt, art, plan),
        lambda: _time_histories(plt, art, plan),
        lambda: _errors(plt, table5, plan),
        lambda: _crash_elements(plt, art, plan),
        lambda: _crash_histories(plt, art, plan),
    )
    figures = dict(zip(FIGURE_FILES, draws, strict=True))
    for name, draw in figures.items():
        fig = draw()
        if fig.get_layout_engine() is None:  # a figure may bring its own (constrained)
            fig.tight_layout()
        fig.savefig(out / name, dpi=90)
        plt.close(fig)
    return list(figures)
