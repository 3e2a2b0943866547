"""``railgym pretrained``: ship the best seed of a ``railgym benchmark`` folder as a pretrained
policy (:func:`agents.policies.pretrained.install`)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from agents.commands.flags import error_status
from agents.policies import pretrained
from agents.policies.pretrained import PRETRAINED, install
from surrogates.cli_flags import Parser, add_common


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym pretrained``."""
    parser = Parser(prog="railgym pretrained", description=pretrained.__doc__.split("\n\n")[0])
    parser.add_argument(
        "name",
        choices=sorted(PRETRAINED),
        metavar="NAME",
        help=f"the pretrained policy: {', '.join(sorted(PRETRAINED))}",
    )
    parser.add_argument("benchmark_dir", type=Path, help="output folder of railgym benchmark")
    parser.add_argument("--overwrite", action="store_true", help="replace a shipped policy")
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """``railgym pretrained NAME BENCHMARK_DIR [--overwrite]``."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        dst = install(args.name, args.benchmark_dir, args.overwrite)
    except Exception as err:
        return error_status(parser.prog, err, args.debug)
    print(f"{args.name}: {dst}")
    return 0
