"""Pictures of the operator console as a person sees it: the demo's ``.rrd`` in Rerun's web viewer, served on
127.0.0.1 and rendered by headless Chromium (Debian's ``chromium``), one DevTools screenshot once the data is in.

    python benchmarks/console_screenshots.py --out /tmp/console      # face, motion, NAO; at frames 50 and 165
    python benchmarks/console_screenshots.py --out /tmp/c --runs face --frames 165

Each run is ``avhear demo --fast --duration 8 --save RUN.rrd`` (plus ``--motion`` or ``--mics nao``), cut at each
frame (its static data and the frames before it, :func:`cut`). The web viewer follows a streamed recording to its
end, as it follows a live run, so the part before frame 50 (1.7 s) shows the console at the start of a run and the
part before 165 (5.5 s) in its middle, both while someone in S2 speaks. The README's picture is ``--runs face --frames 165``
(``layouts/screenshot.png``). Needs the ``websocket-client`` package (the test extra has it).
``tests/app/test_web_viewer.py`` (slow) runs the same path.
"""
from __future__ import annotations

import argparse
import base64
import json
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

import pyarrow.compute as pc
import rerun as rr
from rerun.chunk import Chunk, RrdReader

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from app.cli import main as avhear  # noqa: E402
from app.console.viewer import rerun_executable, stop_process_group  # noqa: E402
from layouts.blueprint import APPLICATION_ID, default_blueprint  # noqa: E402

RUNS = {"face": [], "motion": ["--motion"], "nao": ["--mics", "nao"]}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _capture(chromium: str, url: str, out: Path, profile: Path, wait_s: float) -> None:
    import websocket  # websocket-client

    port = free_port()
    browser = subprocess.Popen(
        [chromium, "--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
         "--disable-quic", "--no-first-run", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", f"--user-data-dir={profile}", "--window-size=1600,1000",
         f"--remote-debugging-port={port}", url], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        tabs: list = []
        for _ in range(100):
            try:
                tabs = json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}/json", timeout=1))
                break
            except OSError:
                time.sleep(0.2)
        page = next(t for t in tabs if t.get("type") == "page")
        ws = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=60)
        time.sleep(wait_s)  # the viewer's wasm compiles and the data streams in
        ws.send(json.dumps({"id": 1, "method": "Page.captureScreenshot", "params": {"format": "png"}}))
        while True:
            reply = json.loads(ws.recv())
            if reply.get("id") == 1:
                break
        out.write_bytes(base64.b64decode(reply["result"]["data"]))
    finally:
        browser.terminate()
        browser.wait(10)


def _wait_for_port(port: int, server: subprocess.Popen, timeout_s: float = 60.0) -> None:
    """Until the web viewer's server takes connections (it starts slowly on a loaded machine)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and server.poll() is None:
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=1):
                return
        except OSError:
            time.sleep(0.2)
    raise RuntimeError(f"the rerun web viewer did not listen on 127.0.0.1:{port} within {timeout_s:g} s")


def cut(rrd: Path, frame: int, out: Path, several_pairs: bool) -> Path:
    """The recording up to (not including) ``frame`` of the frame timeline, with all its static data and the run's
    own layout, written to ``out``. (``rerun rrd split`` leaves out the cameras' static pinholes.)"""
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(str(out), default_blueprint=default_blueprint(several_pairs))
    for chunk in RrdReader(rrd).stream().to_chunks():
        batch = chunk.to_record_batch()
        if chunk.is_static or "frame" not in batch.schema.names:
            rr.send_chunks(chunk, recording=rec)
            continue
        kept = batch.filter(pc.less(batch.column("frame"), frame))
        if kept.num_rows:
            rr.send_chunks(Chunk.from_record_batch(kept), recording=rec)
    rec.flush()
    rec.disconnect()
    return out


def chromium_executable() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


def screenshot(rrd: Path, out: Path, wait_s: float = 40.0) -> Path:
    """Serve ``rrd`` with the ``rerun`` command's web viewer on 127.0.0.1 and save Chromium's view of it to ``out``."""
    chromium, rerun = chromium_executable(), rerun_executable()
    if chromium is None or rerun is None:
        raise RuntimeError("needs Debian's chromium (apt-get install chromium) and rerun-sdk's `rerun` command")
    grpc, web = free_port(), free_port()
    server = subprocess.Popen([rerun, "--serve-web", "--bind", "127.0.0.1", "--port", str(grpc),
                               "--web-viewer-port", str(web), str(rrd)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        _wait_for_port(web, server)
        url = f"http://127.0.0.1:{web}/?url=rerun%2Bhttp%3A%2F%2F127.0.0.1%3A{grpc}%2Fproxy"
        with tempfile.TemporaryDirectory() as profile:
            _capture(chromium, url, out, Path(profile), wait_s)
    finally:
        stop_process_group(server)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for RUN_Ts.png (and the .rrd files)")
    parser.add_argument("--runs", nargs="+", choices=sorted(RUNS), default=["face", "motion", "nao"])
    parser.add_argument("--frames", nargs="+", type=int, default=[50, 165], help="frames to look at (30 a second)")
    parser.add_argument("--wait", type=float, default=40.0, help="seconds Chromium gets to load the data")
    args = parser.parse_args(argv)
    if chromium_executable() is None or rerun_executable() is None:  # checked before minutes of demo runs
        print("console_screenshots: needs Debian's chromium (apt-get install chromium) and rerun-sdk's `rerun` "
              "command on PATH", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    for run in args.runs:
        rrd = args.out / f"{run}.rrd"
        if avhear(["demo", "--duration", "8", "--fast", "--save", str(rrd), *RUNS[run]]) != 0:
            return 1
        for frame in args.frames:
            with tempfile.TemporaryDirectory() as parts:
                before = cut(rrd, frame, Path(parts) / f"{run}_{frame}.rrd", several_pairs=run == "nao")
                print(screenshot(before, args.out / f"{run}_frame{frame}.png", args.wait), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
