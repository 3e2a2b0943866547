"""``railgym leaderboard``: the benchmark table of the tasks of :mod:`railgym.tasks`.

    railgym leaderboard [--task T ...] [--format md|csv|json] [--results DIR]
    railgym leaderboard --list
    railgym leaderboard --quick [--results DIR]
    railgym leaderboard run --task T --algo {ppo,sac,td3} --seeds N [--steps S]
                            [--residual CONTROLLER]
    railgym leaderboard run --task T --policy PATH_OR_CONTROLLER [--name NAME]
    railgym leaderboard references [--task T ...] [--quick]
    railgym leaderboard docs [--results DIR]

The table is read from the stored entries (``--results``, default the shipped ones in
``agents/leaderboard/results``); ``run`` adds an entry (a training run over seeds, plain or
residual on one of the task's classical controllers, or an existing policy: an SB3 ``.zip``
with its manifest, or a classical controller's name, i.e. the controller wrapped as a policy)
with its provenance; ``references`` computes the passive
and bound values of the score (:mod:`agents.leaderboard.bounds`) into
``railgym/data/task_references.json``; ``docs`` writes ``docs/tasks.md`` and
``docs/leaderboard.md``. ``--quick`` (a smoke test, minutes on one core) stores every task's
baselines and a short PPO run on ``bogie-active`` (2 seeds) under ``--results`` and prints
the table.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from agents.commands.flags import error_status, one_line_warnings
from agents.leaderboard.results import FORMATS, RESULTS_DIR, format_table, load_entries, table_rows
from railgym import _checks as val
from railgym.progress import quiet
from railgym.tasks import TASKS
from surrogates.cli_flags import Parser, add_common

__all__ = ["QUICK", "SUBCOMMANDS", "build_parser", "main"]

PROG = "railgym leaderboard"
#: the learned part of ``--quick``: task, algorithm, seeds, env steps per seed
QUICK = ("bogie-active", "ppo", 2, 8192)
ROOT = Path(__file__).resolve().parents[2]
SUBCOMMANDS = ("run", "references", "docs")


def _tasks(parser: argparse.ArgumentParser, many: bool) -> None:
    parser.add_argument(
        "--task",
        nargs="+" if many else None,
        choices=list(TASKS),
        metavar="TASK",
        required=not many,
        help=f"task{'s' if many else ''} (railgym leaderboard --list): {', '.join(TASKS)}",
    )


def _results(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--results",
        type=Path,
        help="folder of the entries (<task>/<name>.json); default: the shipped ones "
        "(agents/leaderboard/results)",
    )


def _residuals() -> dict[str, tuple[str, ...]]:
    """Task → the classical controllers a residual agent of it can correct."""
    from agents.leaderboard.run import residual_controllers

    return {name: residual_controllers(task) for name, task in TASKS.items()}


def build_parser() -> argparse.ArgumentParser:
    """The table's parser; :func:`subcommand_parser` has those of ``run``, ``references`` and
    ``docs`` (``railgym leaderboard SUB --help``)."""
    p = Parser(prog=PROG, description=__doc__.split("\n\n")[0])
    _tasks(p, True)
    p.add_argument("--format", choices=FORMATS, default="md", help="table format")
    p.add_argument("--list", action="store_true", help="name the tasks and exit")
    p.add_argument(
        "--quick",
        action="store_true",
        help="smoke test: the baselines of every task and a short PPO run into --results "
        "(required), then the table",
    )
    _results(p)
    add_common(p)
    return p


def subcommand_parser(name: str) -> argparse.ArgumentParser:
    """The parser of ``railgym leaderboard name`` (one of :data:`SUBCOMMANDS`)."""
    p = Parser(prog=f"{PROG} {name}")
    if name == "run":
        p.description = (
            "Add an entry: a training run over seeds (plain or residual) or an existing policy."
        )
        _tasks(p, False)
        what = p.add_mutually_exclusive_group(required=True)
        what.add_argument("--algo", choices=("ppo", "sac", "td3"), help="train this algorithm")
        what.add_argument(
            "--policy",
            help="an SB3 .zip (with its manifest.json) or a classical controller's name of the "
            "task's env, evaluated as it is",
        )
        p.add_argument(
            "--residual",
            metavar="CONTROLLER",
            help="with --algo: train the agent as a residual on this classical controller of "
            "the task (its action added to the controller's); the entry is "
            "ALGO-residual-CONTROLLER. Controllers: "
            + "; ".join(f"{t}: {', '.join(c) or 'none'}" for t, c in _residuals().items()),
        )
        p.add_argument("--seeds", type=int, default=5, help="training seeds 0 … N−1")
        p.add_argument("--steps", type=int, default=200_000, help="env steps per seed")
        p.add_argument(
            "--name",
            help="entry name (default: the algorithm, ALGO-residual-CONTROLLER, or the policy "
            "name)",
        )
        p.add_argument("--runs", type=Path, default=Path("runs/leaderboard"), help="run folders")
        p.add_argument("--trust", action="store_true", help="as for railgym evaluate")
        _results(p)
    elif name == "references":
        p.description = "Compute the passive and bound values of the tasks' scores."
        _tasks(p, True)
        p.add_argument("--quick", action="store_true", help="no bound search: the baselines' best")
        p.add_argument(
            "-o",
            "--out",
            type=Path,
            help="the JSON file (other tasks in it are kept); default: "
            "railgym/data/task_references.json of the source tree",
        )
    else:
        p.description = "Write docs/tasks.md and docs/leaderboard.md from the stored entries."
        _results(p)
        p.add_argument(
            "-o", "--out", type=Path, help="docs folder (default: docs/ of the source tree)"
        )
    add_common(p)
    return p


def _table(args: argparse.Namespace) -> int:
    if args.list:
        for task in TASKS.values():
            print(f"{task.name}: {task.description} ({task.env_id})")
        return 0
    if args.quick:
        _quick(args.results)
    entries = load_entries(args.results or RESULTS_DIR, args.task)
    if not entries:
        raise val.FieldError("results", f"{args.results} holds no entries (TASK/NAME.json)")
    print(format_table(table_rows(entries), args.format))
    return 0


def _quick(results: Path | None) -> None:
    """The ``--quick`` set into ``results``."""
    from agents.leaderboard.run import baseline_entry, learned_entry

    if results is None:
        raise ValueError("--quick writes its entries into --results: give a folder of your own")
    t0 = time.perf_counter()
    for name, task in TASKS.items():
        for baseline in task.baselines:
            baseline_entry(name, baseline, Path(results))
    quick, algo, seeds, steps = QUICK
    learned_entry(quick, algo, seeds, steps, Path(results) / "runs", results=Path(results))
    print(f"quick set: {time.perf_counter() - t0:.0f} s", file=sys.stderr)


def _run(args: argparse.Namespace) -> int:
    from agents.leaderboard.run import check_residual, learned_entry, policy_entry

    if args.residual is not None:
        if args.policy is not None:
            raise val.FieldError("--residual", "goes with --algo (it trains), not --policy")
        check_residual(TASKS[args.task], args.residual, "--residual")
    results = args.results or RESULTS_DIR
    if args.policy is not None:
        entry = policy_entry(args.task, args.policy, args.name, results=results, trust=args.trust)
    else:
        entry = learned_entry(
            args.task,
            args.algo,
            args.seeds,
            args.steps,
            args.runs,
            args.name,
            results,
            args.residual,
        )
    print(format_table(table_rows([entry])))
    return 0


def _references(args: argparse.Namespace) -> int:
    from agents.leaderboard.bounds import reference_values

    out: Path = args.out or ROOT / "railgym" / "data" / "task_references.json"
    data = json.loads(out.read_text()) if out.is_file() else {}
    for name in args.task or TASKS:
        data[name] = reference_values(name, args.quick)
        out.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    print(f"reference values written to {out}")
    return 0


def _docs(args: argparse.Namespace) -> int:
    from agents.leaderboard.docs import write_docs

    for path in write_docs(load_entries(args.results or RESULTS_DIR), args.out or ROOT / "docs"):
        print(f"wrote {path}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``railgym leaderboard``; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in SUBCOMMANDS:
        parser = subcommand_parser(argv[0])
        command = {"run": _run, "references": _references, "docs": _docs}[argv[0]]
        args = parser.parse_args(argv[1:])
    else:
        parser, command = build_parser(), _table
        args = parser.parse_args(argv)
    try:
        with quiet(args.quiet), one_line_warnings(parser.prog):
            return command(args)
    except Exception as err:
        return error_status(parser.prog, err, args.debug)


if __name__ == "__main__":
    sys.exit(main())
