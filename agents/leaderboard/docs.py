"""The generated pages ``docs/tasks.md`` (per task: observations, actions, reward terms,
episode end, evaluation protocol, score; read from the env each task makes) and
``docs/leaderboard.md`` (the table of the stored entries, each learned entry's hyperparameters
and budget, the compute budget of the whole leaderboard (:mod:`agents.leaderboard.budget`),
the reference values per case and the learning curves, ``docs/leaderboard_curves.png`` where
matplotlib is installed)."""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from agents.leaderboard.budget import (
    FEW_SEEDS,
    MANY_SEEDS,
    SEED_RULE_S,
    projection,
    stored_time,
)
from agents.leaderboard.results import format_table, table_rows
from agents.leaderboard.run import RESIDUAL_BASES
from railgym import tasks as rt

__all__ = [
    "CURVES_PNG",
    "UNITS",
    "budget_section",
    "learned_section",
    "leaderboard_page",
    "plot_curves",
    "tasks_page",
    "write_docs",
]

#: unit of an observation channel by the start of its name (physical value = obs × scale)
UNITS = (
    ("preview_zdot", "m/s"),
    ("preview_z", "m"),
    ("deflection_rate", "m/s"),
    ("deflection", "m"),
    ("damper_command", "1"),
    ("carbody_vel", "m/s"),
    ("acc", "m/s²"),
    ("bogie_acc", "m/s²"),
    ("carbody_acc", "m/s²"),
    ("x_", "m"),
    ("v_", "m/s"),
    ("a_", "m/s²"),
    ("crush_", "m"),
    ("force_", "N"),
    ("scale_", "1"),
)
#: the learning-curve figure beside docs/leaderboard.md
CURVES_PNG = "leaderboard_curves.png"
_EPISODE_END = {
    "railgym/TrainCrash-v1": "terminates when the crash is over (all cars stopped or "
    "rebounding) or the state diverges; truncates at `max_duration`",
    "default": "truncates after `duration`; terminates only where the state diverges "
    "(non-finite or beyond the env's limits)",
}


def _unit(name: str) -> str:
    return next((u for prefix, u in UNITS if name.startswith(prefix)), "")


def _channels(names: Sequence[str], scales: Sequence[float]) -> list[tuple[str, str, str]]:
    """(name, unit, scale) rows; numbered channels ``p_0 … p_k`` of one scale as one row."""
    rows: list[tuple[str, str, str]] = []
    i = 0
    while i < len(names):
        m = re.fullmatch(r"(.*)_(\d+)", names[i])
        j = i + 1
        if m:
            while j < len(names) and re.fullmatch(re.escape(m[1]) + r"_\d+", names[j]):
                j += 1
        label = names[i] if j == i + 1 else f"{names[i]} … {names[j - 1]}"
        rows.append((label, _unit(names[i]), f"{float(scales[i]):g}"))
        i = j
    return rows


def _task_section(task: rt.Task) -> list[str]:
    env = rt.make(task.name)
    base: Any = env.unwrapped
    cfg = base.cfg
    lines = [f"## {task.name}", "", task.description + ".", ""]
    args = ", ".join(f"{k}={v!r}" for k, v in task.env_kwargs.items())
    lines += [f"`gym.make({task.env_id!r}, {args})`", ""]
    lines += ["| observation | unit | scale (physical = obs × scale) |", "|---|---|---|"]
    lines += [f"| {n} | {u} | {s} |" for n, u, s in _channels(base.obs_names, base.obs_scale)]
    space = env.action_space
    lines += ["", f"Action: {space.shape[0]} in [{space.low[0]:g}, {space.high[0]:g}]"]
    if task.env_id.startswith("railgym/TrainCrash"):
        lines[-1] += " per crush zone: absorber force scale `1 + absorber_range · action`."
    elif cfg.actuator == "semi-active":
        lines[-1] += ": damper command (0 softest, 1 hardest)."
    else:
        lines[-1] += f" per actuator: force / f_max, f_max = {cfg.f_max:g} N."
    weights = ", ".join(f"{k} {v:g}" for k, v in cfg.reward_weights.items())
    lines += ["", f"Reward terms (weights): {weights} (docs of the env: *Reward*)."]
    end = _EPISODE_END.get(task.env_id, _EPISODE_END["default"])
    lines += [f"Episode: {cfg.n_steps} steps of {cfg.control_dt:g} s; {end}.", ""]
    cases = ", ".join(c.label for c in task.cases)
    lines += [
        f"Evaluation: cases {cases}; {task.episodes} episode(s) each on the track seeds "
        f"{task.seed} … {task.seed + task.episodes - 1}.",
        f"Metric: {task.metric}, {task.unit}, lower is better. Classical baselines: "
        f"{', '.join(task.baselines)}.",
        f"Score per case: (passive − metric) / (passive − bound). Bound: {task.bound}.",
        "",
    ]
    env.close()
    return lines


#: the physics argument of the task ``bogie-payload`` (docs/tasks.md)
PAYLOAD_ARGUMENT = """## Why bogie-payload limits classical control

The carbody mass m2 ±25 % moves the body bounce mode f = √(k2/m2)/2π of the packaged coach
(k2 = 860 kN/m, m2 = 16 t: 1.17 Hz) to 1.35 Hz (−25 %) and 1.04 Hz (+25 %), and a speed of
86 or 144 km/h scales the track's temporal spectrum by 1.67: the LQG's plant and disturbance
model (designed for the nominal vehicle at 144 km/h) is wrong on every other case, and
neither is observed, so a policy must infer them from the sensors. Its gain is designed
without the 4 kN force limit, which the controller then clips. The gain-scheduled LQG
(`lqg-scheduled`, told each case's mass and speed) removes the first limitation, not the
second. On the linear suspension the clairvoyant optimum is exact (a convex problem), so the
headroom left by both baselines is measured, not estimated (leaderboard.md).
"""


def tasks_page() -> str:
    """The markdown of ``docs/tasks.md``."""
    lines = [
        "# Benchmark tasks",
        "",
        "Generated by `railgym leaderboard docs` from `railgym.tasks` and the envs each task "
        "makes (`railgym.tasks.make(name)`); scores and the table: "
        "[leaderboard.md](leaderboard.md). Every task runs the newest version of its env; "
        "its references and entries were computed on that version's tracks (the streamed "
        "`-v3` draws other tracks than `-v2`: a result on another version is not comparable).",
        "",
    ]
    for task in rt.TASKS.values():
        lines += _task_section(task)
    return "\n".join(lines) + "\n" + PAYLOAD_ARGUMENT


def plot_curves(entries: Sequence[dict[str, Any]], path: Path) -> bool:
    """Learning curves (evaluation reward against env steps and wall time) of the learned
    entries into ``path``; ``False`` without matplotlib or learned entries."""
    learned = [e for e in entries if e.get("curves")]
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    if not learned:
        return False
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for e in learned:
        for seed, c in e["curves"].items():
            label = f"{e['task']} {e['name']} seed {seed}"
            ax[0].plot(c["steps"], c["reward"], marker=".", label=label)
            ax[1].plot(c["wall_s"], c["reward"], marker=".", label=label)
    ax[0].set(xlabel="env steps", ylabel="evaluation reward (mean per episode)")
    ax[1].set(xlabel="wall time (s)")
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return True


def _references() -> list[str]:
    lines = [
        "| task | case | passive | bound | bound from | best baseline |",
        "|---|---|---|---|---|---|",
    ]
    for name, cases in rt.references().items():
        for case, r in cases.items():
            best = min(r["baselines"], key=r["baselines"].__getitem__)
            lines.append(
                f"| {name} | {case} | {r['passive']:.4g} | {r['bound']:.4g} | "
                f"{r['bound_method']} | {best} {r['baselines'][best]:.4g} |"
            )
    return lines


#: how each task's bound is computed and how tight it is (docs/leaderboard.md)
BOUNDS_NOTE = """## The bounds and how tight they are

- `bogie-payload`: exact. On the linear suspension the Wk-weighted carbody acceleration is
  affine in the force sequence, so the clairvoyant optimum over the force box is a convex
  problem; the value stored is a certified lower bound of it (L-BFGS-B's point minus its
  Frank–Wolfe gap, 4·10⁻⁹ m/s² below the point found on the track checked), so no
  controller, causal or not, can beat it.
- `bogie-semi-active`: the best open-loop damper commands found per track by
  `agents.evaluation.semi_active_bound` (L-BFGS-B with forward-difference gradients from the
  baselines' commands and constants; 4 gradient evaluations per start, 10 for the best); a
  local optimum, so an upper estimate of the clairvoyant optimum: a controller could score
  above 1 by the search's remaining gap.
- `crash-adaptive`: the best piecewise-constant absorber commands found per case (pieces of
  50 ms, levels −1 … 1 in steps of 0.25, two coordinate sweeps from every constant setting and
  every baseline's recorded commands); an upper estimate of the optimum alike. On a small case
  (two pieces, three levels) it equals the brute-force optimum (tested).
- `bogie-active`, `vehicle-active`, `vehicle-preview`: the trivial bound 0 m/s². Their
  clairvoyant optimum on the reference model (air spring, bump stops, force limit) would need
  the semi-active search over 2000 force steps per 20 s episode (its Jacobian costs
  N(N+1)/2 ≈ 2·10⁶ lane-steps per evaluation, about 16 times the 5 s semi-active case, hours
  per track on one core): not computed. Their scores are therefore fractions of a_w removed, not
  of the achievable headroom.

Every stored bound is also at most every baseline's value on its case (each baseline is a
feasible command sequence), tested against every stored entry.
"""


#: the keys of a learned entry's training config that are its run's, not hyperparameters
_RUN_KEYS = frozenset(
    {"algo", "n_timesteps", "policy", "seed", "env_kwargs", "eval_freq", "n_eval_episodes"}
    | {"checkpoint_freq", "residual"}
)


def _hours(seconds: float) -> str:
    return f"{seconds:,.0f} s ({seconds / 3600:.2f} h)"


def _block(entry: dict[str, Any]) -> dict[str, Any]:
    """The training config block of a learned entry (its provenance's one env id)."""
    ((_, block),) = entry["provenance"]["config"].items()
    return dict(block)


def _hyper(block: dict[str, Any]) -> str:
    """``key value, …`` of the hyperparameters in ``block`` (``policy_kwargs`` of the network
    alone: ``net_arch``)."""
    parts = []
    for key, value in sorted(block.items()):
        if key in _RUN_KEYS:
            continue
        if key == "policy_kwargs" and set(value) == {"net_arch"}:
            key, value = "net_arch", value["net_arch"]
        parts.append(f"{key} {value}")
    return ", ".join(parts)


def learned_section(entries: Sequence[dict[str, Any]]) -> list[str]:
    """Per learned entry: algorithm, the controller a residual corrects, seeds, steps, wall
    time of training and evaluation, and its hyperparameters (its stored training config)."""
    bases = ", ".join(f"{t} {c}" for t, c in RESIDUAL_BASES.items())
    lines = [
        "## Learned entries: hyperparameters and budget",
        "",
        "SB3 with one hyperparameter set per algorithm, the same on every task "
        "(`agents.leaderboard.run.HYPERPARAMETERS`; the rest SB3's defaults), trained on one "
        "core on the task's training case (`railgym leaderboard run --task T --algo A --seeds N "
        "--steps S`). `A-residual-CONTROLLER` (`… --residual CONTROLLER`): the agent's action "
        "is added to the controller's (`agents.controllers.residual`, scale 1), the "
        "controller designed once for the training case and kept on every evaluation case, "
        "as wherever the saved policy is loaded (the controller's baseline row is designed "
        "for each case; on bogie-payload the `lqg` row is the nominal design, the "
        f"residual's); the full set's controllers: {bases}. Seeds: {MANY_SEEDS} where one "
        f"seed trains in ≤ {SEED_RULE_S / 60:g} min on one core, else {FEW_SEEDS}. Times "
        "in s on one core (the machine in each entry's provenance); evaluation: the held-out "
        "cases of every seed, where recorded.",
        "",
        "| task | entry | algorithm | residual on | seeds | steps per seed | training s | "
        "evaluation s | hyperparameters |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for e in entries:
        if e["kind"] != "learned":
            continue
        block = _block(e)
        evaluation = e.get("eval_wall_s")
        lines.append(
            f"| {e['task']} | {e['name']} | {block['algo']} | {block.get('residual') or '—'} | "
            f"{len(e['seeds'])} | {e['steps']:,} | {e['provenance']['wall_s']:,.0f} | "
            f"{'—' if evaluation is None else f'{evaluation:,.0f}'} | {_hyper(block)} |"
        )
    return lines


def budget_section(entries: Sequence[dict[str, Any]]) -> list[str]:
    """The wall time stored with ``entries`` and the projected time of the full set."""
    stored = stored_time(entries)
    plan = projection(entries)
    projected = [p for p in plan if p.total_s is not None]
    missing = [f"{p.task} {p.name}" for p in plan if p.total_s is None]
    total = sum(p.total_s or 0.0 for p in plan) + stored.others
    lines = [
        "## Compute budget",
        "",
        f"Stored: {_hours(stored.total)} on one core: the entries' provenance wall time "
        f"{_hours(stored.provenance)} (training of the {stored.learned} learned entries "
        f"{stored.training:,.0f} s, the baseline and policy entries {stored.others:,.0f} s), "
        f"and the held-out evaluation of the learned entries {stored.evaluation:,.0f} s "
        f"(recorded for {stored.evaluated} of {stored.learned}). The reference values "
        "(`railgym leaderboard references`: passive, baselines and bound searches) record no "
        "wall time and are not included.",
        "",
        f"Full set ({len(plan)} learned entries: every task × PPO, SAC, TD3, plain and "
        "residual on the controller above, seeds by the rule, at the stored runs' steps; "
        "`agents.leaderboard.budget`): projected "
        f"{_hours(total)} on one core with the baselines, about "
        f"{total / 7200:.2f} h with two runs at once on a 2-core machine (not measured; "
        "target ≤ 8 h).",
    ]
    if missing:
        lines[-1] += (
            f" Not projected ({len(missing)} of {len(plan)}: no stored run of their "
            f"algorithm on their task), so the figure is a lower bound: {', '.join(missing)}."
        )
    lines += [
        "",
        "| task | entry | time from | steps per seed | training s per seed | evaluation s per "
        "seed | seeds | projected s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for p in projected:
        lines.append(
            f"| {p.task} | {p.name} | {p.source} | {p.steps or 0:,} | {p.train_s:,.0f} | "
            f"{p.eval_s:,.0f} | {p.seeds} | {p.total_s:,.0f} |"
        )
    return lines


def leaderboard_page(entries: Sequence[dict[str, Any]], curves: bool) -> str:
    """The markdown of ``docs/leaderboard.md`` from the stored ``entries``."""
    lines = [
        "# Leaderboard",
        "",
        "Generated by `railgym leaderboard docs` from the stored entries "
        "(`agents/leaderboard/results/`); `railgym leaderboard` prints the same table. "
        "Tasks: [tasks.md](tasks.md). Score per case: 0 = passive, 1 = the task's bound; "
        "IQM over seeds × cases with its 95 % stratified bootstrap CI; `all`: over the tasks "
        "shown, for the entries every task has.",
        "",
        format_table(table_rows(entries)),
        "",
        "*wall s*: the entry's provenance wall time on one core (a learned entry: the "
        "training of all its seeds; a baseline or policy: its evaluation).",
        "",
        *learned_section(entries),
        "",
        *budget_section(entries),
        "",
        "## Reference values per case",
        "",
        "The task's metric (its unit, tasks.md). *bound from*: `search` (the least of the "
        "search's and every baseline's value), `exact` (the convex clairvoyant optimum), "
        "`trivial` (0 m/s²), `baselines` (no search "
        "run: the best baseline's value, not a bound).",
        "",
        *_references(),
        "",
        BOUNDS_NOTE,
    ]
    if curves:
        lines += ["", "## Learning curves", "", f"![learning curves]({CURVES_PNG})"]
    return "\n".join(lines) + "\n"


def write_docs(entries: Sequence[dict[str, Any]], docs: Path) -> list[Path]:
    """Write ``tasks.md``, ``leaderboard.md`` (and the curves) into ``docs``."""
    docs.mkdir(parents=True, exist_ok=True)
    curves = plot_curves(entries, docs / CURVES_PNG)
    (docs / "tasks.md").write_text(tasks_page())
    (docs / "leaderboard.md").write_text(leaderboard_page(entries, curves))
    return [docs / "tasks.md", docs / "leaderboard.md"] + ([docs / CURVES_PNG] if curves else [])
