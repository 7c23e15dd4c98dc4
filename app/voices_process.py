"""Each person's voice in a process of its own (:mod:`app.child_process`): the pipeline's
:class:`avcore.separation.VoiceSeparator`, fed through its standard input.

The protocol: the separator's arguments first (:class:`app.child_process.ChildProcess`), then ``("audio", stamp,
samples)`` and ``("people", stamp, ids, positions, speaking)`` in the order the pipeline took them, and
``("flush",)``; the child answers ``("chunks", [VoiceChunk, ...])`` whenever chunks are final, after ``flush`` the
flushed ones, then ``("done", frames)``; ``("end",)`` ends the run. The same inputs in the same order give the same
chunks as the separator in a thread: a replay gives the live run's streams.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from app.child_process import Inbox, Outbox, Stage
from avcore.separation import VoiceChunk, VoiceSeparator

__all__ = ["VoicesProcess", "serve_voices"]


class VoicesProcess(Stage):
    """A :class:`~avcore.separation.VoiceSeparator` (the options are its keyword arguments, the microphones'
    positions among them) in a child process. :meth:`push_audio`, :meth:`push_people` and :meth:`end` come from one
    thread, :meth:`receive` from another (a push may wait for the child, whose answers must still be read)."""

    loop, name = "app.voices_process:serve_voices", "voices"

    def push_audio(self, stamp_s: float, samples: np.ndarray) -> None:
        self.child.send(("audio", float(stamp_s), np.ascontiguousarray(samples)))

    def push_people(self, stamp_s: float, ids: np.ndarray, positions_m: np.ndarray, speaking: np.ndarray) -> None:
        self.child.send(("people", float(stamp_s), ids, positions_m, speaking))

    def end(self) -> None:
        """No more input: the child flushes every stream, sends the last chunks and ``done``."""
        self.child.send(("flush",))

    def receive(self) -> list[VoiceChunk] | None:
        """The next chunks the child made, when they come; None once it is done."""
        message = self.child.receive()
        return message[1] if message[0] == "chunks" else None


def serve_voices(inbox: Inbox, outbox: Outbox, **options: Any) -> None:
    """The voices' process's loop (:func:`app.child_process.serve`): a separator fed in order."""
    separator = VoiceSeparator(**options)
    while True:
        message = inbox.recv()
        kind = message[0]
        if kind == "audio":
            separator.push_audio(message[1], message[2])
        elif kind == "people":
            separator.push_people(*message[1:])
        elif kind == "flush":
            outbox.send(("chunks", separator.flush()))
            outbox.send(("done", separator.frames))
            continue
        elif kind == "end":
            return
        else:
            raise ValueError(f"unknown message {kind!r}")
        chunks = separator.pop()
        if chunks:
            outbox.send(("chunks", chunks))
