"""Each person's voice out of a run: `--voices-dir` writes a WAV a person on the results' clock, the Python API
yields the same chunks, and a stop ends every file cleanly."""
from __future__ import annotations

import json
import wave
from pathlib import Path

import numpy as np
import pytest

from app.cli import main


def _wav(path: Path) -> tuple[np.ndarray, int]:
    with wave.open(str(path)) as f:
        assert f.getnchannels() == 1 and f.getsampwidth() == 2
        return np.frombuffer(f.readframes(f.getnframes()), dtype="<i2"), f.getframerate()


def test_voices_dir_writes_a_wav_a_person_on_the_results_clock(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    """S5 (three people counting, with overlaps), 4 s: one file a person of the results, 16 kHz, from the voices'
    delay (0.6 s) to the end of the sound, without a gap; voices.json says where each starts."""
    out = tmp_path / "voices"
    results = tmp_path / "results.jsonl"
    assert main(["run", "--source", "sim:S5", "--duration", "4", "--fast", "--headless", "--voices-dir", str(out),
                 "--results-jsonl", str(results)]) == 0
    assert "each person's voice in" in capsys.readouterr().out
    ids = {p["id"] for line in results.read_text().splitlines() for p in json.loads(line)["people"]}
    index = json.loads((out / "voices.json").read_text())["voices"]
    assert {v["person_id"] for v in index} == ids and len(ids) == 3
    for v in index:
        samples, rate = _wav(out / v["file"])
        assert rate == 16000 and v["samplerate_hz"] == 16000 and v["gaps"] == 0
        assert v["start_s"] == pytest.approx(0.6, abs=0.1)
        assert samples.size / rate == pytest.approx(v["end_s"] - v["start_s"], abs=1e-3)
        assert v["end_s"] == pytest.approx(4.0, abs=0.1)
        assert 100 < np.sqrt(np.mean(samples.astype(float) ** 2)) < 20000  # sound, not silence nor clipping


def test_voices_dir_that_cannot_be_written_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "file").write_text("")
    assert main(["run", "--source", "sim:S2", "--duration", "1", "--fast", "--headless", "--voices-dir",
                 str(tmp_path / "file")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--voices-dir" in err[-1] and "is a file" in err[-1]


def test_the_api_yields_each_persons_voice_in_time_order() -> None:
    import avhear

    chunks = list(avhear.voices("sim:S2", duration_s=3))
    by_person: dict[int, list] = {}
    for c in chunks:
        by_person.setdefault(c.person_id, []).append(c)
    assert len(by_person) >= 2
    assert [c.stamp_s for c in chunks] == sorted(c.stamp_s for c in chunks)
    for cs in by_person.values():
        assert all(abs(b.stamp_s - a.end_s) < 1e-6 for a, b in zip(cs, cs[1:]))  # no gap while they are there
        assert all(c.samplerate_hz == 16000 and c.samples.dtype == np.float32 for c in cs)
        assert cs[-1].end_s == pytest.approx(3.0, abs=0.1)
