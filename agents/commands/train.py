"""``railgym train``: train a stable-baselines3 agent from a config
(:func:`agents.training.train.train`; the ``agents`` extra)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from agents.commands.flags import bounded_int, error_status
from agents.training import train as train_module
from agents.training.run_files import read_run, speed_text
from agents.training.train_config import ALGOS, MAX_TIMESTEPS
from surrogates.cli_flags import Parser, add_common, add_out, add_seed


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym train``."""
    parser = Parser(prog="railgym train", description=train_module.__doc__.split("\n\n")[0])
    parser.add_argument(
        "config", help="YAML file (agents.training.train format), or the name of a packaged config"
    )
    add_out(
        parser,
        "output folder (default: runs/<config-stem>/ in the working folder)",
        overwrite="write into an existing non-empty -o/--out folder",
    )
    parser.add_argument(
        "--timesteps",
        type=bounded_int(1, MAX_TIMESTEPS),
        default=None,
        help="override n_timesteps",
    )
    add_seed(parser, "override the config's seed", default=None)
    parser.add_argument(
        "--algo",
        choices=sorted(ALGOS),
        default=None,
        help="algorithm of an rl-zoo3 hyperparameter file (rl-zoo3's --algo; the "
        "agents.training.train format names it in the file)",
    )
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``railgym train``; returns the exit
    status (2: user error)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        out = train_module.train(
            args.config,
            args.out,
            args.timesteps,
            not args.quiet,
            args.seed,
            args.overwrite,
            args.algo,
        )
    except Exception as err:
        return error_status(parser.prog, err, args.debug)
    run = read_run(out)
    print(
        f"{speed_text(run)}: rollouts {run['rollout_steps_per_s']} steps/s, updates "
        f"{run['update_steps_per_s']} steps/s, evaluations {run['eval_s']} s; "
        f"model, logs and config in {out}/"
    )
    return 0
