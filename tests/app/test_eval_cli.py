from __future__ import annotations

import json
import re

import pytest

from app.cli import main


def test_eval_synthetic_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "synthetic", "--sequence", "StaCon", "--seed", "0", "--variant", "avhear", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["seeds"] == [0]
    (row,) = out["results"]
    assert row["sequence"] == "StaCon" and row["variant"] == "avhear"
    assert row["tp"] + row["fn"] == 408  # three people in every one of the 136 intervals
    assert 0.0 <= row["visual_tp_rate"] <= 1.0
    assert out["paper"]["visual"]["StaCon"]["tp"] == 392


def test_eval_synthetic_tables(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "synthetic", "--sequence", "StaVar", "--seed", "1"]) == 0
    captured = capsys.readouterr()
    assert "Table 1" in captured.out and "Table 2" in captured.out
    assert captured.out.count("paper (published)") == 2
    assert "paper's method" in captured.out and "avhear" in captured.out
    assert "StaVar seed 1" in captured.err  # progress on stderr


def test_eval_bad_arguments(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["eval", "synthetic", "--seed", "-1"])
    assert stop.value.code == 2 and "--seed" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["eval", "synthetic", "--sequence", "Nope"])


@pytest.mark.parametrize(("value", "text"), [(-0.03, "+0.0"), (-0.0, "+0.0"), (0.04, "+0.0"), (-1.26, "-1.3"), (2.0, "+2.0")])
def test_c0_never_prints_as_minus_zero(value: float, text: str) -> None:
    from app.eval.tables import signed_us

    assert signed_us(value) == text


def test_eval_synthetic_progress_is_each_seeds_own(capsys: pytest.CaptureFixture[str]) -> None:
    """A progress line counts its own seed (the sum so far is said as such), so that its numbers are not mistaken
    for a seed's."""
    assert main(["eval", "synthetic", "--sequence", "StaCon", "--seed", "0", "1", "--variant", "avhear"]) == 0
    lines = re.findall(r"StaCon seed (\d) \(avhear\): TP (\d+)/408 \(all seeds so far: (\d+)/(\d+)\)",
                       capsys.readouterr().err)
    assert [(seed, total) for seed, _, _, total in lines] == [("0", "408"), ("1", "816")], lines
    (_, first, first_sum, _), (_, second, second_sum, _) = lines
    assert first_sum == first and int(second_sum) == int(first) + int(second)  # each its own, then the sum


def test_the_screenshot_benchmark_without_chromium_is_one_line(load_benchmark, monkeypatch: pytest.MonkeyPatch,
                                                               capsys: pytest.CaptureFixture[str],
                                                               tmp_path) -> None:  # noqa: ANN001
    """benchmarks/console_screenshots.py on a machine without Chromium: one line saying what it needs, exit 2,
    checked before its demo runs (it ended in a traceback after them)."""
    shots = load_benchmark("console_screenshots")
    monkeypatch.setattr(shots, "chromium_executable", lambda: None)
    monkeypatch.setattr(shots, "avhear", lambda argv: pytest.fail("ran a demo before checking for Chromium"))
    assert shots.main(["--out", str(tmp_path / "shots")]) == 2
    err = capsys.readouterr().err
    assert "needs Debian's chromium" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "shots").exists()
