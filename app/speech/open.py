"""The transcriber a command asks for (``--transcribe [--words FILE]``), its mistakes said in one line."""
from __future__ import annotations

import importlib.util
from pathlib import Path

from app.errors import UserError
from app.speech.recogniser import read_word_list
from app.speech.transcriber import Transcriber

__all__ = ["open_transcriber", "read_words_file"]


def read_words_file(path: Path | None) -> list[str] | None:
    """The words of ``--words FILE`` (None: the general model), checked against the recogniser's dictionary."""
    if importlib.util.find_spec("pocketsphinx") is None:
        raise UserError("--transcribe needs pocketsphinx, which is not installed: pip install pocketsphinx (its "
                        "wheel carries the US English model)")
    if path is None:
        return None
    try:
        words = read_word_list(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"cannot read --words {path}: {getattr(exc, 'strerror', None) or exc}") from None
    if not words:
        raise UserError(f"--words {path} holds no word: give the words to recognise, e.g. 'one two three'")
    from app.speech.recogniser import Recogniser

    try:
        Recogniser(words)
    except ValueError as exc:
        raise UserError(f"--words {path}: {exc}; leave them out or spell them as the dictionary does") from None
    return words


def open_transcriber(path: Path | None) -> Transcriber:
    """A started :class:`Transcriber` with the words of ``path``; it has loaded its model when this returns."""
    transcriber = Transcriber(read_words_file(path))
    if not transcriber.wait_ready(60.0):
        transcriber.close(0.0)
        raise UserError(f"the speech recogniser did not start: {transcriber.error or 'no answer within 60 s'}")
    return transcriber
