"""Signals for the commands that write: Ctrl-C (SIGINT) and SIGTERM stop them the same way, between two items, so
that what they wrote ends at a complete frame; the previous handlers come back afterwards."""
from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["stop_on_signals"]

SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def stop_on_signals(stop: threading.Event, signals: tuple[int, ...] = SIGNALS) -> Iterator[threading.Event]:
    """Within the block, ``signals`` (SIGINT and SIGTERM) set ``stop`` (and remember which came in ``stop.signal``)
    instead of raising in whatever the main thread was doing; outside the main thread, nothing is installed."""
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return

    def handler(signum: int, _frame: object) -> None:
        stop.signal = signum  # type: ignore[attr-defined]
        stop.set()

    previous = {sig: signal.getsignal(sig) for sig in signals}
    for sig in signals:
        signal.signal(sig, handler)
    try:
        yield stop
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
