"""``railgym crash-report``: the crash tables of ``docs/envs/crash_baselines.md`` and the
surrogate-vs-reference matrix (``--matrix``), computed by :mod:`agents.evaluation.crash_report`."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from agents.commands.flags import error_status, one_line_warnings, with_policy_kwargs
from agents.controllers.crash_baselines import search_constant
from agents.controllers.registry import BASELINES, CRASH_ID, crash_factories
from agents.evaluation import crash_report
from agents.evaluation.crash_matrix import constant_action_cases, matrix_table, random_action_cases
from agents.evaluation.crash_report import (
    FITS,
    SPEEDS_KMH,
    baseline_rows,
    baseline_table,
    envelope_header,
    envelope_rows,
    envelope_table,
    error_table,
    surrogate_error_rows,
    train_line,
)
from agents.policies.loading import load_policy
from railgym.progress import quiet
from surrogates.cli_flags import Parser, add_common


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym crash-report``."""
    parser = Parser(prog="railgym crash-report", description=crash_report.__doc__.split("\n\n")[0])
    parser.add_argument(
        "policy",
        nargs="*",
        metavar="POLICY_ZIP",
        help="--envelope: trained policies (SB3 .zip written by railgym train) beside the "
        "baselines",
    )
    parser.add_argument(
        "--scenario",
        help="crash scenario (name or YAML) of every table: its cars, zones and envelope "
        "(default: paper; --matrix, --envelope: envelope, or the policies' own)",
    )
    parser.add_argument(
        "--matrix",
        action="store_true",
        help="only the surrogate-vs-reference matrix of the env's default elements over speeds "
        "x payloads x constant actions and random action sequences (docs/envs/crash.md)",
    )
    parser.add_argument(
        "--envelope",
        action="store_true",
        help="only the held-out envelope evaluation on the reference (speeds × payloads) of "
        "the baselines and the POLICY_ZIP files",
    )
    parser.add_argument("--trust", action="store_true", help="as for railgym evaluate")
    add_common(parser)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Print the markdown tables of ``docs/envs/crash_baselines.md``."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.policy and not args.envelope:
        parser.error("POLICY_ZIP: only with --envelope")
    if args.matrix and args.envelope:
        parser.error("--matrix, --envelope: each prints only its own tables; give one of them")
    try:
        with quiet(args.quiet), one_line_warnings(parser.prog):
            return _report(args)
    except Exception as err:
        return error_status(parser.prog, err, args.debug)


def _report(args: argparse.Namespace) -> int:
    """The tables ``args`` ask for, printed."""
    if args.envelope:
        policies = crash_factories(BASELINES[CRASH_ID])
        env_kwargs: dict[str, Any] = {} if args.scenario is None else {"scenario": args.scenario}
        for path in args.policy:
            factory, trained, label = load_policy(path, CRASH_ID, args.trust)
            env_kwargs = with_policy_kwargs(trained, env_kwargs, label)
            policies[label] = factory
        rows = envelope_rows(policies, env_kwargs)
        print(envelope_header(rows))
        print(envelope_table(rows))
        return 0
    if args.matrix:
        scenario = args.scenario or "envelope"
        print(train_line(scenario, "surrogate against reference"))
        cases = constant_action_cases(scenario=scenario), random_action_cases(scenario=scenario)
        print(matrix_table(*cases))
        return 0
    scenario = args.scenario or "paper"
    sweep = f"the tables' speeds {SPEEDS_KMH[0]:g}–{SPEEDS_KMH[-1]:g} km/h"
    print(train_line(scenario, f"{sweep} (not its own speed_kmh)") + "\n")
    speeds = np.array(SPEEDS_KMH) / 3.6
    levels = np.linspace(-1, 1, 9)
    res = search_constant(speeds, levels=levels, backend="reference", scenario=scenario)
    print(f"best constant action {res.best.tolist()}, mean worst-car peak {res.score:.3f} g\n")
    print(baseline_table(baseline_rows(scenario=scenario)))
    for fit in FITS:
        print(f"\nsurrogate fitted {fit}\n")
        print(error_table(surrogate_error_rows(scenario=scenario, fit=fit)))
    return 0
