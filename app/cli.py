"""The `avhear` command line: one sub-command per module in :mod:`app.commands`.

Each command module exposes ``add_parser(subparsers)``, which adds its parser and sets ``func`` (called with the
parsed arguments, returning an exit status). Adding a command is adding its module name to ``COMMAND_MODULES``.
"""
from __future__ import annotations

import argparse
import importlib
import logging
import os
import signal
import sys
import threading
import warnings
from collections.abc import Sequence

from app.errors import UserError

# OpenCV and its FFmpeg back-end print their own warnings (a camera index that does not exist, a codec's notes) to the
# terminal; the command line reports what matters itself. Set before anything imports cv2; a user's setting wins.
os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")

COMMAND_MODULES: tuple[str, ...] = (
    "app.commands.eval",
    "app.commands.calibrate",
    "app.commands.simulate",
    "app.commands.run",
    "app.commands.record",
    "app.commands.transcribe",
    "app.commands.sensors",
    "app.commands.devices",
)


def _version() -> str:
    """The installed distribution's version (pyproject.toml's), or "unknown" when avhear runs uninstalled."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("avhear")
    except PackageNotFoundError:
        return "unknown"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="avhear",
        description="Vision-guided robot hearing: who is there, where, and who is speaking.",
    )
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)")
    parser.add_argument("--version", action="version", version=f"avhear {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_parser(sub)
    _every_command(parser)
    return parser


def _every_command(parser: argparse.ArgumentParser) -> None:
    """Each (sub-)command's parser takes ``-v`` too, and knows itself (``_parser``: its own usage for a mistake)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for command in set(action.choices.values()):
                command.add_argument("-v", "--verbose", action="count", default=argparse.SUPPRESS,
                                     help="more log output (-vv for debug)")
                command.set_defaults(_parser=command)
                _every_command(command)


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; returns its exit status: 0, 2 for a user's mistake (one line, no traceback), 130 when
    interrupted. Called as the console script (``argv`` None), it ends the process itself when a Rerun viewer
    stopped answering, since Rerun would then block the interpreter's exit for ever."""
    if argv is None and threading.current_thread() is threading.main_thread():
        # SIGTERM stops a command as Ctrl-C does (a command that writes installs its own handler meanwhile)
        signal.signal(signal.SIGTERM, _interrupt)
    try:
        status = _main(argv)
    except KeyboardInterrupt:  # also while the command modules are still being imported
        print("avhear: interrupted", file=sys.stderr)
        status = 130
    if argv is None and "app.console.viewer" in sys.modules and sys.modules["app.console.viewer"].viewer_abandoned():
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)
    return status


def _warning_as_a_log_line(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                            file: object = None, line: str | None = None) -> None:
    """A Python warning as one log line, without its source line: a fit that stopped at its iteration limit
    (avcore.mixture.ConvergenceWarning) is a detail of the method (-vv shows it); any other a warning."""
    logger = logging.getLogger(category.__module__)
    level = logging.DEBUG if category.__name__ == "ConvergenceWarning" else logging.WARNING
    logger.log(level, "%s: %s", category.__name__, message)


def _interrupt(signum: int, _frame: object) -> None:
    raise KeyboardInterrupt


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # said by the command's own parser, with its usage, not the top level's
        getattr(args, "_parser", parser).error(f"unrecognized arguments: {' '.join(unknown)}")
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    warnings.showwarning = _warning_as_a_log_line
    try:
        return int(args.func(args) or 0)
    except UserError as exc:
        print(f"avhear: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
