"""Argument types shared by the commands: values are checked when the command line is parsed, so that a bad option is
one line from argparse (exit status 2) before any work starts, never a traceback from inside a thread."""
from __future__ import annotations

import argparse
import math
from collections.abc import Callable

__all__ = ["MAX_DURATION_S", "MAX_SIMULATED_S", "MIN_SIMULATED_S", "add_method_arguments", "count", "duration",
           "odd_count", "pipeline_config", "port", "positive", "wants_bodies"]

MAX_DURATION_S = 24 * 3600.0  # a run or a recording of live devices: one day at most
MAX_SIMULATED_S = 1800.0  # the simulator renders a scenario's audio in memory: half an hour at most
MIN_SIMULATED_S = 1.0  # and one second at least (sim.scenario's bound)


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


def odd_count(minimum: int, maximum: int) -> Callable[[str], int]:
    """An odd integer in [minimum, maximum]."""
    within = count(minimum, maximum)

    def parse(text: str) -> int:
        value = within(text)
        if value % 2 == 0:
            raise argparse.ArgumentTypeError(f"expected an odd number (a vote centred on each result), got {text!r}")
        return value
    parse.__name__ = "odd number"
    return parse


def add_method_arguments(p: argparse.ArgumentParser) -> None:
    """The pipeline's method options, the same for ``run``, ``demo`` and ``eval scenarios``
    (:func:`pipeline_config` reads them)."""
    from app.pipeline import DEFAULT_ITD_METHOD
    from avcore.itd import METHODS

    p.add_argument("--motion", action="store_true",
                   help="motion-guided inference (HM3D points, Algorithm 1) instead of face-guided (Algorithm 2)")
    p.add_argument("--itd-method", default=DEFAULT_ITD_METHOD, choices=sorted(METHODS),
                   help="ITD extractor: gcc-phat-robust (default), correlogram (the paper's), gcc-phat, "
                        "correlogram-robust")
    p.add_argument("--decision-window", type=duration(1.0), default=None, metavar="SECONDS",
                   help="face-guided: decide speaking on the ITDs within +- this of each frame only (EM still "
                        "fits on the +-0.2 s time frame); default: on all of them, as the paper")
    p.add_argument("--frame-itds", action=argparse.BooleanOptionalAction, default=True,
                   help="face-guided with gcc-phat-robust: the speaking test also looks at the single 32 ms "
                        "frames' ITDs, where a talker masked by a louder one in every 150 ms window still wins "
                        "some frames (default); --no-frame-itds decides on the windows' ITDs alone")
    p.add_argument("--vote-frames", type=odd_count(1, 99), default=9, metavar="N",
                   help="face-guided: each person's speaking state is the majority over N consecutive results "
                        "centred on it (odd; default 9, 0.3 s at 30 FPS); 1: each frame decides alone")


def add_mics_argument(p: argparse.ArgumentParser) -> None:
    """``--mics``: the simulated robot's microphones, one of the array presets."""
    from avcore.geometry import ARRAY_PRESETS

    p.add_argument("--mics", default="pair", choices=list(ARRAY_PRESETS),
                   help="the simulated robot's microphones: pair (default, the paper's 12 cm pair), nao (NAO's "
                        "four), respeaker4, respeaker-usb, respeaker6, ps3eye, uma8; with several, the face-guided "
                        "fusion uses every pair")


def add_bodies_argument(p: argparse.ArgumentParser) -> None:
    """``--bodies/--no-bodies``: how the simulated people are drawn; :func:`wants_bodies` resolves the
    default. None when neither is given, so that a real source can refuse either."""
    p.add_argument("--bodies", action=argparse.BooleanOptionalAction, default=None,
                   help="the simulated people have a checked shirt, arms and hands that gesture (most while they "
                        "talk), and the seated ones sit behind a table (default); --no-bodies: flat heads and "
                        "shirts that only nod, the scene of the earlier figures")


def wants_bodies(args: argparse.Namespace) -> bool:
    """Whether the simulated room draws bodies: yes unless ``--no-bodies``.

    Motion-guided inference (Algorithm 1) needs people that move like people (textured clothing, gesturing arms);
    face-guided inference looks at the faces, which the bodies do not cover."""
    return args.bodies is not False


def pipeline_config(args: argparse.Namespace):  # noqa: ANN201 - app.pipeline imports this module's types
    """The :class:`app.pipeline.PipelineConfig` of :func:`add_method_arguments`' options; a bad combination is a
    :class:`app.errors.UserError`."""
    from app.errors import UserError
    from app.pipeline import PipelineConfig

    try:
        return PipelineConfig(inference="motion" if args.motion else "face", itd_method=args.itd_method,
                              decision_window_s=args.decision_window, frame_itds=args.frame_itds,
                              vote_frames=args.vote_frames)
    except ValueError as exc:
        raise UserError(str(exc)) from None
