"""The `avhear` command line: one sub-command per module in :mod:`app.commands`.

Each command module exposes ``add_parser(subparsers)``, which adds its parser and sets ``func`` (called with the
parsed arguments, returning an exit status). Adding a command is adding its module name to ``COMMAND_MODULES``.
"""
from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence

from app.errors import UserError

COMMAND_MODULES: tuple[str, ...] = (
    "app.commands.eval",
    "app.commands.calibrate",
    "app.commands.simulate",
    "app.commands.run",
    "app.commands.record",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="avhear",
        description="Vision-guided robot hearing: who is there, where, and who is speaking.",
    )
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(args.func(args) or 0)
    except UserError as exc:
        print(f"avhear: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("avhear: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
