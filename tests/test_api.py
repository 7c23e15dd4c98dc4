"""`avhear.results`: the pipeline's results as an iterator in the caller's process."""
from __future__ import annotations

import threading

import avhear


def test_results_iterate_in_order_and_stop_when_the_loop_ends() -> None:
    stamps, speaking = [], []
    for result in avhear.results("sim:S2", duration_s=2):
        stamps.append(result.stamp_s)
        speaking += [p["speaking"] for p in result.as_dict()["people"]]
    assert len(stamps) == 60 and stamps == sorted(stamps)
    assert any(speaking) and not all(speaking)
    it = avhear.results("sim:S1", duration_s=5)
    first = next(it)
    it.close()  # leaving early stops the pipeline's threads
    assert first.index == 0
    assert not [t for t in threading.enumerate() if t.name.startswith("avhear-")]
