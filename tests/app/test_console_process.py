"""The console in a process of its own (app/console/process.py): what it logs reaches the .rrd as the console in a
thread writes it, a long run's parts start in the child, a viewer that is not there is one line, and a child that
dies during the run costs the run its console, not the run."""
from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np
import pytest

from app.console.process import ConsoleProcess
from app.console.viewer import ViewerTarget
from app.errors import UserError
from avcore.geometry import MicArray
from tests.app.test_console import MICS, RIG, Rrd, _frame


def test_the_frames_reach_the_file_as_the_console_logs_them(tmp_path: Path) -> None:
    """A replay (back-pressure): every frame handed over is in the .rrd once, with its people and its words, and the
    array's pairs are drawn as the console in the pipeline's thread drew them."""
    from app.speech.transcriber import Words

    path = tmp_path / "run.rrd"
    console = ConsoleProcess(ViewerTarget(save=path), RIG, MICS, MicArray.preset("respeaker4"), backpressure=True)
    for i in range(12):
        if i == 6:
            console.log_words([Words(person_id=0, utterance=0, start_s=0.0, end_s=0.2, text="three one four",
                                     confidence=0.9, final=True)])
        console.log(_frame(frame=i, stamp_s=i / 30, itds_s=np.full((2, 6), 1e-5)))
    console.close()
    assert console.parts == [path] and console.dropped == 0 and console.lost == 0
    rrd = Rrd(path)
    assert rrd.frames("/scene/cameras/left/faces", "Boxes2D:centers") == list(range(12))
    assert any("three one four" in str(v) for rows in rrd.rows.values() for f, row in rows if f is not None and f >= 6
               for v in row.values())
    assert any(p.startswith("/itd_pairs") for p in rrd.rows)  # several pairs: their panes


def test_a_long_run_goes_into_parts_started_in_the_child(tmp_path: Path) -> None:
    path = tmp_path / "long.rrd"
    console = ConsoleProcess(ViewerTarget(save=path, part_s=0.3), RIG, MICS)
    for i in range(8):
        console.log(_frame(frame=i))
        time.sleep(0.12)
    console.close()
    assert len(console.parts) >= 2 and console.parts[0] == path
    assert console.parts[1] == tmp_path / "long.part2.rrd"
    seen = sorted(f for part in console.parts for f in Rrd(part).frames("/counts", "Scalars:scalars"))
    assert seen == list(range(8))


def test_a_viewer_that_does_not_take_the_connection_is_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    """The child opens the recording; its user error comes back as the parent's, and nothing is left running."""
    import socket

    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(UserError, match=f"no Rerun viewer at rerun\\+http://127.0.0.1:{port}/proxy"):
        ConsoleProcess(ViewerTarget(connect=f"rerun+http://127.0.0.1:{port}/proxy"), RIG, MICS)


def test_a_console_process_that_dies_costs_the_run_its_console_only(tmp_path: Path,
                                                                    caplog: pytest.LogCaptureFixture) -> None:
    console = ConsoleProcess(ViewerTarget(save=tmp_path / "run.rrd"), RIG, MICS)
    console.log(_frame(frame=0))
    deadline = time.monotonic() + 10
    while len(console._frames) and time.monotonic() < deadline:
        time.sleep(0.01)
    console.child.proc.kill()
    console.child.proc.wait()
    with caplog.at_level(logging.WARNING):
        for i in range(1, 6):
            console.log(_frame(frame=i))
            time.sleep(0.02)
        console.close()  # no exception: the run ends as it would have
    assert console.lost >= 4 and console.child.failed
    assert "the console's process ended during the run" in caplog.text


def test_the_runs_process_hands_frames_over_without_loading_rerun() -> None:
    """Rerun (and pyarrow, 60 MB) is loaded by the console's process only: the run's process builds the frames."""
    import subprocess
    import sys

    code = ("import sys; import app.commands.run, app.pipeline, app.sinks, app.console.process; "
            "from app.console import ConsoleFrame; print(sorted({'rerun', 'pyarrow'} & set(sys.modules)))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                          cwd=Path(__file__).resolve().parents[2])
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_live_the_oldest_frames_are_dropped_and_counted_never_the_newest(tmp_path: Path) -> None:
    """Live, :meth:`log` never waits: frames handed over faster than the child logs them are dropped, oldest first,
    and counted; what is logged and what is dropped add up, and the run's last frame is in the file."""
    path = tmp_path / "live.rrd"
    console = ConsoleProcess(ViewerTarget(save=path), RIG, MICS, queue_size=1)
    frames = [_frame(frame=i) for i in range(50)]
    for frame in frames:  # far faster than 30 a second
        console.log(frame)
    console.close()
    logged = Rrd(path).frames("/scene/cameras/left/faces", "Boxes2D:centers")
    assert console.dropped >= 1 and len(logged) + console.dropped == 50
    assert logged == sorted(logged) and logged[-1] == 49
