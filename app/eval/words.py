"""Who said what, scored where the truth is known (``avhear eval words``): speaker-attributed word error rates.

A simulated scenario (S1-S5: people counting, the ten digits' grammar) or a drawn room (:mod:`sim.rooms`: ARCTIC
sentences, the general language model) runs through the real pipeline as fast as possible with each person's voice
and the transcriber (:class:`app.speech.transcriber.Transcriber`). Three transcripts per person are scored against
what each person said (the truth's words in order), by cpWER (``meeteval``: the word error rate under the best
assignment of the hypothesis' speakers to the reference's):

* ``avhear``: the words of each person's stream, cut by their speaking states (what ``--transcribe`` gives);
* ``reference-mic``: the same recogniser on the first microphone, cut at avhear's utterances (the baseline: the
  speaking states without the voices);
* ``dry``: the same recogniser on each talker's own dry speech, each utterance as the truth cuts it (the
  recogniser's own ceiling).

Each utterance's lag (final words out minus its end, on the results' clock: the pipeline's stamps) is kept too.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["WordsRow", "evaluate_words"]

Progress = Callable[[str], None]
_RATE = 16000


@dataclass(frozen=True)
class WordsRow:
    """One run: cpWER (errors / reference words) of each transcript, and the words per person."""

    name: str
    seed: int
    mics: str
    reference_words: int
    errors: dict[str, int]
    utterances: int
    reference: dict[str, str]
    hypotheses: dict[str, dict[str, str]]

    def cpwer(self, what: str) -> float:
        return self.errors[what] / max(self.reference_words, 1)

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "seed": self.seed, "mics": self.mics, "reference_words": self.reference_words,
                "cpwer": {k: round(self.cpwer(k), 4) for k in self.errors}, "errors": dict(self.errors),
                "utterances": self.utterances, "reference": self.reference, "hypotheses": self.hypotheses}


def _cp_errors(reference: dict[str, str], hypothesis: dict[str, str]) -> int:
    from meeteval.wer import cp_word_error_rate

    hyp = {k: v for k, v in hypothesis.items() if v.strip()} or {"none": ""}
    # each speaker's words in their order already: no timestamps to sort by (said, not warned)
    return int(cp_word_error_rate(reference, hyp, reference_sort=False, hypothesis_sort=False).errors)


def _decode(recogniser: Any, samples: np.ndarray) -> str:
    pcm = np.clip(np.round(samples * 32767.0), -32768, 32767).astype("<i2")
    recogniser.start()
    recogniser.feed(pcm.tobytes())
    return recogniser.end()[0]


def evaluate_words(name: str, *, seed: int = 0, mics: str = "pair", duration_s: float | None = None,
                   data_dir: str | None = None, progress: Progress | None = None,
                   word_penalty: float | None = None) -> WordsRow:
    """``name``: a scenario ("S1".."S5") or "room" (room ``seed`` of :mod:`sim.rooms`); ``word_penalty``: the
    recogniser's for all three transcripts (None: :func:`app.speech.recogniser.default_word_penalty`)."""
    from scipy.signal import resample_poly

    from app.pipeline import Pipeline, PipelineConfig
    from app.sources.open import StreamAdapter
    from app.sources.sim import SimSource
    from app.speech.recogniser import Recogniser
    from app.speech.transcriber import Transcriber
    from sim.audio import DIGIT_WORDS, spoken_words

    say = progress or (lambda m: None)
    if name == "room":
        source = SimSource.from_room(seed, duration_s=duration_s, data_dir=data_dir, mics=mics)
    else:
        source = SimSource.from_preset(name, duration_s=duration_s, seed=seed, data_dir=data_dir, mics=mics)
    scenario, bank = source.scenario, source.bank
    grammar = list(DIGIT_WORDS) if name != "room" else None
    speech = sorted((e for e in scenario.events if e.kind == "speech"), key=lambda e: e.start_s)
    reference = {f"person {k}": " ".join(spoken_words(bank, scenario.actors[k].voice, e.clip, e.label)
                                         for e in speech if e.actor == k).strip()
                 for k in range(len(scenario.actors))}
    reference = {k: v for k, v in reference.items() if v}

    say(f"{name} seed {seed}: the pipeline with each person's voice and words ...")
    transcriber = Transcriber(grammar, word_penalty=word_penalty)
    transcriber.wait_ready()
    finals: list = []
    places: dict[int, list[tuple[float, np.ndarray]]] = {}

    def on_result(result: Any) -> None:
        transcriber.result(result.stamp_s, [(p.id, p.speaking) for p in result.people])
        finals.extend(w for w in transcriber.events() if w.final)
        for p in result.people:
            places.setdefault(p.id, []).append((result.stamp_s, p.position_m))

    with StreamAdapter(source, realtime=False) as adapter:
        Pipeline(adapter, PipelineConfig(voices=True), on_result, on_voice=transcriber.voice).run(whole=True)
    finals.extend(w for w in transcriber.close() if w.final)

    # each tracked id is the actor nearest to it over the results where it was seen
    owner = {}
    for pid, seen in places.items():
        d = [np.mean([np.linalg.norm(scenario.positions(t)[k] - xyz) for t, xyz in seen])
             for k in range(len(scenario.actors))]
        owner[pid] = int(np.argmin(d))
    avhear: dict[str, str] = {}
    for w in sorted(finals, key=lambda w: w.start_s):
        key = f"id {w.person_id}"
        avhear[key] = (avhear.get(key, "") + " " + w.text).strip()

    say(f"{name} seed {seed}: the reference microphone and the dry speech ...")
    recogniser = Recogniser(grammar, word_penalty)
    fs = int(source.samplerate_hz)
    mic = source.audio.samples[:, 0].astype(np.float64) / 32768.0
    mic16 = resample_poly(mic, _RATE, fs) if fs != _RATE else mic
    baseline: dict[str, str] = {}
    for w in sorted(finals, key=lambda w: w.start_s):
        a, b = int(max(w.start_s, 0.0) * _RATE), int(max(w.end_s, 0.0) * _RATE)
        if b > a:
            key = f"id {w.person_id}"
            baseline[key] = (baseline.get(key, "") + " " + _decode(recogniser, mic16[a:b])).strip()
    dry_signals = source.audio.dry.astype(np.float64)
    dry: dict[str, str] = {}
    for e in speech:
        a, b = int(max(e.start_s - 0.2, 0.0) * fs), int((e.end_s + 0.2) * fs)
        piece = dry_signals[e.actor, a:b]
        piece = piece / max(float(np.max(np.abs(piece))), 1e-9) * 0.5
        key = f"person {e.actor}"
        dry[key] = (dry.get(key, "") + " " + _decode(recogniser, resample_poly(piece, _RATE, fs) if fs != _RATE
                                                      else piece)).strip()
    errors = {"avhear": _cp_errors(reference, avhear), "reference-mic": _cp_errors(reference, baseline),
              "dry": _cp_errors(reference, dry)}
    n_words = sum(len(v.split()) for v in reference.values())
    return WordsRow(name, seed, mics, n_words, errors, len(finals), reference,
                    {"avhear": avhear, "reference-mic": baseline, "dry": dry})
