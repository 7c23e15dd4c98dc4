"""Who said what: pocketsphinx on one utterance, the transcriber cutting a person's voice by their speaking state in
a process of its own, the words in the results file, on the bus and in a WebVTT transcript."""
from __future__ import annotations

import json
import time
import wave
from pathlib import Path

import numpy as np
import pytest

from app.bus.messages import Topics, decode
from app.cli import main
from app.sinks.webvtt import vtt_text
from app.speech.recogniser import Recogniser, read_word_list
from app.speech.transcriber import Transcriber, Words
from avcore.separation import VoiceChunk

ARCTIC = Path(__file__).resolve().parents[2] / "sim" / "data" / "speech" / "arctic"


def _sentence(name: str) -> np.ndarray:
    with wave.open(str(ARCTIC / name)) as f:
        assert f.getframerate() == 16000
        return np.frombuffer(f.readframes(f.getnframes()), dtype="<i2").astype(np.float64) / 32768.0


def _shared_words(said: str, heard: str) -> float:
    a, b = said.split(), set(heard.split())
    return sum(w in b for w in a) / len(a)


def test_a_word_lists_default_penalty_writes_fewer_wrong_words_than_pocketsphinxs_own() -> None:
    """Each shipped FSDD digit followed, 0.2 s after it, by another speaker's digit 20 dB quieter (what a person's
    stream keeps of a neighbour), the ten digits' grammar: the default word penalty (0.01 with a word list) makes
    fewer errors (words missed, wrong or written over the other voice) than pocketsphinx's own 0.65."""
    from scipy.signal import resample_poly

    from app.speech.recogniser import default_word_penalty

    digits = ["zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine"]
    assert default_word_penalty(digits) == 0.01 and default_word_penalty(None) == 0.65
    paths = sorted((ARCTIC.parents[1] / "speech" / "digits").glob("*.wav"))
    said = []
    for path in paths:
        with wave.open(str(path)) as f:
            x = np.frombuffer(f.readframes(f.getnframes()), dtype="<i2").astype(np.float64)
            said.append(resample_poly(x, 16000, f.getframerate()) / np.abs(x).max())
    errors = {}
    for penalty in (None, 0.65):
        recogniser, errors[penalty] = Recogniser(digits, penalty), 0
        for i, path in enumerate(paths):
            other = said[(i + 7) % len(said)] * 0.1
            y = 0.3 * np.concatenate([np.zeros(4800), said[i], np.zeros(3200), other, np.zeros(4800)])
            recogniser.start()
            recogniser.feed((y * 32767).astype("<i2").tobytes())
            heard, digit = recogniser.end()[0].split(), digits[int(path.name[0])]
            errors[penalty] += len(heard) - 1 + (digit not in heard) if heard else 1
    assert errors[None] < 0.85 * errors[0.65], errors


def test_the_recogniser_hears_a_read_sentence_and_keeps_to_a_word_list() -> None:
    """ARCTIC a0001 with the general model: most of its words; with a word list, only those words come out; a word
    the dictionary lacks is named."""
    pcm = (np.clip(_sentence("cmu_arctic_us_aew_a0001.wav"), -1, 1) * 32767).astype("<i2").tobytes()
    general = Recogniser()
    general.start()
    general.feed(pcm)
    text, confidence = general.end()
    assert _shared_words("author of the danger trail philip steels etc", text) >= 0.6 and 0 < confidence <= 1
    digits = Recogniser(["one", "two", "three"])
    digits.start()
    digits.feed(pcm)
    text, _ = digits.end()
    assert set(text.split()) <= {"one", "two", "three"}
    with pytest.raises(ValueError, match="xqzzy"):
        Recogniser(["one", "xqzzy"])
    with pytest.raises(ValueError, match="word_penalty"):
        Recogniser(word_penalty=0.0)
    assert read_word_list("one, two  # a comment\nThree two\n") == ["one", "two", "three"]


@pytest.mark.parametrize("beam", ["samples", "plain"])
def test_the_transcriber_cuts_a_persons_voice_by_their_speaking_state(beam: str) -> None:
    """Person 4 says a0010 from 1 s on (the results say so, half a second late as the pipeline's do); person 9 is
    silent. One final utterance for person 4, its times about the speech's, partial words before it, most of the
    sentence's words; nothing for person 9. A chunk's ``plain`` beam, where it has one, is what is recognised (the
    stream's samples are silent then)."""
    speech = _sentence("arctic_a0010.wav")
    signal = np.zeros(int(16000 * 6.0))
    signal[16000:16000 + speech.size] = speech
    end_s = 1.0 + speech.size / 16000
    transcriber = Transcriber()
    assert transcriber.wait_ready()
    events: list[Words] = []
    for k, start in enumerate(range(0, signal.size, 512)):
        t = start / 16000
        for pid, samples in ((4, signal), (9, np.zeros_like(signal))):
            piece = samples[start:start + 512].astype(np.float32)
            transcriber.voice(VoiceChunk(pid, t, piece, 16000) if beam == "samples" else
                              VoiceChunk(pid, t, np.zeros_like(piece), 16000, plain=piece))
        result_t = t - 0.5
        if k % 2 == 0 and result_t >= 0:
            transcriber.result(result_t, [(4, 1.0 <= result_t <= end_s), (9, False)])
        events += transcriber.events()
    events += transcriber.close()
    final = [w for w in events if w.final]
    assert [w.person_id for w in final] == [4]
    assert final[0].start_s == pytest.approx(0.7, abs=0.1) and final[0].end_s == pytest.approx(end_s + 0.3, abs=0.1)
    assert _shared_words("i'm playing a single hand in what looks like a losing game", final[0].text) >= 0.5
    assert any(not w.final and w.person_id == 4 for w in events)
    assert transcriber._child.proc.poll() is not None  # the recogniser's process has ended


def test_a_recogniser_that_fails_in_its_process_says_why_at_once() -> None:
    """The recogniser's process (app.child_process) sends its exception: the transcriber says it, without waiting
    out the timeout, and the process has ended."""
    transcriber = Transcriber(["zzqxvw"])  # not a word of the dictionary: the decoder refuses it
    try:
        began = time.monotonic()
        assert transcriber.wait_ready(30.0) is False
        assert time.monotonic() - began < 25.0  # the failure ended the wait, not the timeout
        assert transcriber.error is not None and "zzqxvw" in transcriber.error
        assert transcriber.error.startswith("ValueError:")
    finally:
        transcriber.close(0.0)
    assert transcriber._child.proc.returncode == 1


def test_words_go_on_the_bus_as_hri_live_speech() -> None:
    topic, typename, payload = Topics().speech(3.5, 2, "one two", False, None)
    assert topic == "humans/voices/v2/speech" and typename == "hri_msgs/msg/LiveSpeech"
    partial = decode(payload, typename)
    assert (partial.incremental, partial.final, partial.language) == ("one two", "", "en-US")
    final = decode(Topics().speech(4.0, 2, "one two three", True, 0.8)[2], typename)
    assert (final.incremental, final.final, final.confidence) == ("", "one two three", 0.8)
    assert (final.header.stamp.sec, final.header.stamp.nanosec) == (4, 0)


def test_a_webvtt_cue_per_utterance_with_its_speaker() -> None:
    words = [Words(2, 1, 3.25, 4.5, "three <four>", 0.9, True), Words(0, 0, -0.1, 1.0, "one", 0.7, True)]
    text = vtt_text(words, start_s=0.0)
    assert text.startswith("WEBVTT\n\n1\n00:00:00.000 --> 00:00:01.000\n<v person 0>one\n")
    assert "2\n00:00:03.250 --> 00:00:04.500\n<v person 2>three &lt;four&gt;\n" in text


def test_run_transcribe_puts_each_utterance_once_in_the_results_file(tmp_path: Path) -> None:
    """S1 (one person counting), 6 s, the digits' grammar: utterances of the results' people, each once, in
    digits only, stamped within the run."""
    words = tmp_path / "digits.txt"
    words.write_text("zero one two three four five six seven eight nine\n")
    out = tmp_path / "r.jsonl"
    assert main(["run", "--source", "sim:S1", "--duration", "6", "--fast", "--headless", "--transcribe", "--words",
                 str(words), "--results-jsonl", str(out)]) == 0
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    ids = {p["id"] for r in lines for p in r["people"]}
    said = [u for r in lines for u in r.get("utterances", [])]
    assert said and {u["person_id"] for u in said} <= ids
    assert len({(u["person_id"], u["utterance"]) for u in said}) == len(said)
    digits = set(words.read_text().split())
    assert all(set(u["text"].split()) <= digits for u in said)
    assert any(u["text"] for u in said)
    assert all(-0.5 <= u["start_s"] < u["end_s"] <= 6.5 for u in said)


@pytest.mark.parametrize(("argv", "message"), [
    (["--words", "WORDS"], "--words chooses the words --transcribe recognises"),
    (["--transcribe", "--words", "MISSING"], "cannot read --words"),
    (["--transcribe", "--words", "BAD"], "not in pocketsphinx's US English dictionary: xqzzy"),
])
def test_word_mistakes_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str],
                                    message: str) -> None:
    (tmp_path / "WORDS").write_text("one two")
    (tmp_path / "BAD").write_text("one xqzzy")
    argv = [str(tmp_path / a) if a in ("WORDS", "MISSING", "BAD") else a for a in argv]
    assert main(["run", "--source", "sim:S1", "--duration", "1", "--fast", "--headless", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_transcribe_writes_a_webvtt_transcript(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    words = tmp_path / "digits.txt"
    words.write_text("zero one two three four five six seven eight nine")
    out = tmp_path / "s2.vtt"
    assert main(["transcribe", "sim:S2", "--duration", "6", "--words", str(words), "-o", str(out)]) == 0
    text = out.read_text()
    assert text.startswith("WEBVTT\n") and "<v person " in text
    assert "utterances of" in capsys.readouterr().out
    assert main(["transcribe", str(tmp_path / "nowhere"), "-o", str(out)]) == 2
    assert "is not a recording folder" in capsys.readouterr().err


def test_eval_words_scores_avhear_beside_the_reference_microphone_and_the_dry_speech(
        capsys: pytest.CaptureFixture[str]) -> None:
    """S1 (one person counting), 6 s: the reference is the digits said in order; each transcript's cpWER is its
    errors over those words; the dry speech, cut by the truth, misses fewer than it hears."""
    pytest.importorskip("meeteval")
    assert main(["eval", "words", "--scenario", "S1", "--duration", "6", "--json"]) == 0
    row = json.loads(capsys.readouterr().out)["rows"][0]
    said = row["reference"]["person 0"].split()
    assert row["name"] == "S1" and row["reference_words"] == len(said) >= 4
    assert set(said) <= {"zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine"}
    assert set(row["cpwer"]) == {"avhear", "reference-mic", "dry"}
    assert all(row["cpwer"][k] == pytest.approx(row["errors"][k] / len(said), abs=1e-4) for k in row["cpwer"])
    assert row["cpwer"]["dry"] < 1.0 and row["utterances"] >= 1
