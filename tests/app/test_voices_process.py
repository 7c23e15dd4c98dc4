"""The voices' separator in a process of its own (app/voices_process.py): the same chunks as in a thread, its failure
said in one error, Ctrl-C and a dead parent handled."""
from __future__ import annotations

import os
import signal
import threading
import time

import numpy as np
import pytest

from app.child_process import ChildProcessFailed
from app.voices_process import VoicesProcess
from avcore.separation import VoiceChunk, VoiceSeparator

MICS = np.array([[-0.032, 0.0, 0.0], [0.0, 0.0, 0.032], [0.032, 0.0, 0.0], [0.0, 0.0, -0.032]])
PEOPLE = np.array([[-1.0, 0.0, 2.0], [0.5, 0.0, 2.5]])
FS = 16000


def _inputs(seconds: float = 2.0) -> list[tuple]:
    """Audio blocks of 1/30 s and a result's people before each, as the pipeline's voices-in thread sends them."""
    x = np.random.default_rng(3).standard_normal((int(FS * seconds), 4)).astype(np.float32) * 0.1
    block, out = FS // 30, []
    for k, start in enumerate(range(0, x.shape[0], block)):
        out.append(("people", start / FS, np.arange(2), PEOPLE, np.array([True, k % 20 < 10])))
        out.append(("audio", start / FS, x[start:start + block]))
    return out


class _Reader:
    """Reads the child's answers in a thread of its own, as the pipeline's voices thread does (one thread that
    both fed the child and read it would wait on a full pipe while the child waits on the other)."""

    def __init__(self, voices: VoicesProcess) -> None:
        self.chunks: list[VoiceChunk] = []
        self.error: BaseException | None = None
        self._voices = voices
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            while (got := self._voices.receive()) is not None:
                self.chunks.extend(got)
        except BaseException as exc:  # noqa: BLE001 -- re-raised by result()
            self.error = exc

    def result(self, timeout_s: float = 60.0) -> list[VoiceChunk]:
        self._thread.join(timeout_s)
        assert not self._thread.is_alive(), "the voices process never said done"
        if self.error is not None:
            raise self.error
        return self.chunks


def _by_person(chunks: list[VoiceChunk]) -> dict[int, tuple[float, np.ndarray, np.ndarray]]:
    out = {}
    for pid in sorted({c.person_id for c in chunks}):
        mine = sorted((c for c in chunks if c.person_id == pid), key=lambda c: c.stamp_s)
        out[pid] = (mine[0].stamp_s, np.concatenate([c.samples for c in mine]),
                    np.concatenate([c.plain for c in mine if c.plain is not None]))
    return out


def test_the_process_gives_the_chunks_of_the_separator_in_a_thread() -> None:
    options = dict(mic_positions_m=MICS, samplerate_hz=FS, learn_delay_s=0.3, max_wait_s=None)
    here = VoiceSeparator(**options)
    voices = VoicesProcess(**options)
    local: list[VoiceChunk] = []
    reader = _Reader(voices)
    try:
        for kind, *args in _inputs():
            getattr(voices, f"push_{kind}")(*args)
            getattr(here, f"push_{kind}")(*args)
            local.extend(here.pop())
        voices.end()
        remote = reader.result()
    finally:
        voices.close()
    local.extend(here.flush())
    a, b = _by_person(local), _by_person(remote)
    assert set(a) == set(b) == {0, 1}
    for pid in a:
        assert a[pid][0] == b[pid][0]
        assert a[pid][1].size > 1.5 * FS  # the stream goes on through the person's silences
        np.testing.assert_array_equal(a[pid][1], b[pid][1])
        np.testing.assert_array_equal(a[pid][2], b[pid][2])


def test_a_separator_that_fails_in_the_process_is_said_with_its_reason() -> None:
    voices = VoicesProcess(mic_positions_m=MICS[:1], samplerate_hz=FS)  # one microphone: no voice
    try:
        with pytest.raises(ChildProcessFailed, match="at least 2 microphones"):
            _Reader(voices).result()
    finally:
        voices.close()


def test_ctrl_c_reaches_the_parent_alone_and_the_child_still_flushes() -> None:
    """A terminal's Ctrl-C (and a service manager's SIGTERM) reach the whole process group: the child keeps going
    until the parent ends the streams, and every chunk comes out."""
    voices = VoicesProcess(mic_positions_m=MICS, samplerate_hz=FS, max_wait_s=None)
    reader = _Reader(voices)
    try:
        for kind, *args in _inputs(1.0):
            getattr(voices, f"push_{kind}")(*args)
        while not reader.chunks and reader.error is None:  # the child is past its start (and its signals' setup)
            time.sleep(0.01)
        os.kill(voices.child.proc.pid, signal.SIGINT)
        os.kill(voices.child.proc.pid, signal.SIGTERM)
        voices.end()
        chunks = reader.result()
    finally:
        voices.close()
    assert voices.child.proc.returncode == 0
    streams = _by_person(chunks)
    assert set(streams) == {0, 1}
    # each stream goes on to the last whole frame of the audio fed (it starts once the people of learn_delay_s
    # before are known)
    assert all(start + samples.size / FS >= 1.0 - 0.032 for start, samples, _ in streams.values())


def test_the_child_exits_when_its_parent_stops_feeding_it() -> None:
    voices = VoicesProcess(mic_positions_m=MICS, samplerate_hz=FS)
    voices.child.close_inbox()  # what the kernel does to a parent that dies
    assert voices.child.proc.wait(10) == 0
    voices.close()
