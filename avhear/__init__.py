"""avhear's Python API for programs in the same process.

```python
import avhear

for result in avhear.results("sim:S2", duration_s=5):   # or "replay:recordings/NAME", or "live" with rig_path=
    for person in result.people:
        if person.speaking:
            print(f"{result.stamp_s:6.2f} s: person {person.id} speaks at {person.position_m} m")
```

Each result is an :class:`app.result.Result`: ``stamp_s``, ``index``, ``mode``, ``people`` (each an
:class:`app.result.Person`: ``id``, ``position_m``, ``speaking``, ``probability``, ``itd_s`` per microphone pair,
``box_px`` or None), the interval's ITDs, the latency, with several microphone pairs ``voices`` (the voices out of
view: :class:`app.hearing.Voice`, an id and a direction), and ``as_dict()`` (a line of the results file). The
pipeline runs in threads while you iterate; leaving the loop (``break``, an exception, or closing the iterator) stops
it.

Each person's voice, steered at them by all the microphones (:mod:`avcore.separation`)::

    for chunk in avhear.voices("sim:S5", duration_s=10):    # VoiceChunk: person_id, stamp_s, samples (16 kHz)
        streams.setdefault(chunk.person_id, []).append(chunk.samples)
"""
from __future__ import annotations

import queue
import threading
from collections.abc import Iterator

__all__ = ["results", "voices"]


def results(source: str = "sim:S2", *, duration_s: float | None = None, realtime: bool = False, seed: int = 0,
            motion: bool = False, rig_path: str | None = None, mics: str = "pair", max_waiting: int = 64) -> Iterator:
    """Fused results of ``source`` (``sim:S1..S5``, ``replay:FOLDER`` or ``live`` with ``rig_path``), in order.

    mics : the simulated robot's microphones (:data:`avcore.geometry.ARRAY_PRESETS`, e.g. "nao").
    realtime : deliver at the source's pace (a live source always is); False replays as fast as the pipeline goes.
    max_waiting : results held for a consumer slower than the pipeline; the pipeline waits for room (a live
        source then drops frames at its input, counted in the pipeline's statistics).
    """
    return _stream(source, "results", duration_s=duration_s, realtime=realtime, seed=seed, motion=motion,
                   rig_path=rig_path, mics=mics, max_waiting=max_waiting)


def voices(source: str = "sim:S5", *, duration_s: float | None = None, realtime: bool = False, seed: int = 0,
           motion: bool = False, rig_path: str | None = None, mics: str = "pair", max_waiting: int = 1024) -> Iterator:
    """Each person's voice from ``source`` (as :func:`results`): :class:`avcore.separation.VoiceChunk` s, each
    ``person_id`` (the results' person id), ``stamp_s`` (its first sample's capture time, the results' clock) and
    ``samples`` (float32, 16 kHz mono), in time order; a person's chunks follow each other without a gap while they
    are there, through their silences."""
    return _stream(source, "voices", duration_s=duration_s, realtime=realtime, seed=seed, motion=motion,
                   rig_path=rig_path, mics=mics, max_waiting=max_waiting)


def _stream(source: str, what: str, *, duration_s: float | None, realtime: bool, seed: int, motion: bool,
            rig_path: str | None, mics: str, max_waiting: int) -> Iterator:
    from app.pipeline import Pipeline, PipelineConfig
    from app.sources.open import open_source

    src = open_source(source, realtime=realtime or source == "live", duration_s=duration_s, seed=seed,
                      rig_path=rig_path, mics=mics)
    waiting: queue.Queue = queue.Queue(maxsize=max_waiting)
    stop = threading.Event()
    end = object()

    def hand_over(item: object) -> None:
        while not stop.is_set():
            try:
                waiting.put(item, timeout=0.1)
                return
            except queue.Full:
                continue

    config = PipelineConfig(inference="motion" if motion else "face", voices=what == "voices")
    pipeline = (Pipeline(src, config, hand_over) if what == "results"
                else Pipeline(src, config, None, on_voice=hand_over))
    failure: list[BaseException] = []

    def run() -> None:
        try:
            pipeline.run(duration_s=duration_s if source == "live" else None)
        except BaseException as exc:  # handed to the consumer
            failure.append(exc)
        finally:
            hand_over(end)

    worker = threading.Thread(target=run, name="avhear-api", daemon=True)
    worker.start()
    try:
        while True:
            item = waiting.get()
            if item is end:
                break
            yield item
        if failure:
            raise failure[0]
    finally:
        stop.set()
        pipeline.stop()
        worker.join(5.0)
        src.close()
