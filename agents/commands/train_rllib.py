"""The arguments of ``railgym train-rllib``, in a module of their own:
:mod:`agents.training.train_rllib` (its ``main``) needs the ``rllib`` extra to be imported, its
help and ``docs/cli.md`` do not."""

from __future__ import annotations

import argparse

from agents.commands.flags import bounded_int
from surrogates.cli_flags import Parser, add_common, add_out, add_seed

__all__ = ["MAX_ITERATIONS", "build_parser"]

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
