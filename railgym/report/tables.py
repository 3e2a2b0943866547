"""Markdown tables of the paper report, from the plain data of :func:`railgym.report.compute`.

Each section gives our numbers, then the paper's beside them, labelled :data:`PAPER_LABEL`.
"""

from __future__ import annotations

import math
import platform
from typing import Any

from railgym.report.published import PAPER_LABEL

__all__ = ["QUANTITIES", "markdown", "table"]

#: eq. 9 quantities: (key, row label)
QUANTITIES = (
    ("x", "Displacement error (m)"),
    ("v", "Velocity error (m/s)"),
    ("a", "Acceleration error (m/s²)"),
)
LABEL = {"lpr": "LPR", "kriging": "Kriging"}
KINDS = ("lpr", "kriging")
CARS = ("lead", "passenger")


def _e(x: float | None) -> str:
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.3g}"


def table(header: list[str], rows: list[list[str]]) -> str:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def _sim_cell(entry: dict[str, Any], key: str) -> str:
    text = _e(entry[key])
    return f"{text} (diverged at {entry['t_end_s']:.2f} s)" if entry["diverged"] else text


def _ood(entry: dict[str, Any]) -> str:
    return f"{entry['out_of_domain']} / {entry['evaluations']}"


def _intro(r: dict[str, Any]) -> str:
    p, n = r["plan"], r["table3"]["n"]
    return (
        "# railgym paper: the paper's tables and figures on our reference models\n\n"
        f"Mode: {'quick' if p['quick'] else 'full'}; seed {p['seed']}; run time "
        f"{r['elapsed_s']:.1f} s on {platform.machine()} ({platform.python_version()}). "
        "Vertical case: dynamic reference model (air spring with surge reservoir, Maxwell "
        "damper, bump stops), Manchester vehicle; training data FRA class 5 at 144 km/h, "
        f"20 s at 50 Hz ({n} points, track seed {p['seed']}). Crash case: packaged "
        "`paper` scenario. Each table gives our numbers, then the paper's, labelled "
        f'"{PAPER_LABEL}". Both elements, LPR and Kriging, run in the same compiled RK4 '
        "kernel as the secondary suspension; a run that leaves the finite range is flagged "
        "diverged.\n"
    )


def _table3(t3: dict[str, Any]) -> str:
    unit = "(–)" if t3["lpr"]["oob_error_kind"] == "relative" else "(N)"
    if t3["lpr"]["oob_error_kind"] == "relative":
        what = "eq. 8 average relative error"
    else:
        what = (
            "eq. 9 average absolute error (N): the outputs m2·ẍ2 cross zero, so eq. 8 is "
            "undefined; also given divided by the mean |output| of the OOB samples"
        )
    rows = [
        [
            LABEL[k],
            e["chosen"],
            _e(e["oob_error"]),
            _e(e["oob_error_normalised"]),
            _e(e["oob_nrms"]),
        ]
        for k, e in ((k, t3[k]) for k in KINDS)
    ]
    head = [
        "model",
        "chosen degree / kernel",
        f"OOB error {unit}",
        "OOB error / mean |v| (–)",
        "OOB relative RMS (–)",
    ]
    pub = t3["published"]
    every = [
        [LABEL[k], str(m), e["chosen"], _e(e["oob_error"]), _e(e["oob_nrms"])]
        for k, d in t3["all_sizes"].items()
        for m, e in d.items()
    ]
    return (
        f"## Table 3: out-of-bag error, M = {t3['m']} of {t3['n']}\n\nOurs, {what}.\n\n"
        + table(head, rows)
        + f"\n{PAPER_LABEL}, eq. 8:\n\n"
        + table(
            ["model", "OOB error, eq. 8 (–)"],
            [["LPR", _e(pub["lpr"])], ["Kriging", _e(pub["kriging"])]],
        )
        + "\nAll fitted sizes:\n\n"
        + table(["model", "M", "chosen", f"OOB error {unit}", "OOB relative RMS (–)"], every)
        + "\nThe reference element has memory (reservoir pressure, damper bush), so no function "
        "F(δ, δ̇) reproduces it: both models stop at the same floor of about "
        f"{t3['lpr']['oob_nrms']:.0%} relative RMS. The paper's errors of 1e-8..1e-5 imply a "
        "nearly memoryless Simpack element.\n"
    )


def _published_errors(pub: dict[str, Any], keys: tuple[int, ...], col: str) -> str:
    rows = [
        [label] + [_e(pub[k][c][i]) for k in KINDS for c in keys]
        for i, (_, label) in enumerate(QUANTITIES)
    ]
    head = ["quantity"] + [f"{LABEL[k]} {col}{c}" for k in KINDS for c in keys]
    return table(head, rows)


def _table5(t5: dict[str, Any]) -> str:
    sizes = list(t5["lpr"])
    scale = t5["reference_mean_abs"]
    rows = [
        [label] + [_sim_cell(t5[k][m], q) for k in KINDS for m in sizes] + [_e(scale[q])]
        for q, label in QUANTITIES
    ]
    rows.append(
        ["out-of-domain stage evaluations"] + [_ood(t5[k][m]) for k in KINDS for m in sizes] + [""]
    )
    rows.append(
        ["diverged"] + [str(t5[k][m]["diverged"]).lower() for k in KINDS for m in sizes] + [""]
    )
    head = ["quantity"] + [f"{LABEL[k]} {m}" for k in KINDS for m in sizes]
    head.append("reference mean abs.")
    return (
        f"## Table 5 / fig. 11: simulation errors (eq. 9), class 5, 144 km/h, "
        f"{t5['duration_s']:g} s, unseen track seed {t5['track_seed']}, "
        f"recorded at {t5['sample_rate_hz']:g} Hz\n\n"
        + table(head, rows)
        + f"\n{PAPER_LABEL}:\n\n"
        + _published_errors(t5["published"], (51, 101, 201), "")
    )


def _table6(t6: dict[str, Any]) -> str:
    rows = []
    for kind in KINDS:
        for m, e in t6[kind].items():
            rows.append(
                [
                    LABEL[kind],
                    str(m),
                    f"{e['T_t_fit_s']:.4f}",
                    f"{e['T_t_build_s']:.2f}",
                    f"{e['T_s_numba_s']:.3f}",
                    f"{e['predict_call_us']:.1f}",
                    f"{e['predict_point_us']:.3f}",
                ]
            )
    rows.append(["reference (dynamic, numba)", "—", "—", "—", f"{t6['reference_s']:.3f}", "—", "—"])
    head = [
        "model",
        "M",
        "T_t fit (s)",
        "T_t build (s)",
        "T_s numba (s)",
        "predict µs/call",
        "predict µs/point",
    ]
    pt = t6["published"]
    pub = [[LABEL[k], str(m), _e(v[0]), _e(v[1])] for k in KINDS for m, v in pt[k].items()]
    pub.append(["Simpack reference", "—", "—", _e(pt["reference_s"])])
    return (
        f"\n## Table 6: training time T_t and simulation time T_s ({t6['duration_s']:g} s "
        "simulated)\n\nT_t (fit): final fit on the M samples; T_t (build): GA sampling + "
        "model selection + fit. T_s (numba): the compiled RK4 kernel of "
        "`railgym.vehicles.vertical.simulate` with the element inside (Kriging costs O(M) per "
        "evaluation, LPR O(degree)). `predict` cost: µs per call with one point "
        "(the unit of work of a co-simulation that calls the model once per stage) and µs per "
        "point in a batch of 10⁴ (the model's own cost, O(M) for Kriging).\n\n"
        + table(head, rows)
        + f"\n{PAPER_LABEL} (20 s simulated):\n\n"
        + table(["model", "M", "T_t (s)", "T_s (s)"], pub)
    )


def _table8(t8: dict[str, Any]) -> str:
    cls = t8["classes"]
    head = (
        ["quantity"]
        + [f"{LABEL[k]} class {c} ({cls[c]['speed_kmh']:g} km/h)" for k in KINDS for c in cls]
        + [f"reference mean abs. class {c}" for c in cls]
    )
    rows = [
        [label]
        + [_sim_cell(cls[c][k], q) for k in KINDS for c in cls]
        + [_e(cls[c]["reference_mean_abs"][q]) for c in cls]
        for q, label in QUANTITIES
    ]
    blank = [""] * len(cls)
    rows.append(
        ["out-of-domain stage evaluations"] + [_ood(cls[c][k]) for k in KINDS for c in cls] + blank
    )
    rows.append(
        ["diverged"] + [str(cls[c][k]["diverged"]).lower() for k in KINDS for c in cls] + blank
    )
    contacts = ", ".join(f"class {c}: {cls[c]['reference_contacts']}" for c in cls)
    return (
        f"\n## Table 8: tolerance to other track classes (LPR and Kriging trained on class 5, "
        f"M = {t8['m']}, {t8['duration_s']:g} s, track seed {t8['track_seed']})\n\n"
        + table(head, rows)
        + f"\nReference bump-stop contacts (substeps): {contacts}. Inputs outside the "
        "training box are extrapolated linearly from the box boundary (the models' guard). "
        f"{_divergence(cls)}\n"
        + f"\n{PAPER_LABEL} (Kriging diverged on class 4):\n\n"
        + _published_errors(t8["published"], (3, 4, 6), "class ")
    )


def _divergence(cls: dict[Any, Any]) -> str:
    """One sentence on which runs of table 8 diverged (the paper's Kriging did on class 4)."""
    gone = [
        f"{LABEL[k]} on class {c} (at {cls[c][k]['t_end_s']:.2f} s)"
        for k in KINDS
        for c in cls
        if cls[c][k]["diverged"]
    ]
    if gone:
        return "Diverged: " + ", ".join(gone) + "."
    return (
        "No run diverged: with the guard our Kriging stays finite on class 4, where the "
        "paper's diverged; its errors there are the Kriging columns above."
    )


def _table10(t10: dict[str, Any], variants: list[str]) -> str:
    cap = t10["max_degree"]
    rows = [
        [
            v,
            name,
            f"{e['degree']}{' (= the cap)' if e['degree'] == cap else ''}",
            str(e["n_samples"]),
            _e(e["cv_rms_N"] / 1e3),
        ]
        for v in variants
        for name, e in t10["variants"][v].items()
    ]
    return (
        f"\n## Table 10: LPR degrees of the crash elements (10-fold CV, degrees 1..{cap})\n\n"
        + table(["variant", "element_branch", "degree", "samples", "CV RMS (kN)"], rows)
        + f"\n{PAPER_LABEL}: the degrees of table 10 are not in our copy of the paper's "
        "text. The `hysteretic` variant fits only the loading envelope and unloads "
        "elastically, so it has two LPRs instead of four.\n"
    )


def _table11(t11: dict[str, Any], variants: list[str]) -> str:
    head = ["quantity"] + [f"variant {v}: {car} car" for v in variants for car in CARS]
    rows = [
        [label] + [_e(t11["variants"][v][car][q]) for v in variants for car in CARS]
        for q, label in QUANTITIES
    ]
    times = "; ".join(
        f"{v}: build {e['build_s']:.2f} s, simulation {e['sim_s'] * 1e3:.2f} ms"
        for v, e in t11["variants"].items()
    )
    pt = t11["published"]
    pub = [
        [label, _e(pt["lead"][i]), _e(pt["passenger"][i])]
        for i, (_, label) in enumerate(QUANTITIES)
    ]
    return (
        "\n## Table 11: crash simulation errors (eq. 9), paper scenario\n\n"
        + table(head, rows)
        + f"\nCompiled kernels: reference model {t11['reference_s'] * 1e3:.2f} ms; {times}.\n"
        + f"\n{PAPER_LABEL} (FE {pt['reference_s']:g} s, data-driven about "
        f"{pt['surrogate_s']:g} s):\n\n" + table(["quantity", "lead car", "passenger car"], pub)
    )


def markdown(r: dict[str, Any]) -> str:
    """The whole ``report.md`` of a :func:`railgym.report.make_report` result."""
    variants = r["plan"]["crash_variants"]
    figures = "\n".join(f"![{f}]({f})" for f in r["figures"]) or "(matplotlib not installed)"
    parts = [
        _intro(r),
        _table3(r["table3"]),
        _table5(r["table5"]),
        _table6(r["table6"]),
        _table8(r["table8"]),
        _table10(r["table10"], variants),
        _table11(r["table11"], variants),
        validation_markdown(r["validation"]),
        "\n## Figures\n\n" + figures + "\n",
    ]
    return "\n".join(parts)


def validation_markdown(v: dict[str, Any]) -> str:
    """The validation matrix (:func:`railgym.report.validation.validation_matrix`)."""
    st = v["settings"]
    rows = [
        [
            r["element"],
            str(r["class"]),
            r["controller"],
            f"{100 * r['median']:.1f}",
            f"{100 * r['p90']:.1f}",
            f"{100 * r['max']:.1f}",
            *(_e(x) for x in r["eq9"]),
            str(r["diverged"]),
        ]
        for r in sorted(v["rows"], key=lambda r: (r["element"], r["class"], r["controller"]))
    ]
    head = [
        "element",
        "class",
        "controller",
        "median %",
        "90th %",
        "max %",
        "eq. 9 x2 (m)",
        "eq. 9 v2 (m/s)",
        "eq. 9 a2 (m/s²)",
        "diverged",
    ]
    return (
        f"\n## Validation matrix: relative RMS error of the carbody acceleration against the "
        f"reference ({st['n_seeds']} unseen tracks per class, {st['duration']:g} s at each "
        "class's maximum speed, closed loop)\n\n"
        + table(head, rows)
        + f"\n{PAPER_LABEL}, table 8 (eq. 9, trained on class 5):\n\n"
        + _published_errors(v["published"], (3, 4, 6), "class ")
    )
