"""Offline speech recognition of one utterance at a time: pocketsphinx (CMU Sphinx), whose wheel carries the US
English acoustic model, dictionary and language model, so nothing is downloaded at run time.

:class:`Recogniser` decodes 16 kHz mono 16-bit audio fed in pieces (:meth:`feed` returns the partial hypothesis so
far) and ends with :meth:`end` (the words and a confidence: the mean posterior probability of the words,
pocketsphinx's ``Segment.prob``). With ``words`` (a list, e.g. the ten digits of the scenarios' counting) it
recognises only sequences of those words (a JSGF grammar ``<word>+``); otherwise the general language model.
``word_penalty`` is pocketsphinx's word insertion probability (``wip``): lower, fewer words are written where
there are none (noise, another voice) and more are missed. Its default (:func:`default_word_penalty`) is 0.01 with a
word list, whose ``<word>+`` otherwise turns every sound of a person's stream into words, and pocketsphinx's 0.65
with the general model, whose language model already weighs words (the measurements: docs/experiments.md).
"""
from __future__ import annotations

from collections.abc import Sequence

__all__ = ["Recogniser", "default_word_penalty", "read_word_list"]

_NOT_WORDS = {"<s>", "</s>", "<sil>"}  # pocketsphinx's marks; fillers are in brackets ([NOISE], ...)


def default_word_penalty(words: Sequence[str] | None) -> float:
    """0.01 with a word list, pocketsphinx's own 0.65 with the general model (see the module docstring)."""
    return 0.01 if words else 0.65


def read_word_list(text: str) -> list[str]:
    """The words of a ``--words`` file: whitespace or commas between them, ``#`` starts a comment; lower case."""
    words: list[str] = []
    for line in text.splitlines():
        for w in line.split("#", 1)[0].replace(",", " ").split():
            if w.lower() not in words:
                words.append(w.lower())
    return words


class Recogniser:
    """One pocketsphinx decoder; :meth:`start`, :meth:`feed` any number of times, :meth:`end`."""

    def __init__(self, words: Sequence[str] | None = None, word_penalty: float | None = None) -> None:
        from pocketsphinx import Decoder

        if word_penalty is None:
            word_penalty = default_word_penalty(words)
        if not 0 < word_penalty <= 1:
            raise ValueError(f"word_penalty must be a probability in (0, 1], got {word_penalty!r}")
        self._decoder = Decoder(samprate=16000, logfn="/dev/null", wip=float(word_penalty))
        if words:
            unknown = [w for w in words if self._decoder.lookup_word(w) is None]
            if unknown:
                raise ValueError(f"not in pocketsphinx's US English dictionary: {', '.join(unknown)}")
            alternatives = " | ".join(words)
            self._decoder.add_jsgf_string("words", "#JSGF V1.0;\ngrammar words;\npublic <utterance> = <word>+;\n"
                                                   f"<word> = {alternatives};\n")
            self._decoder.activate_search("words")
        self._open = False

    def start(self) -> None:
        if self._open:
            self._decoder.end_utt()
        self._decoder.start_utt()
        self._open = True

    def feed(self, pcm: bytes) -> str:
        """Decode more of the utterance (little-endian int16 bytes); the words so far."""
        if not self._open:
            self.start()
        self._decoder.process_raw(pcm, False, False)
        hyp = self._decoder.hyp()
        return hyp.hypstr if hyp is not None else ""

    def end(self) -> tuple[str, float]:
        """The utterance's words and their mean posterior probability (0 with no words)."""
        if not self._open:
            return "", 0.0
        self._decoder.end_utt()
        self._open = False
        hyp = self._decoder.hyp()
        if hyp is None or not hyp.hypstr:
            return "", 0.0
        probs = [s.prob for s in self._decoder.seg() if s.word not in _NOT_WORDS and not s.word.startswith("[")]
        return hyp.hypstr, float(sum(probs) / len(probs)) if probs else 0.0
