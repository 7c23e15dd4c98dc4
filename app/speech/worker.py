"""The recognising process of :class:`app.speech.transcriber.Transcriber`:
``python -m app.speech.worker WORD_PENALTY [WORD ...]``.

It reads jobs from its standard input and writes answers to its standard output, each a pickled tuple behind its
length (4 bytes, little-endian): ("audio", person, utterance, pcm) and ("end", person, utterance) in; ("ready",),
("partial", person, utterance, text), ("final", person, utterance, text, confidence) and ("error", message) out.
One decoder a person (:class:`app.speech.recogniser.Recogniser`), created when the person first speaks. Its own
process, not a thread: pocketsphinx holds the interpreter's lock while it decodes.
"""
from __future__ import annotations

import pickle
import struct
import sys
from typing import Any, BinaryIO

__all__ = ["read_message", "write_message"]


def write_message(stream: BinaryIO, message: tuple) -> None:
    data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(struct.pack("<I", len(data)) + data)
    stream.flush()


def read_message(stream: BinaryIO) -> Any:
    """The next message, or None at the end of the stream."""
    head = stream.read(4)
    if len(head) < 4:
        return None
    (size,) = struct.unpack("<I", head)
    data = stream.read(size)
    return pickle.loads(data) if len(data) == size else None


def main(penalty: float, words: list[str]) -> int:
    from app.speech.recogniser import Recogniser

    source, sink = sys.stdin.buffer, sys.stdout.buffer
    try:
        decoders: dict[int, Recogniser] = {-1: Recogniser(words or None, penalty)}  # the model loaded before "ready"
        current: dict[int, int] = {}
        write_message(sink, ("ready",))
        while (job := read_message(source)) is not None:
            kind, person, utterance = job[0], job[1], job[2]
            rec = decoders.get(person)
            if rec is None:
                rec = decoders[person] = decoders.pop(-1) if -1 in decoders else Recogniser(words or None, penalty)
            if current.get(person) != utterance:
                rec.start()
                current[person] = utterance
            if kind == "audio":
                write_message(sink, ("partial", person, utterance, rec.feed(job[3])))
            else:
                text, confidence = rec.end()
                current.pop(person, None)
                write_message(sink, ("final", person, utterance, text, confidence))
    except Exception as exc:  # noqa: BLE001 - said in the parent
        write_message(sink, ("error", f"{type(exc).__name__}: {exc}"))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(float(sys.argv[1]), sys.argv[2:]))
