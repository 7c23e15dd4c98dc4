"""A stage of the pipeline in a child process of its own, fed through its standard input and answering on its standard
output.

Why: the ITDs' and the voices' arithmetic is thousands of small numpy steps a second, each of which takes and gives
back the interpreter's lock; in threads beside vision, the fusion and Rerun they held the others up (measured in
docs/experiments.md, twentieth session). Pocketsphinx holds the lock while it decodes.

The child is ``python -m app.child_process MODULE:FUNCTION``: only what the stage needs is imported (not the
parent's main module, as multiprocessing's spawn would), and the stage's classes keep their modules' names for
pickle. It has the directory that holds ``app/`` on its path and BLAS on one thread (small matrices). Messages are
pickled tuples behind their length (4 bytes, little-endian), on the child's standard input and output, which work
alike on Linux, macOS and Windows; whatever the stage prints goes to the standard error. The child answers
``("error", traceback)`` when it fails; it ignores SIGINT and SIGTERM (a terminal's Ctrl-C and a service manager's
stop reach the whole process group: the parent stops the pipeline and ends the stage, so that nothing is lost), and
the end of its input is its end (a parent that closed it, or died).

A stage that ended cleanly (:meth:`ChildProcess.release`: its loop returned on ``("end",)`` and nothing of it is
left unread) waits for its next options, and :meth:`ChildProcess.start` hands it to the next run of the same stage
in this process: an evaluation runs dozens of pipelines, the test suite hundreds, and each child's start imports
Python, numpy and scipy's FFT again. A stage that failed, or was cut short, is closed instead.
"""
from __future__ import annotations

import atexit
import importlib
import os
import pickle
import signal
import struct
import subprocess
import sys
import threading
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

__all__ = ["ChildProcess", "ChildProcessFailed", "Inbox", "Outbox", "Stage"]

_ROOT = Path(__file__).resolve().parents[1]  # the directory that holds app/ and avcore/


class ChildProcessFailed(RuntimeError):
    """A stage's process failed (``reason``: its exception's last line, ``"Type: message"``), or ended before it said
    it was done (``reason`` None)."""

    def __init__(self, message: str, reason: str | None = None) -> None:
        super().__init__(message)
        self.reason = reason


def _write(stream: BinaryIO, message: tuple) -> None:
    data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(struct.pack("<I", len(data)) + data)
    stream.flush()


def _read(stream: BinaryIO) -> Any:
    """The next message; None at the end of the stream."""
    head = stream.read(4)
    if len(head) < 4:
        return None
    (size,) = struct.unpack("<I", head)
    data = stream.read(size)
    return pickle.loads(data) if len(data) == size else None


_IDLE: dict[str, list[ChildProcess]] = {}  # loop -> children whose last run ended cleanly, waiting for options
_IDLE_LOCK = threading.Lock()
_IDLE_MAX = 2  # kept per stage


class ChildProcess:
    """``loop`` (``"module:function"``: the function takes an :class:`Inbox`, an :class:`Outbox` and ``options``,
    which it gets as the first message, ``("init", options)``; a loop that can be handed on returns on ``("end",)``)
    in a child process; ``name`` says which stage in
    errors. :meth:`send` may wait while the child's input is full, and
    :meth:`receive` waits for an answer: a parent that does both at once does them in two threads."""

    @classmethod
    def start(cls, loop: str, name: str, **options: Any) -> ChildProcess:
        """A child for ``loop`` given ``options``: one released by an earlier run of the stage, or a new one."""
        with _IDLE_LOCK:
            idle = _IDLE.get(loop, [])
            while idle:
                child = idle.pop()
                try:
                    if child.proc.poll() is None:
                        child.send(("init", options))
                        child.name = name
                        return child
                except ChildProcessFailed:  # it ended while it waited: a new one instead
                    pass
                child.close()
        return cls(loop, name, **options)

    def __init__(self, loop: str, name: str, **options: Any) -> None:
        self.name, self.loop = name, loop
        self.failed = False  # it said it failed, or ended: never handed on
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(_ROOT), env.get("PYTHONPATH", "")) if p)
        for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
            env.setdefault(var, "1")
        self.proc = subprocess.Popen([sys.executable, "-m", "app.child_process", loop], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, env=env)
        self.send(("init", options))

    def send(self, message: tuple) -> None:
        try:
            _write(self.proc.stdin, message)  # type: ignore[arg-type]
        except (OSError, ValueError) as exc:  # a broken pipe (the child is gone), or an input already closed
            raise self._ended("while it was being fed") from exc

    def receive(self) -> tuple:
        """The child's next answer, when it comes. Raises :class:`ChildProcessFailed` with the child's traceback
        when it failed, or when it ended without answering."""
        try:
            message = _read(self.proc.stdout)  # type: ignore[arg-type]
        except (OSError, ValueError, EOFError, pickle.UnpicklingError) as exc:
            raise self._ended("before its last answer") from exc
        if message is None:
            raise self._ended("before its last answer")
        if message[0] == "error":
            self.failed = True
            raise ChildProcessFailed(f"the {self.name} process failed:\n{message[1]}",
                                     message[1].strip().splitlines()[-1])
        return message

    def release(self) -> None:
        """The stage ended cleanly and nothing of it is unread: the child ends its loop and waits, for
        :meth:`start`, for its next options (closed when enough wait already)."""
        if self.failed:
            self.close()
            return
        try:
            self.send(("end",))
        except ChildProcessFailed:
            self.close()
            return
        with _IDLE_LOCK:
            idle = _IDLE.setdefault(self.loop, [])
            if len(idle) < _IDLE_MAX:
                idle.append(self)
                return
        self.close()

    def close_inbox(self) -> None:
        """The end of the child's input: it ends once it has read what came before."""
        try:
            self.proc.stdin.close()  # type: ignore[union-attr]
        except OSError:  # a broken pipe on the last flush: the child is gone already
            pass

    def close(self, timeout_s: float = 5.0) -> None:
        """End the child's input and wait for it (killed after ``timeout_s``)."""
        self.close_inbox()
        try:
            self.proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.proc.stdout.close()  # type: ignore[union-attr]

    def _ended(self, when: str) -> ChildProcessFailed:
        self.failed = True
        try:
            status = self.proc.wait(5)
        except subprocess.TimeoutExpired:
            status = None
        return ChildProcessFailed(f"the {self.name} process ended (exit status {status}) {when}")


class Stage:
    """A stage's side in the pipeline: its :class:`ChildProcess` (``loop`` and ``name`` as the subclass says, the
    options as given), handed on to the next run by :meth:`release` once its run ended cleanly, else closed."""

    loop: str
    name: str

    def __init__(self, **options: Any) -> None:
        self.child = ChildProcess.start(self.loop, self.name, **options)

    def release(self) -> None:
        self.child.release()

    def close(self) -> None:
        self.child.close()


@atexit.register
def _close_idle() -> None:
    with _IDLE_LOCK:
        children = [c for idle in _IDLE.values() for c in idle]
        _IDLE.clear()
    for child in children:
        child.close(1.0)


class Inbox:
    """The child's side of its input: :meth:`recv` raises EOFError at its end."""

    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream

    def recv(self) -> Any:
        message = _read(self._stream)
        if message is None:
            raise EOFError
        return message


class Outbox:
    """The child's side of its answers."""

    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream

    def send(self, message: tuple) -> None:
        _write(self._stream, message)


def serve(loop: Callable[..., Any]) -> int:
    """The child's side: ``loop(inbox, outbox, **options)`` on the standard input and output for each
    ``("init", options)`` (a loop returns on ``("end",)``); its exception goes to the parent as ``("error",
    traceback)``. Exit status 0 when its input ended, 1 when it failed."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    inbox = Inbox(os.fdopen(os.dup(0), "rb"))
    outbox = Outbox(os.fdopen(os.dup(1), "wb"))
    os.dup2(2, 1)  # what the stage prints goes to the standard error, not into the answers
    sys.stdout = sys.stderr
    try:
        while True:  # a run of the stage, then (released) the next one's options
            kind, options = inbox.recv()
            if kind != "init":
                raise ValueError(f"the first message must be init, got {kind!r}")
            loop(inbox, outbox, **options)
    except EOFError:  # the parent closed the input, or is gone
        return 0
    except Exception:  # noqa: BLE001 -- the parent says what failed
        try:
            outbox.send(("error", traceback.format_exc()))
        except OSError:
            pass
        return 1


def main(argv: list[str]) -> int:
    """``MODULE:FUNCTION``: :func:`serve` the function."""
    module, _, function = argv[0].partition(":")
    return serve(getattr(importlib.import_module(module), function))


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
