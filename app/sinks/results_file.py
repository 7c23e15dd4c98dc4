"""The results file: every fused result as one JSON line (``--results-jsonl FILE``), the headless log that tests and
other programs read, and the payload the bus publishes on ``avhear/results``.

Schema of one line (one fused result; fields may be added, never renamed):

```
{"stamp_s": float,            # capture time of the vision result, seconds on the source's clock
 "index": int,                # frame number of the (middle) left image
 "mode": "face" | "motion",   # Algorithm 2 (faces) or Algorithm 1 (HM3D points)
 "n_itds": int,               # ITDs in its time frame
 "latency_s": float | null,   # result time minus capture stamp (null for a replay as fast as possible)
 "people": [{"id": int,                 # stable while the person is tracked
             "position_m": [x, y, z],   # scene frame (docs/architecture.md: x right, y down, z forward), metres
             "speaking": bool,
             "probability": float,      # in [0, 1], above 0.5 exactly when speaking
             "itd_mean_s": float,       # the person's mean in ITD space
             "box_px": [x, y, w, h],    # face-guided only: the face box in the left image, pixels
             "lip_activity": float | null  # with the lips read only: how much the lips moved over 0.4 s (the
                                           # spread of the mouth's opening); null: no opinion (face just seen)
             "voice_id": "v<id>"        # the person's voice: on the bus humans/voices/v<id>/, with --voices-dir
                                        # its stream in person_<id>.wav
            },
            {"id": int,                 # several microphone pairs, face-guided only: a voice no visible person
             "position_m": null,        # explains, heard now (speaking) from a direction: a person without a face
             "speaking": true,          # or a position; its id is from the people's numbering, never a seen
             "probability": null,       # person's, and kept while the voice is heard about the same way
             "itd_mean_s": null,
             "azimuth_deg": float,      # from straight ahead, positive to the right
             "elevation_deg": float | null,  # up (null: the array cannot tell); its distance is unknown
             "voice_id": "v<id>"
            }, ...],
 "utterances": [{"person_id": int,      # --transcribe only, on the line after the words became final: each
                 "utterance": int,      # utterance once (its number in the run)
                 "start_s": float, "end_s": float,   # when it was said, the source's clock
                 "text": str,           # the words (pocketsphinx, US English)
                 "confidence": float    # the words' mean posterior probability, 0-1
                }, ...]}
```

Readers that want the people in view only keep those whose ``position_m`` is not null.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import IO, Any

from app.errors import UserError

__all__ = ["ResultsWriter"]


class ResultsWriter:
    """Writes results to a JSON-lines file as they come, one flushed line each, so that any stop keeps them.

    The file is opened (parent folders created) at construction, before the run, so that an unwritable path is a
    :class:`UserError` at once rather than after the work.
    """

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file: IO[str] | None = self.path.open("w", encoding="utf-8")
        except OSError as exc:
            raise UserError(f"cannot write the results file {self.path}: {exc.strerror or exc}; "
                            "choose another --results-jsonl path") from exc
        self.written = 0

    def write(self, result: Any, utterances: list[dict[str, Any]] | None = None) -> None:
        """One result's line; ``utterances``: the words that became final since the last line (``--transcribe``)."""
        if self._file is None:
            raise ValueError(f"the results file {self.path} is closed")
        record = result.as_dict()
        if utterances:
            record["utterances"] = utterances
        self._file.write(json.dumps(record, separators=(",", ":")) + "\n")
        self._file.flush()
        self.written += 1

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> ResultsWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
