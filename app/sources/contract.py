"""The one Source contract: what the pipeline takes from cameras and microphones, whatever delivers them (live
devices, the simulated room, a recording, the bus). Sources derive from :class:`SourceBase` for the defaults."""
from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:  # the contract itself imports nothing heavy: a source's module brings what it needs
    from app.events import AudioBlock, StereoFrame
    from avcore.geometry import MicArray, MicPair
    from avcore.stereo import StereoRig

__all__ = ["Source", "SourceBase"]


class Source(Protocol):
    """What the pipeline needs from a source.

    rig : the rectifying stereo calibration; mics : the microphone pair (with c1, c0); samplerate_hz : of the audio
    blocks; channels : the (left, right) channel numbers within a block.
    array : several microphones (a :class:`MicArray` of two pairs or more, its ``channels`` within a block), or
        None for the one pair ``mics``; with an array, ``mics`` and ``channels`` are its first pair.
    frames(stop), audio(stop) : blocking iterators of stamped frames and audio blocks, on one clock, paced by the
        source (real time, or as fast as possible for a replay); they end when the source is exhausted or ``stop``
        is set.
    realtime : False for a replay as fast as possible, which gets back-pressure instead of drops (nothing of a
        recording is lost); True for everything delivered at capture pace.
    overflows : audio samples lost at the input (a sound card's overflows, a bus's dropped blocks), counted.
    frames_dropped : frames skipped at the input because they came late or could not be paired, counted.
    clock() : now, on the clock of the stamps (the pipeline's latency is ``clock() - stamp``). The convention of
        every source: live devices and the bus stamp on the capturing machine's monotonic clock; the simulator and a
        recording stamp on their own clock (the simulator from 0, a recording as it was captured), paced in real
        time or not.
    close() : release what the source holds (files, subscriptions); a source is also a context manager.
    """

    rig: StereoRig
    mics: MicPair
    samplerate_hz: float
    channels: tuple[int, int]
    realtime: bool
    array: MicArray | None

    @property
    def overflows(self) -> int: ...

    @property
    def frames_dropped(self) -> int: ...

    def frames(self, stop: threading.Event) -> Iterator[StereoFrame]: ...

    def audio(self, stop: threading.Event) -> Iterator[AudioBlock]: ...

    def clock(self) -> float: ...

    def close(self) -> None: ...


class SourceBase:
    """Defaults of the contract: real time, nothing counted, nothing to close; a context manager."""

    realtime: bool = True
    array: MicArray | None = None
    overflows: int = 0
    frames_dropped: int = 0

    def clock(self) -> float:
        """The capturing machine's monotonic clock (live devices, the bus)."""
        return time.monotonic()

    def close(self) -> None:
        """Nothing to release."""

    def __enter__(self) -> SourceBase:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
