"""The operator console as a person sees it: the demo's .rrd in the Rerun web viewer, served on 127.0.0.1 and
rendered by headless Chromium (Debian's chromium package); a DevTools screenshot once the data is loaded, taken by
`benchmarks/console_screenshots.py` (which makes the README's picture).

Slow (about a minute): `pytest -m slow tests/app/test_web_viewer.py`. With AVHEAR_SCREENSHOT=PATH the screenshot
is kept there."""
from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.cli import main

pytestmark = pytest.mark.slow

def test_console_in_the_web_viewer(tmp_path: Path, load_benchmark) -> None:  # noqa: ANN001
    shots = load_benchmark("console_screenshots")
    if shots.chromium_executable() is None:
        pytest.skip("Debian's chromium is not installed (apt-get install chromium)")
    pytest.importorskip("websocket", reason="pip install websocket-client (the test extra has it)")
    rrd = tmp_path / "demo.rrd"
    assert main(["demo", "--duration", "6", "--fast", "--save", str(rrd)]) == 0
    shot = shots.screenshot(rrd, Path(os.environ.get("AVHEAR_SCREENSHOT", tmp_path / "console.png")), wait_s=40)
    img = cv2.imread(str(shot))
    assert img is not None and img.shape[1] >= 1200
    # the loading screen is a flat dark page; the console has the camera image, panes and plots
    assert img.std() > 25, "the web viewer showed no data"
    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    assert np.count_nonzero(grey > 150) > 0.05 * grey.size  # the bright room of the camera pane is on screen
