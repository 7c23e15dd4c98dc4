"""Argument types shared by the commands: values are checked when the command line is parsed, so that a bad option is
one line from argparse (exit status 2) before any work starts, never a traceback from inside a thread."""
from __future__ import annotations

import argparse
import math
from collections.abc import Callable

__all__ = ["MAX_DURATION_S", "MAX_SIMULATED_S", "count", "duration", "port", "positive"]

MAX_DURATION_S = 24 * 3600.0  # a run or a recording of live devices: one day at most
MAX_SIMULATED_S = 1800.0  # the simulator renders a scenario's audio in memory: half an hour at most


def positive(text: str, *, maximum: float = math.inf, what: str = "a positive number") -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
    if value > maximum:
        raise argparse.ArgumentTypeError(f"{text} is more than the {maximum:g} allowed")
    return value


def duration(maximum: float = MAX_DURATION_S) -> Callable[[str], float]:
    """Seconds in (0, maximum]."""
    def parse(text: str) -> float:
        return positive(text, maximum=maximum, what="a positive number of seconds")
    parse.__name__ = "seconds"
    return parse


def count(minimum: int = 0, maximum: int | None = None) -> Callable[[str], int]:
    """An integer in [minimum, maximum]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if value < minimum or (maximum is not None and value > maximum):
            bound = f">= {minimum}" if maximum is None else f"between {minimum} and {maximum}"
            raise argparse.ArgumentTypeError(f"expected a whole number {bound}, got {text!r}")
        return value
    parse.__name__ = "integer"
    return parse


port = count(1, 65535)
