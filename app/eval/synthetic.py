"""The synthetic evaluation of section 7.1: Algorithm 1 on the generated sequences, scored by the paper's protocol.

Algorithm 2 (face-guided) is measured on the same sequences too (:func:`evaluate_face_guided`), with the faces
given, to decide the choices the paper leaves open (anchored or free means, the speaking test).

``PAPER_VISUAL`` and ``PAPER_AUDIO`` are the paper's tables 1 and 2 (section 7.1), printed beside ours.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace

import numpy as np

from avcore.evaluation import EvalTotals, match_clusters
from avcore.geometry import MicPair
from avcore.inference import (
    FaceGuidedHearing,
    FaceGuidedParams,
    MotionGuidedHearing,
    MotionGuidedParams,
    SpeakingTest,
)
from sim.synthetic import SEQUENCES, Interval, SyntheticConfig, generate_sequence

__all__ = [
    "FACE_VARIANTS",
    "PAPER_AUDIO",
    "PAPER_VISUAL",
    "VARIANTS",
    "SequenceScore",
    "evaluate_face_guided",
    "evaluate_sequence",
    "score_intervals",
]

# Table 1 (visual): FP, FN, TP, TP %, ALE (m)
PAPER_VISUAL: dict[str, dict[str, float]] = {
    "StaCon": {"fp": 12, "fn": 16, "tp": 392, "tp_pct": 96.1, "ale_m": 0.03},
    "DynCon": {"fp": 43, "fn": 139, "tp": 269, "tp_pct": 65.9, "ale_m": 0.10},
    "StaVar": {"fp": 46, "fn": 69, "tp": 160, "tp_pct": 69.9, "ale_m": 0.03},
    "DynVar": {"fp": 40, "fn": 82, "tp": 147, "tp_pct": 64.1, "ale_m": 0.11},
}
# Table 2 (auditory state): FP, FN, TP, TP %
PAPER_AUDIO: dict[str, dict[str, float]] = {
    "StaCon": {"fp": 161, "fn": 33, "tp": 214, "tp_pct": 86.6},
    "DynCon": {"fp": 144, "fn": 56, "tp": 208, "tp_pct": 78.8},
    "StaVar": {"fp": 53, "fn": 33, "tp": 143, "tp_pct": 81.2},
    "DynVar": {"fp": 56, "fn": 34, "tp": 139, "tp_pct": 80.3},
}

VARIANTS: dict[str, Callable[[], MotionGuidedParams]] = {
    "paper": MotionGuidedParams.paper,
    "avhear": MotionGuidedParams,
}


@dataclass(frozen=True)
class SequenceScore:
    """The totals of one sequence type over several seeds for one variant of the method."""

    sequence: str
    variant: str
    seeds: tuple[int, ...]
    totals: EvalTotals

    def as_dict(self) -> dict[str, object]:
        return {"sequence": self.sequence, "variant": self.variant, "seeds": list(self.seeds), **self.totals.as_dict()}


def _start(name: str, mics: MicPair | None, seeds: Iterable[int]) -> tuple[MicPair, EvalTotals, tuple[int, ...]]:
    if name not in SEQUENCES:
        raise ValueError(f"unknown sequence {name!r}; choose one of {', '.join(SEQUENCES)}")
    return (mics if mics is not None else MicPair()), EvalTotals(), tuple(int(s) for s in seeds)


def evaluate_sequence(
    name: str,
    seeds: Iterable[int],
    params: MotionGuidedParams,
    *,
    variant: str = "",
    mics: MicPair | None = None,
    config: SyntheticConfig | None = None,
    progress: Callable[[str], None] | None = None,
) -> SequenceScore:
    """Run Algorithm 1 over the sequence ``name`` for every seed and score each interval (section 7 protocol).

    The method keeps its model across the intervals of a sequence and starts afresh for each seed.
    """
    mics, totals, seeds = _start(name, mics, seeds)
    for seed in seeds:
        hearing = MotionGuidedHearing(mics, params)
        this_seed = EvalTotals()  # the progress line is this seed's; the table sums the seeds
        for interval in generate_sequence(name, seed=seed, mics=mics, config=config):
            out = hearing.step(interval.points, interval.itds)
            match = match_clusters(out.positions, interval.truth_xyz, detected_speaking=out.speaking,
                                   truth_speaking=interval.truth_speaking)
            totals.add(match)
            this_seed.add(match)
        if progress is not None:
            progress(f"{name} seed {seed} ({variant or 'custom'}): TP {this_seed.tp}/{this_seed.n_truth} "
                     f"(all seeds so far: {totals.tp}/{totals.n_truth})")
    return SequenceScore(name, variant, seeds, totals)


def score_intervals(
    name: str,
    sequences: Iterable[tuple[int, list[Interval]]],
    params: MotionGuidedParams,
    *,
    variant: str = "",
    mics: MicPair | None = None,
) -> SequenceScore:
    """Algorithm 1 over already generated sequences ``(seed, intervals)`` (e.g. :func:`sim.bodies.generate_bodies`,
    :func:`sim.skeletons.generate_family`), scored as :func:`evaluate_sequence` does: the model is kept across a
    sequence's intervals, fresh per sequence."""
    mics = mics if mics is not None else MicPair()
    totals, seeds = EvalTotals(), []
    for seed, intervals in sequences:
        seeds.append(int(seed))
        hearing = MotionGuidedHearing(mics, params)
        for interval in intervals:
            out = hearing.step(interval.points, interval.itds)
            totals.add(match_clusters(out.positions, interval.truth_xyz, detected_speaking=out.speaking,
                                      truth_speaking=interval.truth_speaking))
    return SequenceScore(name, variant, tuple(seeds), totals)


FACE_VARIANTS: dict[str, Callable[[], FaceGuidedParams]] = {
    "paper": FaceGuidedParams.paper,
    "paper+anchored": lambda: FaceGuidedParams(speaking=SpeakingTest(outlier_aware=False)),
    "avhear free means": lambda: replace(FaceGuidedParams.paper(), speaking=SpeakingTest()),
    "avhear": FaceGuidedParams,
}


def evaluate_face_guided(
    name: str,
    seeds: Iterable[int],
    params: FaceGuidedParams,
    *,
    variant: str = "",
    face_noise_m: float = 0.01,
    mics: MicPair | None = None,
    config: SyntheticConfig | None = None,
) -> SequenceScore:
    """Algorithm 2 on the same sequences: the faces are the visible people (plus F3D-like noise of
    ``face_noise_m`` per axis), the ITDs those of the interval; scored on the speaking states only."""
    mics, totals, seeds = _start(name, mics, seeds)
    for seed in seeds:
        rng = np.random.default_rng([seed, 7])
        hearing = FaceGuidedHearing(mics, params)
        for interval in generate_sequence(name, seed=seed, mics=mics, config=config):
            faces = interval.truth_xyz + rng.normal(0.0, face_noise_m, interval.truth_xyz.shape)
            out = hearing.step(faces, interval.itds)
            totals.add(match_clusters(faces, interval.truth_xyz, detected_speaking=out.speaking,
                                      truth_speaking=interval.truth_speaking))
    return SequenceScore(name, variant, seeds, totals)
