"""`avhear demo` and `avhear run` end to end, headless: the simulated room through the real pipeline into an .rrd."""
from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from rerun.chunk import RrdReader

from app.cli import main


def _entities(path: Path) -> dict[str, int]:
    rows: dict[str, int] = {}
    for chunk in RrdReader(path).stream().to_chunks():
        path = chunk.entity_path.lstrip("/")
        rows[path] = rows.get(path, 0) + chunk.to_record_batch().num_rows
    return rows


def test_demo_writes_the_console_to_an_rrd(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rrd, stats = tmp_path / "demo.rrd", tmp_path / "stats.json"
    assert main(["demo", "--duration", "3", "--fast", "--save", str(rrd), "--stats-json", str(stats)]) == 0
    out = capsys.readouterr().out
    assert "results in" in out and f"rerun {rrd}" in out
    # the command it gives runs from here: `rerun` on PATH, or the venv's own (.venv/bin/rerun when not activated)
    import shutil

    command = out.split("open it with: ", 1)[1].split()[0]
    assert shutil.which(command) or Path(command).is_file(), command
    figures = json.loads(stats.read_text())
    assert figures["results"] >= 80  # 3 s at 30 FPS, nothing lost when replayed as fast as possible
    assert set(figures["drops"]) >= {"frames", "audio", "fusion", "itds_unmatched", "frame_itds"}
    assert not any(figures["drops"].values())
    assert figures["itds"] > 20 and figures["latency_ms_p95"] is None  # undefined as fast as possible
    ents = _entities(rrd)
    image = [e for e in ents if e.endswith("/image")]
    assert image and ents[image[0]] >= 80
    assert any(e.startswith("birdseye/heads/") for e in ents)
    assert any(e.startswith("itd/faces/") for e in ents)
    assert "itd/histogram" in ents
    assert any(e.startswith("people/") and e.endswith("speaking_probability") for e in ents)


def _active_tab_origins(path: Path) -> set[str]:
    """The views that the .rrd's blueprint opens in front of their tabs, by origin."""
    reader = RrdReader(path)
    (store,) = reader.blueprints()
    origins, active = {}, set()
    for chunk in reader.stream(store=store).to_chunks():
        batch = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            origins[chunk.entity_path.lstrip("/")] = batch.column("ViewBlueprint:space_origin").to_pylist()[-1][0]
        if "ContainerBlueprint:active_tab" in batch.schema.names:
            active.update(v for row in batch.column("ContainerBlueprint:active_tab").to_pylist() for v in row or [])
    return {origins[v] for v in active if v in origins}


@pytest.mark.parametrize(("mics", "front"), [("nao", "itd_pairs"), (None, "itd")])
def test_the_console_opens_on_every_pairs_itds_with_an_array(tmp_path: Path, mics: str | None, front: str) -> None:
    rrd = tmp_path / "demo.rrd"
    assert main(["demo", "--duration", "1", "--fast", "--save", str(rrd), *(["--mics", mics] if mics else [])]) == 0
    tabs = _active_tab_origins(rrd)
    assert front in tabs and ({"itd", "itd_pairs"} - {front}).isdisjoint(tabs)
    assert "legend" in _entities(rrd)


def test_the_console_shows_where_the_self_calibration_stands(tmp_path: Path) -> None:
    """--self-calibrate: each pair's c1, c0 and inliers as series, from the start's values (the simulated pair's
    nominal 1 and 0 us) to a fit on the inliers it gathers."""
    rrd = tmp_path / "demo.rrd"
    assert main(["demo", "--duration", "4", "--fast", "--self-calibrate", "--save", str(rrd)]) == 0
    series: dict[str, list[float]] = {}
    for chunk in RrdReader(rrd).stream().to_chunks():
        batch = chunk.to_record_batch()
        if "self_calibration" in chunk.entity_path and "Scalars:scalars" in batch.schema.names:
            series.setdefault(chunk.entity_path.rsplit("/", 1)[-1], []).extend(
                v[0] for v in batch.column("Scalars:scalars").to_pylist())
    assert set(series) == {"c1", "c0_us", "inliers"}
    assert series["c1"][0] == 1.0 and series["c0_us"][0] == 0.0 and series["inliers"][0] == 0.0
    assert series["inliers"][-1] >= 30 and series["c1"][-1] != 1.0  # fitted once enough people talked alone


def test_run_replays_a_recording(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "s1"
    assert main(["simulate", "S1", "-o", str(folder), "--duration", "2"]) == 0
    stats = tmp_path / "stats.json"
    assert main(["run", "--source", f"replay:{folder}", "--fast", "--headless", "--stats-json", str(stats)]) == 0
    figures = json.loads(stats.read_text())
    assert figures["results"] == 60 and figures["bad_frames"] == 0


def test_a_video_truncated_mid_replay_is_a_clear_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The frame count in the AVI header still says 60, so the damage shows only at the first missing frame, in
    the grabber thread: the user gets its message and status 2, not a thread's traceback."""
    folder = tmp_path / "s1"
    assert main(["simulate", "S1", "-o", str(folder), "--duration", "2"]) == 0
    video = folder / "left.avi"
    video.write_bytes(video.read_bytes()[: video.stat().st_size // 4])
    capsys.readouterr()
    assert main(["run", "--source", f"replay:{folder}", "--fast", "--headless"]) == 2
    err = capsys.readouterr().err
    assert "left.avi: frame" in err and "cannot be decoded" in err and "Traceback" not in err


def test_run_bad_sources(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert main(["run", "--source", "sim:S9", "--headless"]) == 2
    assert "unknown scenario" in capsys.readouterr().err
    assert main(["run", "--source", "live", "--headless"]) == 2
    assert "--rig" in capsys.readouterr().err
    assert main(["run", "--source", f"replay:{tmp_path / 'nothing'}", "--headless"]) == 2
    assert main(["run", "--source", "tape", "--headless"]) == 2


def test_one_place_for_the_console_data(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """--headless (no file) with --save used to drop the file silently: the targets now exclude each other."""
    with pytest.raises(SystemExit) as stop:
        main(["run", "--source", "sim:S1", "--headless", "--save", str(tmp_path / "x.rrd")])
    assert stop.value.code == 2
    assert "argument --save: not allowed with argument --headless" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["demo", "--serve", "--connect"])
    assert not (tmp_path / "x.rrd").exists()


def test_serve_binds_to_localhost(capsys: pytest.CaptureFixture[str]) -> None:
    """--serve hosts the web viewer with the rerun server bound to 127.0.0.1 (checked while it runs)."""
    import socket

    import rerun as rr

    from app.console.viewer import ViewerSession, ViewerTarget

    with socket.socket() as a, socket.socket() as b:  # two free ports
        a.bind(("127.0.0.1", 0))
        b.bind(("127.0.0.1", 0))
        grpc_port, web_port = a.getsockname()[1], b.getsockname()[1]
    session = ViewerSession(ViewerTarget(serve=True, grpc_port=grpc_port, web_port=web_port))
    group = session.server.pid if session.server is not None else -1
    try:
        assert session.server is not None and session.server.poll() is None
        listening = Path("/proc/net/tcp").read_text() if Path("/proc/net/tcp").exists() else ""
        for port in (grpc_port, web_port):
            entries = [line.split()[1] for line in listening.splitlines()[1:] if line.split()[3] == "0A"]
            mine = [e for e in entries if int(e.split(":")[1], 16) == port]
            assert mine and all(e.split(":")[0] == "0100007F" for e in mine), (port, mine)  # 127.0.0.1 only
        assert f"127.0.0.1:{web_port}" in session.web_url
        session.recording.log("probe", rr.TextLog("hello"))  # type: ignore[union-attr]
    finally:
        session.close(keep_serving=False)
    assert session.server is None
    with pytest.raises(ProcessLookupError):  # the viewer binary the rerun launcher started is gone too
        os.killpg(group, 0)


@pytest.mark.parametrize(("argv", "bodies"), [
    (["demo", "--motion"], True),
    (["demo"], True),
    (["demo", "--motion", "--no-bodies"], False),
    (["run", "--source", "sim:S1", "--no-bodies"], False),
    (["run", "--source", "sim:S1", "--bodies"], True),
])
def test_the_simulated_people_have_bodies_unless_told_otherwise(argv: list[str], bodies: bool,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """`avhear demo` and `avhear run --source sim:` draw people with bodies by default (issue 18); --no-bodies gives
    the flat scene."""
    import app.sources.open
    from app.errors import UserError

    asked: dict[str, object] = {}

    def stop(spec: str, **kwargs: object) -> None:
        asked.update(kwargs)
        raise UserError("stopped here")

    monkeypatch.setattr(app.sources.open, "open_source", stop)  # where the command takes it from when it runs
    assert main([*argv, "--headless"]) == 2
    assert asked["bodies"] is bodies


def test_a_simulated_run_in_real_time_stamps_from_zero(tmp_path: Path) -> None:
    """`stamp_s` is on the source's clock: the simulator's starts at 0 whether paced in real time or not (it was
    the machine's uptime in real time)."""
    out = tmp_path / "r.jsonl"
    assert main(["run", "--source", "sim:S1", "--duration", "1.5", "--headless", "--results-jsonl", str(out)]) == 0
    stamps = [json.loads(line)["stamp_s"] for line in out.read_text().splitlines()]
    assert stamps and 0.0 <= stamps[0] < 0.2 and stamps[-1] < 1.5
    latencies = [json.loads(line)["latency_s"] for line in out.read_text().splitlines()]
    assert all(lat is not None and 0.0 < lat < 5.0 for lat in latencies)  # measured on the same clock


def test_a_replay_stops_after_its_duration(tmp_path: Path) -> None:
    folder, out = tmp_path / "s1", tmp_path / "r.jsonl"
    assert main(["simulate", "S1", "-o", str(folder), "--duration", "4", "--fps", "10"]) == 0
    assert main(["run", "--source", f"replay:{folder}", "--duration", "1.5", "--fast", "--headless",
                 "--results-jsonl", str(out)]) == 0
    stamps = [json.loads(line)["stamp_s"] for line in out.read_text().splitlines()]
    assert stamps and max(stamps) < 1.5 and len(stamps) >= 12  # 1.5 s of the 4 s, at 10 FPS


def test_a_self_calibrated_run_saves_its_rig(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """--self-calibrate --save-rig: the rig file the run writes holds the cameras and the learned correction (the
    simulated room's is about c1 = 0.81, c0 = 0), and the next run reads it with --rig; --save-rig alone is one line."""
    from app.config import load_rig

    rig_file = tmp_path / "learned.yaml"
    assert main(["demo", "--duration", "8", "--fast", "--headless", "--self-calibrate", "--save-rig",
                 str(rig_file)]) == 0
    assert f"the self-calibrated rig is in {rig_file}" in capsys.readouterr().out
    rig = load_rig(rig_file)
    assert rig.stereo is not None and rig.microphones is not None
    assert abs(rig.microphones.c1 - 0.81) < 0.08 and abs(rig.microphones.c0) < 8e-6
    assert main(["demo", "--headless", "--save-rig", str(tmp_path / "x.yaml")]) == 2
    assert "--save-rig keeps what --self-calibrate learns" in capsys.readouterr().err


def test_an_arrays_learned_turn_goes_into_the_saved_rig(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """--save-rig after an array's self-calibration: the file holds the array turned as learned (its microphones
    where the turn puts them, each pair's c1, c0), says the turn in its header, and reads back as that array."""
    from types import SimpleNamespace

    import numpy as np

    from app.commands.run import _save_learned_rig
    from app.config import load_rig
    from avcore.geometry import MicArray

    given = MicArray.preset("respeaker4")
    state = [{"c1": 0.9 + 0.01 * p, "c0_s": 1e-6 * p, "inliers": 40, "observations": 50, "array_yaw_deg": -8.0}
             for p in range(given.n_pairs)]
    path = tmp_path / "learned.yaml"
    _save_learned_rig(path, SimpleNamespace(array=given, rig=None), state)
    assert "the array turned -8.0 degrees about the vertical" in path.read_text()
    assert "the array turned -8.0 degrees" in capsys.readouterr().out
    saved = load_rig(path).array
    assert saved is not None and saved.pairs == given.pairs and saved.channels == given.channels
    np.testing.assert_allclose(np.asarray(saved.positions), np.asarray(given.turned(np.radians(-8.0)).positions),
                               atol=1e-9)
    np.testing.assert_allclose(saved.c1, [s["c1"] for s in state])
    np.testing.assert_allclose(saved.c0, [s["c0_s"] for s in state])
