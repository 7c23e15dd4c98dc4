"""The ITD worker in a process of its own (app/itd_process.py): the messages of the same arithmetic in the pipeline's
process, in the same order; a worker that cannot start is said with its reason."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from app.child_process import ChildProcessFailed
from app.itd_process import FrameItdsMessage, ItdProcess, ItdWorker
from app.pipeline_config import DEFAULT_ITD_METHOD
from avcore.geometry import MicArray

FS = 16000


def _talker_blocks(array: MicArray, seconds: float = 2.0, block: int = 512) -> list[tuple[float, np.ndarray]]:
    """Noise bursts from 40 degrees to the left on every microphone of ``array`` (a whole-sample delay each), cut
    into blocks, with a lost block after 1 s (a gap the streams restart at)."""
    rng = np.random.default_rng(5)
    n = int(FS * seconds)
    source = rng.standard_normal(n + 64) * (np.sin(np.arange(n + 64) / FS * 2 * np.pi * 2) > 0)
    direction = np.array([np.sin(np.radians(40)), 0.0, np.cos(np.radians(40))])
    delays = np.rint((array.positions @ direction) / array.speed_of_sound * FS).astype(int) + 32  # nearer: sooner
    x = np.zeros((n, max(array.channels) + 1))
    for q, ch in enumerate(array.channels):
        x[:, ch] = source[delays[q]:delays[q] + n] + 0.01 * rng.standard_normal(n)
    blocks = [(start / FS, x[start:start + block]) for start in range(0, n - block + 1, block)]
    return [b for k, b in enumerate(blocks) if k != int(1.0 * FS / block)]


def _same(a: object, b: object) -> None:
    assert type(a) is type(b)
    for f in dataclasses.fields(a):  # type: ignore[arg-type]
        x, y = getattr(a, f.name), getattr(b, f.name)
        if dataclasses.is_dataclass(x) or isinstance(x, tuple):
            for u, v in zip(dataclasses.astuple(x) if dataclasses.is_dataclass(x) else x,
                            dataclasses.astuple(y) if dataclasses.is_dataclass(y) else y):
                np.testing.assert_array_equal(u, v)
        else:
            np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("dereverb", [False, True])
def test_the_process_gives_the_workers_messages_in_order(dereverb: bool) -> None:
    array = MicArray.preset("respeaker4")
    options = dict(array=array, samplerate_hz=FS, itd_method=DEFAULT_ITD_METHOD, window_s=0.15, hop_s=0.02,
                   energy_threshold=1e-3, frame_itds=True, envelope=True, dereverb=dereverb)
    here, there = ItdWorker(**options), ItdProcess(**options)
    try:
        gaps, kinds = [], set()
        for stamp, samples in _talker_blocks(array):
            mine, gap = here.push(stamp, samples)
            theirs, their_gap = there.push(stamp, samples)
            assert gap == their_gap and len(mine) == len(theirs)
            for a, b in zip(mine, theirs):
                _same(a, b)
                kinds.add(type(a).__name__)
            gaps.append(gap)
    finally:
        there.close()
    assert sum(gaps) == 1  # the lost block
    assert kinds == {"EnvelopeMessage", "FrameItdsMessage", "ItdMessage", "ClockMessage"}
    assert there.child.proc.returncode == 0


def test_the_workers_itds_point_at_the_talker() -> None:
    """What the process computes is the ITDs themselves: each pair's median window ITD is the talker's."""
    array = MicArray.preset("respeaker4")
    worker = ItdWorker(array, FS, itd_method=DEFAULT_ITD_METHOD, window_s=0.15, hop_s=0.02, energy_threshold=1e-3,
                       frame_itds=True, envelope=False, dereverb=False)
    itds = [m.itd_s for stamp, samples in _talker_blocks(array) for m in worker.push(stamp, samples)[0]
            if type(m).__name__ == "ItdMessage"]
    direction = np.array([np.sin(np.radians(40)), 0.0, np.cos(np.radians(40))])
    expected = array.itd(direction[None] * 3.0)[0]
    np.testing.assert_allclose(np.nanmedian(np.array(itds), axis=0), expected, atol=1.5 / FS)
    frames = [m for stamp, samples in _talker_blocks(array)[:20] for m in worker.push(stamp, samples)[0]
              if isinstance(m, FrameItdsMessage)]
    assert frames and all(m.bins is not None for m in frames)


def test_a_worker_that_cannot_start_is_said_with_its_reason() -> None:
    array = MicArray.preset("respeaker4")
    proc = ItdProcess(array=array, samplerate_hz=FS, itd_method="no-such-method", window_s=0.15, hop_s=0.02,
                      energy_threshold=1e-3, frame_itds=False, envelope=False, dereverb=False)
    try:
        with pytest.raises(ChildProcessFailed, match="(?s)the ITD process failed.*no-such-method"):
            proc.push(0.0, np.zeros((512, 4)))
    finally:
        proc.close()


def test_a_released_process_serves_the_next_run_as_a_new_one_would() -> None:
    """A run that ended cleanly leaves its process to the next (app.child_process: an evaluation runs dozens of
    pipelines); the next run's options are its own, and nothing of the last run's streams is left in it."""
    array = MicArray.preset("respeaker4")
    blocks = _talker_blocks(array, seconds=1.0)
    first = dict(array=array, samplerate_hz=FS, itd_method=DEFAULT_ITD_METHOD, window_s=0.15, hop_s=0.02,
                 energy_threshold=1e-3, frame_itds=False, envelope=False, dereverb=False)
    second = dict(first, frame_itds=True, envelope=True, dereverb=True)
    proc = ItdProcess(**first)
    pid = proc.child.proc.pid
    for stamp, samples in blocks:
        proc.push(stamp, samples)
    proc.release()
    again, fresh = ItdProcess(**second), ItdWorker(**second)
    try:
        assert again.child.proc.pid == pid
        for stamp, samples in blocks:
            theirs, their_gap = again.push(stamp, samples)
            mine, gap = fresh.push(stamp, samples)
            assert gap == their_gap and len(mine) == len(theirs)
            for a, b in zip(mine, theirs):
                _same(a, b)
    finally:
        again.close()


def test_a_process_that_failed_is_not_handed_on() -> None:
    array = MicArray.preset("respeaker4")
    options = dict(array=array, samplerate_hz=FS, itd_method="no-such-method", window_s=0.15, hop_s=0.02,
                   energy_threshold=1e-3, frame_itds=False, envelope=False, dereverb=False)
    proc = ItdProcess(**options)
    with pytest.raises(ChildProcessFailed):
        proc.push(0.0, np.zeros((512, 4)))
    proc.release()  # what a careless caller might do: the child has ended, so it is closed, not kept
    assert proc.child.proc.poll() is not None
    good = ItdProcess(**dict(options, itd_method=DEFAULT_ITD_METHOD))
    try:
        assert good.child.proc.pid != proc.child.proc.pid
        assert good.push(0.0, np.zeros((512, 4)))[0]
    finally:
        good.close()


def test_a_released_process_that_died_while_it_waited_is_replaced() -> None:
    array = MicArray.preset("respeaker4")
    options = dict(array=array, samplerate_hz=FS, itd_method=DEFAULT_ITD_METHOD, window_s=0.15, hop_s=0.02,
                   energy_threshold=1e-3, frame_itds=False, envelope=False, dereverb=False)
    proc = ItdProcess(**options)
    proc.push(0.0, np.zeros((512, 4)))
    proc.release()
    proc.child.proc.kill()  # an out-of-memory killer, say
    proc.child.proc.wait(10)
    again = ItdProcess(**options)
    try:
        assert again.child.proc.pid != proc.child.proc.pid
        assert again.push(0.0, np.zeros((512, 4)))[0]
    finally:
        again.close()
