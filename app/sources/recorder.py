"""Recording live input to the raw recording folder format (recordings/FORMAT.md).

The camera and audio threads only enqueue; the caller's thread writes, so the writer needs no lock. Recorded data
is never dropped: the queue is large, and when the run ends (duration, Ctrl-C, a device that fails) everything
already captured is written and the files are closed, so the folder is always a readable recording.
"""
from __future__ import annotations

import logging
import queue
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from app.events import AudioBlock, StereoFrame
from app.sources.recording import RecordingWriter

log = logging.getLogger(__name__)

__all__ = ["RecordStats", "record"]


@dataclass
class RecordStats:
    frames: int = 0
    audio_blocks: int = 0
    duration_s: float = 0.0
    interrupted: bool = False
    errors: list[str] = field(default_factory=list)


def record(source: Any, writer: RecordingWriter, *, duration_s: float | None = None,
           stop: threading.Event | None = None, max_queue: int = 2000) -> RecordStats:
    """Write what ``source`` (``frames(stop)`` and ``audio(stop)`` iterators) delivers until ``duration_s`` of wall
    time, ``stop``, Ctrl-C, or the end or failure of a device. Device errors are collected in the stats, not
    raised: the folder is closed and usable either way."""
    stop = stop if stop is not None else threading.Event()
    items: queue.Queue[StereoFrame | AudioBlock | None] = queue.Queue(maxsize=max_queue)
    stats = RecordStats()

    def pump(name: str, iterate: Any) -> None:
        try:
            for item in iterate(stop):
                items.put(item)
                if stop.is_set():
                    break
        except Exception as exc:  # a device problem ends the recording; it is reported, not lost
            stats.errors.append(f"{name}: {exc}")
            stop.set()
        finally:
            items.put(None)

    threads = [threading.Thread(target=pump, args=(n, f), name=f"avhear-record-{n}", daemon=True)
               for n, f in (("cameras", source.frames), ("audio", source.audio))]
    start = time.perf_counter()
    finished = 0
    try:
        for t in threads:
            t.start()
        while finished < len(threads):
            if duration_s is not None and time.perf_counter() - start >= duration_s:
                stop.set()
            try:
                item = items.get(timeout=0.1)
            except queue.Empty:
                continue
            if item is None:
                finished += 1
                stop.set()  # one stream ended: stop the other, keep what both delivered
            elif isinstance(item, StereoFrame):
                writer.add_frame(item)
                stats.frames += 1
            else:
                writer.add_audio(item)
                stats.audio_blocks += 1
    except KeyboardInterrupt:
        stats.interrupted = True
        stop.set()
    finally:
        stop.set()
        for t in threads:
            t.join(2.0)
        while True:  # what was captured before the stop is written too
            try:
                item = items.get_nowait()
            except queue.Empty:
                break
            if isinstance(item, StereoFrame):
                writer.add_frame(item)
                stats.frames += 1
            elif isinstance(item, AudioBlock):
                writer.add_audio(item)
                stats.audio_blocks += 1
        writer.close()
        stats.duration_s = time.perf_counter() - start
    return stats
