"""``railgym env-tables [--check]``: rewrite (or, with ``--check``, only list) the argument
tables of ``docs/envs/*.md`` that differ from the env declarations
(:func:`railgym.envs.params.update_docs`); a maintainer's command of a source checkout."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from railgym.envs.params import update_docs
from surrogates.cli_flags import Parser, add_common

#: the env pages with generated argument tables, in a source checkout
DOCS = Path(__file__).resolve().parents[2] / "docs" / "envs"


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym env-tables``."""
    parser = Parser(
        prog="railgym env-tables",
        description="Rewrite the argument tables of docs/envs/*.md from the env declarations "
        "(a source checkout's docs).",
    )
    parser.add_argument(
        "--check",
        action="store_true",
        help="only list the stale tables; exit status 1 when there are any",
    )
    add_common(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Rewrite (or list) the stale tables; 1 when ``--check`` finds one, 2 on bad input."""
    parser = build_parser()
    args = parser.parse_args(argv)
    pages = sorted(DOCS.glob("*.md"))
    if not pages:
        parser.error(f"{DOCS}: no env pages there (a source checkout's command)")
    stale = [f"{p.name}: {c}" for p in pages for c in update_docs(p, write=not args.check)]
    for line in stale:
        print(line)
    return 1 if stale and args.check else 0
