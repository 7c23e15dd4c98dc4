"""The operator console as a person sees it: the demo's .rrd in the Rerun web viewer, served on 127.0.0.1 and
rendered by headless Chromium (Debian's chromium package); a DevTools screenshot once the data is loaded.

Slow (about a minute): `pytest -m slow tests/app/test_web_viewer.py`. With AVHEAR_SCREENSHOT=PATH the screenshot
is kept there (the README's picture is made so)."""
from __future__ import annotations

import base64
import json
import os
import shutil
import socket
import subprocess
import time
import urllib.request
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.cli import main
from app.console.viewer import rerun_executable, stop_process_group

pytestmark = pytest.mark.slow


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _screenshot(chromium: str, url: str, out: Path, profile: Path, wait_s: float) -> None:
    websocket = pytest.importorskip("websocket", reason="pip install websocket-client (the test extra has it)")
    port = _free_port()
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


def test_console_in_the_web_viewer(tmp_path: Path) -> None:
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("Debian's chromium is not installed (apt-get install chromium)")
    rrd = tmp_path / "demo.rrd"
    assert main(["demo", "--duration", "6", "--fast", "--save", str(rrd)]) == 0
    grpc, web = _free_port(), _free_port()
    rerun = rerun_executable()
    assert rerun is not None
    server = subprocess.Popen([rerun, "--serve-web", "--bind", "127.0.0.1", "--port", str(grpc),
                               "--web-viewer-port", str(web), str(rrd)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    shot = Path(os.environ.get("AVHEAR_SCREENSHOT", tmp_path / "console.png"))
    try:
        time.sleep(2)
        url = f"http://127.0.0.1:{web}/?url=rerun%2Bhttp%3A%2F%2F127.0.0.1%3A{grpc}%2Fproxy"
        _screenshot(chromium, url, shot, tmp_path / "profile", wait_s=40)
    finally:
        stop_process_group(server)
    img = cv2.imread(str(shot))
    assert img is not None and img.shape[1] >= 1200
    # the loading screen is a flat dark page; the console has the camera image, panes and plots
    assert img.std() > 25, "the web viewer showed no data"
    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    assert np.count_nonzero(grey > 150) > 0.05 * grey.size  # the bright room of the camera pane is on screen
