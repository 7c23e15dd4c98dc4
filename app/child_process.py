"""A stage of the pipeline in a child process of its own, fed and answered through two OS pipes.

Why: the ITDs' and the voices' arithmetic is thousands of small numpy steps a second, each of which takes and gives
back the interpreter's lock. In threads beside vision, the fusion and Rerun they cost far more CPU and hold the
others up: measured on this 2-core machine (docs/experiments.md, 2026-11-30, twentieth session), the voices' separator took 0.29-0.31
s of CPU a second of NAO's audio in a thread against 0.07 in a process beside the same running pipeline.

The child is ``python -m app.child_process MODULE:FUNCTION`` (only what the stage needs is imported, not the
parent's main module as multiprocessing's spawn would; the stage's classes keep their modules' names, for pickle),
with the directory that holds ``app/`` on its path and BLAS on one thread (small
matrices). Messages are pickled tuples (:class:`multiprocessing.connection.Connection`). The child answers
``("error", traceback)`` when it fails; it ignores SIGINT and SIGTERM (a terminal's Ctrl-C and a service manager's
stop reach the whole process group: the parent stops the pipeline and ends the stage, so that nothing is lost), and
exits when its inbox ends (a parent that died).
"""
from __future__ import annotations

import importlib
import os
import signal
import subprocess
import sys
import traceback
from collections.abc import Callable
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

__all__ = ["ChildProcess", "ChildProcessFailed", "serve"]

_ROOT = Path(__file__).resolve().parents[1]  # the directory that holds app/ and avcore/


class ChildProcessFailed(RuntimeError):
    """A stage's process failed, or ended before it said it was done."""


class ChildProcess:
    """``loop`` (``"module:function"``, see :func:`serve`) in a child process with an inbox and an outbox; ``name``
    says which stage in errors. :meth:`send` may wait
    while the child's inbox is full: a parent that also reads must read in another thread."""

    def __init__(self, loop: str, name: str) -> None:
        self.name = name
        r_in, w_in = os.pipe()
        r_out, w_out = os.pipe()
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(_ROOT), env.get("PYTHONPATH", "")) if p)
        for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
            env.setdefault(var, "1")
        try:
            self.proc = subprocess.Popen([sys.executable, "-m", "app.child_process", loop, str(r_in), str(w_out)],
                                         pass_fds=(r_in, w_out), env=env, stdin=subprocess.DEVNULL)
        except OSError:
            for fd in (w_in, r_out):
                os.close(fd)
            raise
        finally:
            os.close(r_in)
            os.close(w_out)
        self._to = Connection(w_in, readable=False)
        self._from = Connection(r_out, writable=False)

    def send(self, message: tuple) -> None:
        try:
            self._to.send(message)
        except OSError as exc:  # BrokenPipeError among them: the child is gone
            raise self._ended("while it was being fed") from exc

    def receive(self, timeout_s: float | None = None) -> tuple | None:
        """The child's next answer; None when none came within ``timeout_s``. Raises :class:`ChildProcessFailed`
        with the child's traceback when it failed, or when it ended without answering."""
        if timeout_s is not None and not self._from.poll(timeout_s):
            if self.proc.poll() is not None and not self._from.poll(0):
                raise self._ended("before its last answer")
            return None
        try:
            message = self._from.recv()
        except (EOFError, OSError) as exc:
            raise self._ended("before its last answer") from exc
        if message[0] == "error":
            raise ChildProcessFailed(f"the {self.name} process failed:\n{message[1]}")
        return message

    def close_inbox(self) -> None:
        """What the kernel does when the parent dies: the child reads the end of its inbox and exits."""
        self._to.close()

    def close(self, timeout_s: float = 5.0) -> None:
        """Close the pipes and wait for the child (killed after ``timeout_s``)."""
        for conn in (self._to, self._from):
            if not conn.closed:
                conn.close()
        try:
            self.proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()

    def _ended(self, when: str) -> ChildProcessFailed:
        try:
            status = self.proc.wait(5)
        except subprocess.TimeoutExpired:
            status = None
        return ChildProcessFailed(f"the {self.name} process ended (exit status {status}) {when}")


def serve(argv: list[str], loop: Callable[[Connection, Connection], Any]) -> int:
    """The child's side: ``loop(inbox, outbox)`` on the pipes named by ``argv``; its exception goes to the parent as
    ``("error", traceback)``. Exit status 0 when the loop returned or the parent is gone, 1 when it failed."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    inbox = Connection(int(argv[0]), writable=False)
    outbox = Connection(int(argv[1]), readable=False)
    try:
        loop(inbox, outbox)
    except EOFError:  # the parent is gone: nobody to answer
        return 0
    except Exception:  # noqa: BLE001 -- the parent says what failed
        try:
            outbox.send(("error", traceback.format_exc()))
        except OSError:
            pass
        return 1
    return 0


def main(argv: list[str]) -> int:
    """``MODULE:FUNCTION INBOX_FD OUTBOX_FD``: :func:`serve` the function on the pipes."""
    module, _, function = argv[0].partition(":")
    return serve(argv[1:], getattr(importlib.import_module(module), function))


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
