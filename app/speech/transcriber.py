"""Who said what: each person's voice cut into utterances by their speaking state, recognised in a process of its own.

:class:`Transcriber` takes the results' people (:meth:`result`, from the fusion thread) and each person's voice
(:meth:`voice`, :class:`avcore.separation.VoiceChunk` s from the voices thread; their ``plain`` beam where there
is one, which pocketsphinx recognises better than the stream's choice between beams). An utterance starts
``preroll_s`` before a person's first result called speaking and ends ``postroll_s`` after the last, once they have
been silent for ``hangover_s`` (pauses between words stay within one utterance). Its audio goes to the recogniser
as it arrives, so that partial words come while the person speaks and the final words soon after they stop.

Recognition (:class:`app.speech.recogniser.Recogniser`, one decoder a person) runs in a child process
(:mod:`app.speech.worker` through :mod:`app.child_process`): pocketsphinx holds the interpreter's lock while it
decodes, and the pipeline's 30 results a second must not wait for it. The child answers with partial and final
hypotheses; :meth:`events` hands them out as :class:`Words` (the sinks take them on the fusion thread, with the next
result). :meth:`close` ends every open utterance and waits for its words.
"""
from __future__ import annotations

import collections
import queue
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.speech.recogniser import default_word_penalty
from app.child_process import ChildProcess, ChildProcessFailed
from avcore.separation import VoiceChunk

__all__ = ["Transcriber", "Words"]

_RATE = 16000
_KEEP_S = 4.0  # each person's voice kept this long before an utterance needs it (results come ~0.5 s late)


@dataclass(frozen=True)
class Words:
    """Person ``person_id``'s utterance number ``utterance`` (from 0, per run), from ``start_s`` to ``end_s`` on the
    capture clock (``end_s`` is None while partial): its ``text`` so far, or final with its ``confidence``."""

    person_id: int
    utterance: int
    start_s: float
    end_s: float | None
    text: str
    confidence: float | None
    final: bool

    def as_dict(self) -> dict[str, Any]:
        return {"person_id": self.person_id, "utterance": self.utterance, "start_s": round(self.start_s, 3),
                "end_s": None if self.end_s is None else round(self.end_s, 3), "text": self.text,
                "confidence": None if self.confidence is None else round(self.confidence, 3)}


@dataclass
class _Utterance:
    number: int
    start_s: float
    last_speaking_s: float
    sent_until_s: float
    end_s: float | None = None  # set when it closes


class Transcriber:
    """See the module docstring. ``words``: recognise only these words (None: the general model)."""

    def __init__(self, words: Sequence[str] | None = None, *, preroll_s: float = 0.3, postroll_s: float = 0.3,
                 hangover_s: float = 0.4, word_penalty: float | None = None) -> None:
        self.preroll_s, self.postroll_s, self.hangover_s = preroll_s, postroll_s, hangover_s
        penalty = default_word_penalty(words) if word_penalty is None else word_penalty
        self._child = ChildProcess("app.speech.worker:serve_words", "recogniser", penalty=float(penalty),
                                   words=list(words or ()))
        self._jobs: queue.Queue = queue.Queue()  # the pipeline's threads never wait on the pipe: a writer does
        self._writer = threading.Thread(target=self._write, name="avhear-words-writer", daemon=True)
        self._writer.start()
        self._lock = threading.Lock()
        self._audio: dict[int, collections.deque[VoiceChunk]] = {}
        self._open: dict[int, _Utterance] = {}
        self._closing: dict[tuple[int, int], _Utterance] = {}
        self._starts: dict[tuple[int, int], tuple[float, float | None]] = {}
        self._events: list[Words] = []
        self._partial: dict[tuple[int, int], str] = {}  # the last partial words said of each open utterance
        self._pending = 0  # utterances ended whose final words have not come back
        self._count = 0
        self.error: str | None = None
        self._ready = threading.Event()
        self._reader = threading.Thread(target=self._read, name="avhear-words-reader", daemon=True)
        self._reader.start()

    # -- input ---------------------------------------------------------------------------------------------------

    def voice(self, chunk: VoiceChunk) -> None:
        with self._lock:
            kept = self._audio.setdefault(chunk.person_id, collections.deque())
            kept.append(chunk)
            while kept and kept[0].end_s < chunk.end_s - _KEEP_S:
                kept.popleft()
            self._forward(chunk.person_id)

    def result(self, stamp_s: float, people: Sequence[tuple[int, bool]]) -> None:
        """The people of one result: (id, speaking) pairs; a person no longer there ends their utterance."""
        with self._lock:
            there = set()
            for pid, speaking in people:
                there.add(pid)
                utt = self._open.get(pid)
                if speaking:
                    if utt is None:
                        start = stamp_s - self.preroll_s
                        utt = self._open[pid] = _Utterance(self._count, start, stamp_s, start)
                        self._starts[(pid, utt.number)] = (start, None)
                        self._count += 1
                    utt.last_speaking_s = stamp_s
                elif utt is not None and stamp_s - utt.last_speaking_s > self.hangover_s:
                    self._close(pid)
            for pid in [p for p in self._open if p not in there]:
                self._close(pid)
            for pid in {p for p, _ in self._closing} | set(self._open):
                self._forward(pid)

    def _close(self, pid: int) -> None:
        utt = self._open.pop(pid)
        utt.end_s = utt.last_speaking_s + self.postroll_s
        self._closing[(pid, utt.number)] = utt
        self._starts[(pid, utt.number)] = (utt.start_s, utt.end_s)

    def _forward(self, pid: int) -> None:
        """Send person ``pid``'s audio up to where it is known (and to the end of a closing utterance)."""
        kept = self._audio.get(pid, ())
        for utt in [u for (p, _), u in self._closing.items() if p == pid] + (
                [self._open[pid]] if pid in self._open else []):
            until = utt.end_s if utt.end_s is not None else float("inf")
            pieces = []
            for c in kept:
                lo, hi = max(utt.sent_until_s, c.stamp_s), min(until, c.end_s)
                if hi > lo:
                    a, b = int(round((lo - c.stamp_s) * _RATE)), int(round((hi - c.stamp_s) * _RATE))
                    pieces.append((c.samples if c.plain is None else c.plain)[a:b])
                    utt.sent_until_s = c.stamp_s + b / _RATE
            if pieces:
                pcm = np.clip(np.round(np.concatenate(pieces) * 32767.0), -32768, 32767).astype("<i2")
                self._jobs.put(("audio", pid, utt.number, pcm.tobytes()))
            newest = kept[-1].end_s if kept else -float("inf")
            if utt.end_s is not None and (utt.sent_until_s >= utt.end_s - 1.0 / _RATE or newest >= utt.end_s):
                self._jobs.put(("end", pid, utt.number))
                self._pending += 1
                del self._closing[(pid, utt.number)]

    # -- output --------------------------------------------------------------------------------------------------

    def _write(self) -> None:
        while (job := self._jobs.get()) is not None:
            try:
                self._child.send(job)
            except ChildProcessFailed:
                return
        self._child.close_inbox()  # the recogniser's end

    def _read(self) -> None:
        while True:
            try:
                answer = self._child.receive()
            except ChildProcessFailed as exc:
                if exc.reason is not None:  # the child's exception, "Type: message"
                    self.error = exc.reason
                elif self.error is None and self._pending > 0:  # it stopped with words still owed
                    self.error = "the recogniser stopped"
                return
            if answer[0] == "ready":
                self._ready.set()
                continue
            kind, pid, number = answer[0], answer[1], answer[2]
            with self._lock:
                start, end = self._starts.get((pid, number), (float("nan"), None))
                if kind == "final":
                    self._pending -= 1
                    self._partial.pop((pid, number), None)
                    self._starts.pop((pid, number), None)
                    self._events.append(Words(pid, number, start, end, answer[3], answer[4], True))
                elif answer[3] and answer[3] != self._partial.get((pid, number)):
                    self._partial[(pid, number)] = answer[3]
                    self._events.append(Words(pid, number, start, None, answer[3], None, False))

    def events(self) -> list[Words]:
        """The words that came since the last call, partial and final, in order."""
        with self._lock:
            out, self._events = self._events, []
        return out

    def wait_ready(self, timeout_s: float = 30.0) -> bool:
        """Whether the recogniser has loaded its model (within ``timeout_s``); False at once when it failed
        (:attr:`error` says why)."""
        deadline = time.monotonic() + timeout_s
        while not self._ready.wait(0.05):
            if self.error is not None or time.monotonic() >= deadline:
                return False
        return True

    def close(self, timeout_s: float = 10.0) -> list[Words]:
        """End every open utterance, wait (at most ``timeout_s``) for the words still coming, stop the process;
        the events not taken yet."""
        with self._lock:
            for pid in list(self._open):
                self._close(pid)
            for (pid, number), utt in list(self._closing.items()):
                self._jobs.put(("end", pid, number))
                self._pending += 1
                del self._closing[(pid, number)]
        deadline = time.monotonic() + timeout_s
        while (self._pending > 0 and self.error is None and self._child.proc.poll() is None
               and time.monotonic() < deadline):
            time.sleep(0.02)
        self._jobs.put(None)
        self._writer.join(2.0)
        self._reader.join(2.0)  # the child has read the end of its inbox and closed its outbox
        self._child.close(2.0)
        return self.events()
