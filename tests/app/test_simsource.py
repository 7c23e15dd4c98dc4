"""Tests of app.sources.sim: the simulated room as a stream, consistent with its ground truth (issue 5, section 1).

Everything runs without ../shared/data (``data_dir`` points to a missing folder): drawn faces, synthetic speech.
"""
from __future__ import annotations

import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.events import AudioBlock, StereoFrame
from app.sources.sim import SimSource, load_clip_bank, render_audio
from avcore.faces import detect_faces
from avcore.itd import extract_itds
from sim.scenario import make_scenario


@pytest.fixture(scope="module")
def missing(tmp_path_factory):
    return tmp_path_factory.mktemp("clean") / "no-shared-data"


@pytest.fixture(scope="module")
def s2(missing):
    return SimSource.from_preset("S2", duration_s=3.0, seed=5, fps=10, data_dir=missing)


def _iou(a, b):
    ix = max(0.0, min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]))
    return ix * iy / (a[2] * a[3] + b[2] * b[3] - ix * iy)


def test_without_shared_data_it_falls_back_to_drawn_faces_and_synthetic_speech(s2):
    assert s2.meta["speech"] == "synthetic" and s2.meta["faces"] == "drawn"
    assert s2.audio.clipped == 0


def test_same_seed_same_stream_other_seed_other_stream(s2, missing):
    again = SimSource.from_preset("S2", duration_s=3.0, seed=5, fps=10, data_dir=missing)
    other = SimSource.from_preset("S2", duration_s=3.0, seed=6, fps=10, data_dir=missing)
    np.testing.assert_array_equal(s2.audio.samples, again.audio.samples)
    assert not np.array_equal(s2.audio.samples, other.audio.samples)
    for k in (0, 7, 29):
        a, b = s2._images(k), again._images(k)
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])


def test_stream_delivers_frames_and_blocks_in_order_on_one_clock(s2):
    items = list(s2.stream(block_size=400))
    frames = [i for i in items if isinstance(i, StereoFrame)]
    blocks = [i for i in items if isinstance(i, AudioBlock)]
    assert len(frames) == 30 and s2.n_frames == 30
    np.testing.assert_allclose([f.stamp_s for f in frames], np.arange(30) / 10)
    assert frames[0].left.shape == (480, 640, 3) and frames[0].left.dtype == np.uint8
    assert sum(b.samples.shape[0] for b in blocks) == 48000 and blocks[0].samples.shape == (400, 2)
    assert all(b.first_sample == i * 400 and b.stamp_s == pytest.approx(i * 400 / 16000) for i, b in enumerate(blocks))
    assert blocks[0].samples.dtype == np.float32 and np.abs(blocks[0].samples).max() < 1
    # delivery order: a block when its last sample is in, a frame at its stamp
    due = [i.end_stamp_s if isinstance(i, AudioBlock) else i.stamp_s for i in items]
    assert all(b >= a - 1e-9 for a, b in zip(due, due[1:]))
    # separate frame and audio iterators give the same items
    assert [f.stamp_s for f in s2.frames()] == [f.stamp_s for f in frames]
    assert [b.first_sample for b in s2.audio_blocks(block_size=400)] == [b.first_sample for b in blocks]
    assert all(s2.truth(f.index) is not None and s2.truth(f.index).positions_m.shape == (3, 3) for f in frames)


@settings(max_examples=15, deadline=None)
@given(block_size=st.integers(1, 20000))
def test_audio_blocks_of_any_size_add_up_to_the_recording(s2, block_size):
    blocks = list(s2.audio_blocks(block_size=block_size))
    np.testing.assert_array_equal(np.concatenate([b.samples for b in blocks]),
                                  s2.audio.samples.astype(np.float32) / 32768)
    assert all(b.stamp_s == pytest.approx(b.first_sample / 16000) for b in blocks)
    assert all(b.samples.shape[0] == block_size for b in blocks[:-1])


def test_the_cameras_first_frame_is_rendered_before_the_clock_starts(missing, monkeypatch):
    """The renderers build the room's textures at their first frame, several frame periods: a real-time stream
    renders it before its clock starts, so that its first frames are not skipped as late."""
    import threading

    from app.sources.open import StreamAdapter

    src = SimSource.from_preset("S1", duration_s=1.0, seed=0, fps=15, data_dir=missing, camera="rgbd")
    adapter = StreamAdapter(src, realtime=True)
    render, rendered = src._renderer.render, []
    monkeypatch.setattr(src._renderer, "render", lambda t: rendered.append((t, time.monotonic())) or render(t))
    first = next(iter(adapter.frames(threading.Event())))
    assert first.index == 0 and first.depth_m is not None
    assert [t for t, _ in rendered] == [0.0] and rendered[0][1] < adapter._start_s


def test_real_time_stream_paces_on_the_monotonic_clock_and_stamps_from_zero(missing):
    """Paced in real time, nothing is delivered before its capture instant; the stamps stay the simulator's own
    (from 0), the convention of the Source contract."""
    src = SimSource.from_preset("S1", duration_s=1.0, seed=0, fps=15, data_dir=missing)
    t0 = time.monotonic()
    items, early = [], []
    for item in src.stream(realtime=True, start_s=t0):
        due = item.end_stamp_s if isinstance(item, AudioBlock) else item.stamp_s
        early.append(t0 + due - time.monotonic())
        items.append(item)
    assert max(early) <= 1e-3
    assert items[0].stamp_s == pytest.approx(0.0, abs=1e-9)
    assert items[-1].stamp_s - items[0].stamp_s == pytest.approx(1.0, abs=0.1)  # a second of stream
    assert time.monotonic() - t0 >= 0.95  # paced: a second of stream takes a second at least
    assert src.stats.frames + src.stats.frames_dropped == 15


def test_faces_are_drawn_where_the_truth_says(s2, face_finder):
    for k in (0, 12, 25):
        left, _ = s2._images(k)
        truth = s2.truth(k)
        found = detect_faces(left, face_finder)
        for box, visible in zip(truth.boxes_left, truth.visible):
            assert visible
            assert max((_iou(box, f) for f in found), default=0.0) > 0.4, (k, box, found)


def test_the_talker_outside_the_view_is_not_in_the_image(missing, face_finder):
    src = SimSource.from_preset("S4", duration_s=1.0, seed=1, fps=5, data_dir=missing)
    truth = src.truth(2)
    found = detect_faces(src._images(2)[0], face_finder)
    assert truth.visible.tolist() == [False, True, True]
    assert len(found) == 2
    for box in truth.boxes_left[1:]:
        assert max(_iou(box, f) for f in found) > 0.4


def test_itds_of_the_active_talker_are_where_the_geometry_says(missing):
    """Little reverberation (RT60 0.15 s): the GCC-PHAT ITDs of windows with one talker sit at that talker's mapped
    position. (Reverberation pulls ITDs towards zero; at RT60 0.4 s by about a third, which the affine AV
    calibration of section 5.3 absorbs.)"""
    bank = load_clip_bank(16000, missing)
    sc = make_scenario("S2", clip_durations_s=bank.durations_s, duration_s=6.0, seed=2, rt60_s=0.15)
    audio = render_audio(sc, bank)
    x = audio.samples.astype(np.float64) / 32768
    track = extract_itds(x[:, 0], x[:, 1], 16000, method="gcc-phat")
    speaking = sc.speaking_at(track.times_s)
    truth = sc.truth(1.0).itds_s
    for i in range(3):
        alone = speaking[:, i] & (speaking.sum(axis=1) == 1)
        assert alone.sum() >= 10
        med = np.median(track.itds_s[alone])
        assert abs(med - truth[i]) < 35e-6, (i, med, truth[i])
        assert np.argmin(np.abs(truth - med)) == i


def test_a_moving_loudspeaker_is_heard_where_it_is(missing):
    """Calibration (section 5.3): the ITDs of the white-noise bursts follow the zig-zag of the loudspeaker."""
    src = SimSource.from_preset("calibration", duration_s=6.0, seed=0, fps=5, data_dir=missing)
    x = src.audio.samples.astype(np.float64) / 32768
    track = extract_itds(x[:, 0], x[:, 1], 16000, method="gcc-phat")
    assert len(track) > 100
    truth = np.array([src.scenario.truth(t).itds_s[0] for t in track.times_s])
    assert np.ptp(truth) > 150e-6
    assert np.corrcoef(track.itds_s, truth)[0, 1] > 0.9


def test_bad_arguments_are_named(missing):
    bank = load_clip_bank(16000, missing)
    sc = make_scenario("S1", clip_durations_s=bank.durations_s, duration_s=1.0)
    with pytest.raises(ValueError, match="fps"):
        SimSource(sc, bank, data_dir=missing, fps=200)
    with pytest.raises(ValueError, match="8000 Hz"):
        render_audio(sc, load_clip_bank(8000, missing))


def test_real_faces_and_digits_when_the_shared_data_is_there(shared_data, face_finder):
    """With ../shared/data: real face crops found where the truth says, real digits heard from the right side."""
    src = SimSource.from_preset("S2", duration_s=6.0, seed=0, fps=5, data_dir=shared_data)
    assert src.meta["speech"] == "digits" and src.meta["faces"] == "faces"
    hits = total = 0
    for k in range(0, src.n_frames, 3):
        truth, found = src.truth(k), detect_faces(src._images(k)[0], face_finder)
        for box in truth.boxes_left[truth.visible]:
            total += 1
            hits += max((_iou(box, f) for f in found), default=0.0) > 0.4
    assert hits >= 0.8 * total
    x = src.audio.samples.astype(np.float64) / 32768
    track = extract_itds(x[:, 0], x[:, 1], 16000, method="gcc-phat")
    speaking = src.scenario.speaking_at(track.times_s)
    medians = [np.median(track.itds_s[speaking[:, i] & (speaking.sum(axis=1) == 1)]) for i in range(3)]
    assert medians[0] < -40e-6 and abs(medians[1]) < 20e-6 and medians[2] > 40e-6  # left, centre, right


def test_an_rgbd_camera_gives_colour_and_depth_and_the_pipeline_finds_the_faces(missing):
    """camera="rgbd": each frame is the left camera's colour with a depth image aligned to it (no right image); the
    face-guided pipeline locates the faces from the depth, within 5 cm of the truth in every frame."""
    from app.pipeline import Pipeline, PipelineConfig
    from app.sources.open import StreamAdapter

    source = SimSource.from_preset("S1", duration_s=2.0, seed=3, fps=10, data_dir=missing, camera="rgbd")
    frames = list(source.frames(realtime=False))
    assert all(f.right is None and f.depth_m.dtype == np.float32 and f.depth_m.shape == f.left.shape[:2]
               for f in frames)
    truth = {f.index: source.truth(f.index) for f in frames}
    errors = []

    def keep(result) -> None:
        t = truth[result.index]
        for xyz in result.xyz:
            errors.append(np.min(np.linalg.norm(t.positions_m[t.visible] - xyz, axis=1)))

    stats = Pipeline(StreamAdapter(source, realtime=False), PipelineConfig(), keep).run()
    assert stats.bad_frames == 0 and len(errors) >= len(frames)
    assert max(errors) < 0.05
