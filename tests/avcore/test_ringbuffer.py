from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avcore.ringbuffer import RingBuffer


def ramp(start: int, n: int, channels: int) -> np.ndarray:
    """Samples whose value encodes their absolute index and channel, to see exactly what came back."""
    idx = np.arange(start, start + n, dtype=np.float64)[:, None]
    return idx * 10 + np.arange(channels)[None, :]


@settings(max_examples=60, deadline=None)
@given(capacity=st.integers(1, 40), channels=st.integers(1, 4),
       sizes=st.lists(st.integers(0, 90), min_size=1, max_size=12), data=st.data())
def test_read_equals_tail_of_written_across_wraps(capacity, channels, sizes, data):
    buf = RingBuffer(channels, capacity)
    written = np.zeros((0, channels))
    for n in sizes:
        block = ramp(written.shape[0], n, channels)
        first = buf.append(block)
        assert first == written.shape[0]
        written = np.concatenate([written, block])
        assert buf.total_written == written.shape[0]
        assert len(buf) == min(capacity, written.shape[0])
        k = data.draw(st.integers(0, len(buf)))
        np.testing.assert_array_equal(buf.read_latest(k), written[written.shape[0] - k:])
        if len(buf):
            end = data.draw(st.integers(buf.oldest_index + 1, buf.total_written))
            k2 = data.draw(st.integers(0, end - buf.oldest_index))
            np.testing.assert_array_equal(buf.read_ending_at(end, k2), written[end - k2:end])


def test_append_does_not_reallocate_storage():
    buf = RingBuffer(2, 16)
    storage = buf._data
    for n in (5, 7, 30, 1):
        buf.append(np.ones((n, 2)))
    assert buf._data is storage


def test_read_outside_the_held_samples_is_an_error():
    buf = RingBuffer(1, 8)
    buf.append(np.arange(20.0))
    with pytest.raises(ValueError, match="future"):
        buf.read_ending_at(21, 2)
    with pytest.raises(ValueError, match="oldest sample"):
        buf.read_ending_at(15, 8)
    with pytest.raises(ValueError, match="capacity"):
        buf.read_latest(9)
    np.testing.assert_array_equal(buf.read_ending_at(20, 8)[:, 0], np.arange(12.0, 20.0))


def test_read_into_out_argument():
    buf = RingBuffer(2, 8)
    buf.append(ramp(0, 11, 2))
    out = np.empty((4, 2))
    assert buf.read_latest(4, out=out) is out
    np.testing.assert_array_equal(out, ramp(7, 4, 2))


def test_bad_arguments():
    with pytest.raises(ValueError, match="n_channels"):
        RingBuffer(0, 8)
    with pytest.raises(ValueError, match="capacity"):
        RingBuffer(2, 0)
    with pytest.raises(ValueError, match=r"shape \(n, 2\)"):
        RingBuffer(2, 8).append(np.zeros((4, 3)))
    assert RingBuffer.for_duration(2, 0.15, 16000).capacity == 2400

