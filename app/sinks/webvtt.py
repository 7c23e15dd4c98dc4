"""A WebVTT transcript (W3C WebVTT, https://www.w3.org/TR/webvtt1/): one cue per utterance, its speaker as a voice
span (``<v person 2>``), its times from the start of the recording (``start_s``), so that a video player shows who
said what over the recording's video."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["vtt_text", "write_vtt"]


def _time(seconds: float) -> str:
    ms = int(round(max(seconds, 0.0) * 1000))
    h, rest = divmod(ms, 3_600_000)
    m, rest = divmod(rest, 60_000)
    s, ms = divmod(rest, 1000)
    return f"{h:02d}:{m:02d}:{s:02d}.{ms:03d}"


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def vtt_text(utterances: Sequence[Any], start_s: float = 0.0) -> str:
    """The WebVTT file of ``utterances`` (:class:`app.speech.transcriber.Words`, final), in order of their start."""
    lines = ["WEBVTT", ""]
    for n, w in enumerate(sorted(utterances, key=lambda w: (w.start_s, w.person_id)), 1):
        begin, end = w.start_s - start_s, w.end_s - start_s
        lines += [str(n), f"{_time(begin)} --> {_time(max(end, begin + 0.001))}",
                  f"<v person {w.person_id}>{_escape(w.text)}", ""]
    return "\n".join(lines)


def write_vtt(path: Path | str, utterances: Sequence[Any], start_s: float = 0.0) -> None:
    Path(path).write_text(vtt_text(utterances, start_s), encoding="utf-8")
