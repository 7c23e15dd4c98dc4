"""The recognising process of :class:`app.speech.transcriber.Transcriber` (:mod:`app.child_process`, the loop
:func:`serve_words`).

Options: the word penalty and the words (:class:`app.child_process.ChildProcess`); then messages ("audio", person,
utterance, pcm) and ("end", person, utterance) in; ("ready",) once the model is loaded, ("partial", person,
utterance, text) and ("final", person, utterance, text, confidence) out. One decoder a person
(:class:`app.speech.recogniser.Recogniser`), created when the person first speaks. Its own process, not a thread:
pocketsphinx holds the interpreter's lock while it decodes.
"""
from __future__ import annotations

from app.child_process import Inbox, Outbox

__all__ = ["serve_words"]


def serve_words(inbox: Inbox, outbox: Outbox, *, penalty: float, words: list[str]) -> None:
    """The loop (:func:`app.child_process.serve`): until the transcriber closes the inbox."""
    from app.speech.recogniser import Recogniser

    decoders: dict[int, Recogniser] = {-1: Recogniser(words or None, penalty)}  # the model loaded before "ready"
    current: dict[int, int] = {}
    outbox.send(("ready",))
    while True:
        job = inbox.recv()  # EOFError at the end
        kind, person, utterance = job[0], job[1], job[2]
        rec = decoders.get(person)
        if rec is None:
            rec = decoders[person] = decoders.pop(-1) if -1 in decoders else Recogniser(words or None, penalty)
        if current.get(person) != utterance:
            rec.start()
            current[person] = utterance
        if kind == "audio":
            outbox.send(("partial", person, utterance, rec.feed(job[3])))
        else:
            text, confidence = rec.end()
            current.pop(person, None)
            outbox.send(("final", person, utterance, text, confidence))
