"""Who said what, in the console: each person's words as a subtitle under their face while they speak (and for
:data:`HOLD_S` after), and the transcript pane, one line per utterance in the person's colour
(``avhear run --transcribe``; the words come from :class:`app.speech.transcriber.Transcriber`)."""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import rerun as rr

from app.console import geometry as geo
from app.console.entities import CAMERA_LEFT

__all__ = ["HOLD_S", "SUBTITLES", "TRANSCRIPT", "WordsDisplay"]

SUBTITLES = f"{CAMERA_LEFT}/words"
TRANSCRIPT = "transcript"
HOLD_S = 2.0  # a final utterance stays under its face this long (the results' clock)


class WordsDisplay:
    """Keeps each person's latest words (:meth:`take`) and logs them with each frame (:meth:`log`)."""

    def __init__(self) -> None:
        self._shown: dict[int, tuple[str, float | None]] = {}  # person -> (words, shown until; None: partial)
        self._finals: list[Any] = []
        self._occupied = False

    def take(self, words: list[Any]) -> None:
        for w in words:
            self._shown[w.person_id] = (w.text, None if not w.final else float("nan"))
            if w.final:
                self._finals.append(w)

    def log(self, log: Callable[..., None], stamp_s: float, ids: list[int], boxes: np.ndarray | None,
            colors: np.ndarray) -> None:
        """The transcript's new lines and the subtitles of the people in ``ids`` (faces ``boxes`` (N, 4) pixels,
        packed ``colors``) at ``stamp_s``."""
        for w in self._finals:
            rgb = geo.person_colors(np.array([w.person_id]))[0]
            log(TRANSCRIPT, rr.TextLog(f"person {w.person_id} ({w.start_s:.1f}-{w.end_s:.1f} s): {w.text or '...'}",
                                       level=rr.TextLogLevel.INFO, color=rgb))
        self._finals = []
        for pid, (text, until) in list(self._shown.items()):
            if until is not None and until != until:  # a final just come: shown from now
                self._shown[pid] = (text, stamp_s + HOLD_S)
            elif until is not None and stamp_s > until:
                del self._shown[pid]
        at, labels, keep = [], [], []
        if boxes is not None:
            for n, pid in enumerate(ids):
                if pid in self._shown and self._shown[pid][0]:
                    x, y, w, h = boxes[n]
                    at.append((x + w / 2, y + h + 14.0))
                    labels.append(self._shown[pid][0][-60:])  # the latest words of a long utterance
                    keep.append(n)
        if at:
            log(SUBTITLES, rr.Points2D(np.asarray(at), radii=0.1, colors=colors[keep], labels=labels,
                                       draw_order=25.0))
            self._occupied = True
        elif self._occupied:
            log(SUBTITLES, rr.Clear(recursive=False))
            self._occupied = False
