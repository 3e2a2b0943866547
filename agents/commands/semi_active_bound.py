"""``railgym semi-active-bound``: the best open-loop (clairvoyant) damper commands per track
against the semi-active baselines (:func:`agents.evaluation.semi_active_bound.optimise_track`).

    railgym semi-active-bound --track-class 4 5 6 --seed 1000 --seeds 3 --duration 5

A table per track and the median margins per class on stdout, one line per track on stderr
(none with ``--quiet``). Results: docs/results.md, *Semi-active*.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

from agents.commands.flags import (
    add_track_classes,
    bounded_int,
    duration_s,
    episodes,
    error_status,
)
from agents.controllers.registry import ENV_ID
from agents.evaluation.semi_active_bound import DISCARD_S, STARTS, format_results, optimise_track
from railgym.progress import bar, quiet
from railgym.registration import ENVS, env_family
from surrogates.checks import MAX_SEED
from surrogates.cli_flags import Parser, add_common, add_seed

#: most gradient evaluations of one search (``--screen-eval``, ``--max-eval``)
MAX_EVAL = 10_000


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym semi-active-bound``."""
    parser = Parser(
        prog="railgym semi-active-bound",
        description="Best open-loop (clairvoyant) damper commands per track against the "
        "semi-active baselines (reference backend, each class at its maximum speed).",
    )
    add_track_classes(parser, [4, 5, 6])
    add_seed(parser, "track seed of the first track of each class (then +1, +2, ...)", 1000)
    parser.add_argument("--seeds", type=episodes, default=3, help="tracks per class")
    parser.add_argument(
        "--duration",
        type=duration_s,
        default=5.0,
        help=f"s per track, more than the settling time {DISCARD_S:g} s left out of a_w",
    )
    parser.add_argument(
        "--screen-eval",
        type=bounded_int(1, MAX_EVAL),
        default=12,
        help="gradient evaluations of every start",
    )
    parser.add_argument(
        "--max-eval",
        type=bounded_int(1, MAX_EVAL),
        default=50,
        help="gradient evaluations of the best start in all",
    )
    family = env_family(ENV_ID)
    parser.add_argument(
        "--env-id",
        choices=[e for e in ENVS if env_family(e) == family],
        default=ENV_ID,
        metavar="ID",
        help="the registered version of the vertical env whose tracks and step are searched",
    )
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the bound on every (class, seed) and print the tables."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not args.duration > DISCARD_S:
        parser.error(f"--duration must exceed the settling time {DISCARD_S:g} s")
    if args.seed + args.seeds - 1 > MAX_SEED:
        parser.error(f"--seed: the last track's seed must be at most {MAX_SEED} (--seeds)")
    t0 = time.perf_counter()
    seeds = range(args.seed, args.seed + args.seeds)
    cases = [(tc, s) for tc in args.track_class for s in seeds]
    results = []
    try:
        with quiet(args.quiet):
            for tc, s in bar(cases, desc="tracks"):
                r = optimise_track(
                    tc, s, args.duration, STARTS, args.screen_eval, args.max_eval, args.env_id
                )
                if not args.quiet:
                    print(
                        f"class {tc} seed {s}: best {r.a_w['best']:.4f} vs clipped-lqg "
                        f"{r.a_w['clipped-lqg']:.4f} ({r.margin:+.1f} %), {r.wall_s:.0f} s",
                        file=sys.stderr,
                    )
                results.append(r)
    except Exception as err:
        return error_status(parser.prog, err, args.debug)
    print(
        f"{args.env_id}, reference backend, actuator semi-active, {args.duration:g} s per "
        f"track, a_w Wk (m/s², first {DISCARD_S:g} s left out); "
        f"{time.perf_counter() - t0:.0f} s wall"
    )
    print(format_results(results))
    return 0
