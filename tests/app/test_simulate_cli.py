"""`avhear simulate` end to end on a clean machine (no ../shared/data): CLI -> recording -> the pipeline's front-ends
(face detection and F3D on the frames, ITD extraction on the audio) agree with the recorded ground truth."""
from __future__ import annotations

import numpy as np

from app.cli import main
from app.sources.recording import open_recording
from app.events import StereoFrame
from avcore.faces import locate_faces
from avcore.itd import extract_itds


def test_simulate_writes_a_recording_that_the_front_ends_read(tmp_path, capsys, face_finder):
    out = tmp_path / "s1"
    missing = tmp_path / "no-shared-data"
    status = main(["simulate", "S1", "-o", str(out), "--duration", "2.5", "--fps", "8", "--seed", "3",
                   "--data", str(missing)])
    printed = capsys.readouterr().out
    assert status == 0
    assert "frames 20/20 (100 %)" in printed and "speech: synthetic, faces: drawn" in printed
    assert f"wrote {out}" in printed

    rec = open_recording(out)
    assert rec.has_truth and rec.meta["scenario"] == "S1" and rec.meta["seed"] == 3
    frames, blocks = [], []
    for item in rec.stream():
        (frames if isinstance(item, StereoFrame) else blocks).append(item)
    assert len(frames) == 20
    # F3D on the replayed frames finds the person where the truth says (section 5.2)
    errors = []
    for f in frames[::4]:
        faces = locate_faces(f.left, f.right, rec.stereo, detector=face_finder)
        assert len(faces) >= 1  # the detector may add a false positive on the background; the person is there
        errors.append(np.min(np.linalg.norm(faces.points - rec.truth(f.index).positions_m[0], axis=1)))
    assert np.median(errors) < 0.1
    # ITDs of the replayed audio are those of the person while they speak (section 5.1)
    audio = np.concatenate([b.samples for b in blocks]).astype(np.float64)
    track = extract_itds(audio[:, rec.channels["left"]], audio[:, rec.channels["right"]], rec.samplerate_hz,
                         method="gcc-phat")
    assert len(track) >= 10
    truth_itd = rec.truth(frames[0].index).itds_s[0]
    assert abs(np.median(track.itds_s) - truth_itd) < 40e-6


def test_simulate_refuses_to_overwrite_and_rejects_bad_options(tmp_path, capsys):
    out = tmp_path / "s4"
    args = ["simulate", "S4", "-o", str(out), "--duration", "1", "--fps", "4", "--data", str(tmp_path / "none")]
    assert main(args) == 0
    assert main(args) == 2
    assert "already holds a recording" in capsys.readouterr().err
    assert main(args + ["--force"]) == 0
    assert main(["simulate", "S4", "-o", str(out), "--duration", "0.2", "--force"]) == 2
    assert "duration_s must be between 1 and 3600" in capsys.readouterr().err


def test_simulate_draws_bodies_unless_asked_not_to(tmp_path, capsys):
    """The recording's people have bodies by default (as in demo and eval scenarios); --no-bodies gives the flat
    scene. The same seed draws the same room, so the two recordings' first images differ by the bodies alone."""
    images = {}
    for flag in ([], ["--no-bodies"]):
        out = tmp_path / ("flat" if flag else "bodies")
        assert main(["simulate", "S1", "-o", str(out), "--duration", "1", "--fps", "4", "--seed", "1",
                     "--data", str(tmp_path / "none"), "--video", "png", *flag]) == 0
        first = next(item for item in open_recording(out).stream() if isinstance(item, StereoFrame))
        images[bool(flag)] = first.left.astype(float)
    capsys.readouterr()
    changed = np.abs(images[False] - images[True]).mean(axis=-1) > 30
    assert 0.02 < changed.mean() < 0.6  # arms, hands, a table: a part of the image, not all of it
