"""``railgym benchmark``: seeds, held-out evaluation, learning curve and table of a training
config (:func:`agents.evaluation.benchmark.benchmark`)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from agents.commands.flags import (
    add_parallel_arguments,
    bounded_int,
    check_parallel,
    episodes,
    error_status,
    seed_number,
)
from agents.evaluation import benchmark as benchmark_module
from railgym.progress import quiet
from surrogates.cli_flags import Parser, add_common, add_out


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym benchmark``."""
    parser = Parser(prog="railgym benchmark", description=benchmark_module.__doc__.split("\n\n")[0])
    parser.add_argument("config", help="agents.training.train config: YAML file or packaged name")
    parser.add_argument("--seeds", type=bounded_int(1, 1000), default=3, help="training seeds")
    parser.add_argument(
        "--seed",
        type=seed_number,
        default=None,
        help="first training seed (then +1, +2, ...); default: the config's seed",
    )
    parser.add_argument("--timesteps", type=bounded_int(1), help="override n_timesteps")
    parser.add_argument("--episodes", type=episodes, default=10, help="held-out episodes per case")
    add_out(
        parser,
        "output folder (default: runs/benchmark_<config-stem>/)",
        overwrite="write into a non-empty -o/--out folder",
    )
    add_parallel_arguments(parser, "", "the seeds", "the numbers do")
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``railgym benchmark``; returns the
    exit status (2: user error)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        check_parallel(args)
        with quiet(args.quiet):
            out = benchmark_module.benchmark(
                args.config,
                args.seeds,
                args.workers,
                args.timesteps,
                args.episodes,
                args.out,
                args.overwrite,
                args.seed,
                args.address,
            )
    except Exception as err:
        return error_status(parser.prog, err, args.debug)
    print(f"results.csv, learning_curve.png and table.md in {out}/")
    return 0
