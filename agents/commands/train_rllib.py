"""``railgym train-rllib``: train RLlib PPO from a config
(:func:`agents.training.train_rllib.train_rllib`). :mod:`agents.training.train_rllib` needs the
``rllib`` extra to be imported, this parser, its help and ``docs/cli.md`` do not."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from agents._extras import MissingExtraError, report_missing
from agents.commands.flags import bounded_int, error_status
from agents.training.run_files import read_run, speed_text
from railgym.progress import quiet
from surrogates.cli_flags import Parser, add_common, add_out, add_seed

__all__ = ["MAX_ITERATIONS", "build_parser", "main"]

#: most training iterations of one run (each thousands of env steps: weeks of training)
MAX_ITERATIONS = 10**6


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym train-rllib``."""
    parser = Parser(
        prog="railgym train-rllib",
        description="Train PPO with RLlib (new API stack) on the native railgym vector envs "
        "(the rllib extra, in its own virtual environment: docs/scaling.md).",
    )
    parser.add_argument(
        "config", help="YAML file with trainer: rllib, or the name of a packaged config"
    )
    add_out(
        parser,
        "output folder (default: runs/<config-stem>/ in the working folder)",
        overwrite="write into an existing non-empty -o/--out folder",
    )
    parser.add_argument(
        "--iterations",
        type=bounded_int(1, MAX_ITERATIONS),
        default=None,
        help="override the config's iterations",
    )
    add_seed(parser, "override the config's seed", default=None)
    parser.add_argument(
        "--address", default=None, help="join the Ray cluster at HOST:PORT (or 'auto')"
    )
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``railgym train-rllib``; returns the exit status (2: user error or a
    missing ``rllib`` extra)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        from agents.training.train_rllib import train_rllib

        with quiet(args.quiet):
            out = train_rllib(
                args.config, args.out, args.iterations, args.seed, args.address, args.overwrite
            )
    except MissingExtraError as err:
        if args.debug:
            raise
        return report_missing(err, parser.prog, "RLlib training")
    except Exception as err:
        return error_status(parser.prog, err, args.debug)
    run = read_run(out)
    reward = run["eval"]["mean_reward"]
    print(f"{speed_text(run)}; evaluation reward {reward:.4g}; checkpoint, logs in {out}/")
    return 0
