"""The console in a process of its own (:mod:`app.child_process`): the :class:`app.console.Console` and its Rerun
recording (:class:`app.console.viewer.ViewerSession`) live in the child, and the pipeline hands each result's
:class:`app.console.ConsoleFrame` over without waiting.

Why: Rerun's Python side builds Arrow arrays for a dozen ``rr.log`` calls a result, most of them holding the
interpreter's lock, which in the fusion thread held up the pipeline's other threads (measured in
docs/experiments.md, twenty-first session). In a child of its own it costs the pipeline's threads a pickle of the
frame.

The protocol: the options first (the viewer target, the rig, the microphones, the array), answered ``("ready",)``
or ``("user-error", message)`` (a viewer that does not take the connection); then ``("frame", ConsoleFrame)`` and
``("words", [Words, ...])``; ``("close",)`` flushes and closes the recording and is answered ``("closed", parts,
abandoned)``: the .rrd files written (a long run's parts start in the child) and whether a viewer that stopped
answering was given up on (that child is not handed on: Rerun's exit hook would wait for it). The web viewer of
``--serve`` is the parent's (:class:`app.console.viewer.WebViewer`): it serves until the user's Ctrl-C, which the
child ignores.
"""
from __future__ import annotations

import logging
import queue
import threading
from dataclasses import replace
from pathlib import Path
from typing import Any

from app.child_process import ChildProcessFailed, Inbox, Outbox, Stage
from app.console.viewer import ViewerSession, ViewerTarget, WebViewer
from app.errors import UserError
from app.queues import DropOldestQueue

__all__ = ["ConsoleProcess", "serve_console"]

log = logging.getLogger(__name__)


class ConsoleProcess(Stage):
    """The console for ``target`` (which logs: a file, a viewer, the web viewer) in a child process.

    A feeding thread sends the frames. Live (``backpressure`` False), :meth:`log` never waits: when the child falls
    behind by ``queue_size`` frames the oldest are dropped and counted (:attr:`dropped`). A replay as fast as
    possible (``backpressure``) waits for room instead, so that its recording holds every result, as the console in
    the pipeline's thread wrote it. Words are never dropped. A child
    that fails during the run is said once on the log and counted (:attr:`lost`); the pipeline goes on without its
    console. :meth:`finish` flushes the recording (:attr:`parts` then names its files), :meth:`close` ends it all
    and, with ``keep_serving``, serves the web viewer until Ctrl-C.
    """

    loop, name = "app.console.process:serve_console", "console"

    def __init__(self, target: ViewerTarget, rig: Any, mics: Any, array: Any = None, *, queue_size: int = 8,
                 backpressure: bool = False) -> None:
        if not target.logs:
            raise ValueError("a console process needs a target that logs (save, connect, spawn or serve)")
        self.web = WebViewer(target) if target.serve else None
        child_target = replace(target, serve=False, connect=self.web.grpc_url) if self.web is not None else target
        try:
            super().__init__(target=child_target, several_pairs=array is not None and array.n_pairs > 1, rig=rig,
                             mics=mics, array=array)
            answer = self.child.receive()
        except BaseException:
            self._stop_web()
            raise
        if answer[0] == "user-error":
            self.child.close()
            self._stop_web()
            raise UserError(answer[1])
        self.parts: list[Path] = [target.save] if target.save is not None else []
        self.backpressure = backpressure
        self.dropped = 0
        self.lost = 0  # frames not logged because the child had failed
        self._failed: ChildProcessFailed | None = None
        self._frames: DropOldestQueue[Any] = DropOldestQueue(queue_size, "console")
        self._words: queue.SimpleQueue[list] = queue.SimpleQueue()
        self._stop = threading.Event()  # finish() was called: the feeder ends once the queue is empty
        self._feeder = threading.Thread(target=self._feed, name="avhear-console-feed", daemon=True)
        self._feeder.start()

    def log(self, frame: Any) -> None:
        """Hand one :class:`app.console.ConsoleFrame` over (with ``backpressure``, once there is room)."""
        while self.backpressure and not self._frames.wait_for_room(0.1) and self._feeder.is_alive():
            pass
        self._frames.put(frame)

    def log_words(self, words: list) -> None:
        """Words (:class:`app.speech.transcriber.Words`) to show from the next frame on; never waits."""
        self._words.put(list(words))

    def _feed(self) -> None:
        while True:
            frame = self._frames.get(timeout=0.1)
            words: list = []
            while not self._words.empty():
                words += self._words.get()
            if frame is None and not words:
                if self._stop.is_set():
                    return
                continue
            if self._failed is not None:
                self.lost += frame is not None
                continue
            try:
                if words:
                    self.child.send(("words", words))
                if frame is not None:
                    self.child.send(("frame", frame))
            except ChildProcessFailed as exc:
                self._failed = exc
                self.lost += frame is not None
                log.warning("the console's process ended during the run; the run goes on without its console (%s)",
                            exc)

    def finish(self) -> None:
        """Send what is queued, then flush and close the recording; :attr:`parts` names the files written."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._feeder.join()
        self.dropped = self._frames.dropped
        if self._failed is not None:
            self.child.close()
            return
        try:
            self.child.send(("close",))
            _, parts, abandoned = self.child.receive()
        except ChildProcessFailed as exc:
            log.warning("the console's process failed at its end: %s", exc)
            self.child.close()
            return
        self.parts = [Path(p) for p in parts]
        if abandoned:
            self.child.close(timeout_s=1.0)
        else:
            self.child.release()

    def close(self, *, keep_serving: bool = False) -> None:
        """:meth:`finish`, then (``--serve``) keep serving until Ctrl-C when ``keep_serving``, and stop the server."""
        self.finish()
        if self.web is not None and keep_serving:
            self.web.keep_serving()
        self._stop_web()

    def _stop_web(self) -> None:
        if self.web is not None:
            self.web.stop()


def serve_console(inbox: Inbox, outbox: Outbox, *, target: ViewerTarget, several_pairs: bool, rig: Any, mics: Any,
                  array: Any) -> None:
    """The child's side: a :class:`ViewerSession` and a :class:`~app.console.Console` on it, the frames logged as
    they come and the .rrd parts started when due."""
    try:
        session = ViewerSession(target, several_pairs=several_pairs)
    except UserError as exc:
        outbox.send(("user-error", str(exc)))
        _wait_for_end(inbox)
        return
    from app.console import Console

    console = Console(rig, mics, recording=session.recording, array=array)
    outbox.send(("ready",))
    while True:
        message = inbox.recv()
        kind = message[0]
        if kind == "frame":
            if session.part_due():
                session.next_part()
                console.new_part()
            console.log(message[1])
        elif kind == "words":
            console.log_words(message[1])
        elif kind == "close":
            session.close(keep_serving=False)
            outbox.send(("closed", [str(p) for p in session.parts], session.abandoned))
            _wait_for_end(inbox)
            return
        elif kind == "end":
            session.close(keep_serving=False)
            return
        else:
            raise ValueError(f"unknown message {kind!r}")


def _wait_for_end(inbox: Inbox) -> None:
    while inbox.recv()[0] != "end":
        pass
