"""``--voices-dir DIR``: each person's voice (:class:`avcore.separation.VoiceChunk` s) as one WAV file a person.

``DIR/person_<id>.wav``: mono, 16-bit, 16 kHz, its first sample captured at the ``start_s`` that ``DIR/voices.json``
gives (the source's clock, as the results' ``stamp_s``); a gap in a person's stream (out of view for a while, audio
lost) is written as silence, so that a sample's time is always ``start_s + index / samplerate_hz``. The files are
written as the chunks come and closed (their lengths in the headers, ``voices.json`` written) by :meth:`close`,
which a run calls on its end, Ctrl-C and SIGTERM alike.
"""
from __future__ import annotations

import json
import wave
from pathlib import Path
from typing import Any

import numpy as np

from avcore.separation import VoiceChunk

__all__ = ["VoicesWriter"]

_MAX_GAP_S = 3600.0  # a chunk this far after a person's last (or 1 s before it) is a jump of the clock: a new file


class VoicesWriter:
    """Writes into ``folder`` (created); :meth:`write` from one thread; a context manager that closes."""

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self._files: dict[int, wave.Wave_write] = {}
        self._info: dict[int, dict[str, Any]] = {}  # the open file's of each person
        self._parts: dict[int, int] = {}
        self._done: list[dict[str, Any]] = []  # files closed by a clock's jump
        self.written_s = 0.0

    def write(self, chunk: VoiceChunk) -> None:
        pid = int(chunk.person_id)
        info = self._info.get(pid)
        if info is None or not -1.0 < chunk.stamp_s - info["end_s"] < _MAX_GAP_S:
            info = self._open(pid, chunk)  # the first chunk, or the clock jumped: a file of its own
        f = self._files[pid]
        gap = int(round((chunk.stamp_s - info["end_s"]) * chunk.samplerate_hz))
        if gap > 0:
            f.writeframes(np.zeros(gap, dtype="<i2").tobytes())
            info["gaps"] += 1
        samples = chunk.samples[max(0, -gap):]  # an overlap with what is written (a clock's jitter) is cut
        f.writeframes(np.clip(np.round(samples * 32767.0), -32768, 32767).astype("<i2").tobytes())
        info["end_s"] = info["start_s"] + f.getnframes() / chunk.samplerate_hz
        self.written_s += samples.size / chunk.samplerate_hz

    def _open(self, pid: int, chunk: VoiceChunk) -> dict[str, Any]:
        part = self._parts[pid] = self._parts.get(pid, 0) + 1
        if pid in self._files:
            self._files.pop(pid).close()
            self._done.append(self._info[pid])
        name = f"person_{pid}.wav" if part == 1 else f"person_{pid}_part{part}.wav"
        f = wave.open(str(self.folder / name), "wb")
        f.setnchannels(1)
        f.setsampwidth(2)
        f.setframerate(int(chunk.samplerate_hz))
        self._files[pid] = f
        info = self._info[pid] = {"person_id": pid, "file": name, "start_s": float(chunk.stamp_s),
                                  "end_s": float(chunk.stamp_s), "samplerate_hz": int(chunk.samplerate_hz),
                                  "gaps": 0}
        return info

    def close(self) -> None:
        """Close every file and write ``voices.json`` (safe to call twice)."""
        for f in self._files.values():
            f.close()
        self._files.clear()
        index = [{**i, "start_s": round(i["start_s"], 6), "end_s": round(i["end_s"], 6)}
                 for i in sorted([*self._done, *self._info.values()], key=lambda i: (i["person_id"], i["start_s"]))]
        (self.folder / "voices.json").write_text(json.dumps({"voices": index}, indent=2) + "\n")

    def __enter__(self) -> VoicesWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
