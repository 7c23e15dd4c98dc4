"""Rooms we did not draw (:mod:`sim.rooms`) through the real pipeline, scored per result x person.

Each room is drawn from its seed, simulated (rendered faces, room acoustics, read sentences, background noise) and
replayed as fast as possible through :class:`~app.pipeline.Pipeline`; its results are matched to the truth's faces
(section 7's protocol, tau_loc = 0.35 m) and scored by :mod:`app.eval.per_result`: precision and recall per result
and person (plain, and with the edges of each person's speech forgiven by 0.3 s), utterances heard, and false
speaking stretches per utterance.

Methods: ``"avhear"`` (the configuration as given), ``"paper"`` (Algorithm 2 as written: free means and
variances, tau_A = K / (N + 2), the correlogram's ITDs, no single frames' looks, no vote), so that every default is
read beside the paper's method, and ``"all-rescues"`` (the configuration with every call of the speaking test's later
looks standing, as before :class:`avcore.speaking.RescueContinuity`).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from app.eval.per_result import ResultCounts, result_counts
from app.pipeline import Pipeline, PipelineConfig
from app.result import Result
from app.sources.open import StreamAdapter
from app.sources.sim import SimSource
from avcore.evaluation import TAU_LOC_M, match_clusters
from avcore.geometry import MicArray, MicPair
from sim.rooms import overlap_share

__all__ = ["DEFAULT_METHODS", "METHODS", "RoomScore", "evaluate_room", "method_config"]

METHODS: tuple[str, ...] = ("avhear", "paper", "all-rescues")
DEFAULT_METHODS: tuple[str, ...] = ("avhear", "paper")
Progress = Callable[[str], None]


def method_config(config: PipelineConfig, method: str) -> PipelineConfig:
    """``config`` for ``method``: as it is for "avhear"; Algorithm 2 as written for "paper"; every rescued call
    standing for "all-rescues"."""
    if method == "avhear":
        return config
    if method == "paper":
        return replace(config, inference="face", face_variant="paper", itd_method="correlogram", frame_itds=False,
                       vote_frames=1, lips=False, rescue_gap_s=None, dereverb=False)
    if method == "all-rescues":
        return replace(config, rescue_gap_s=None)
    raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")


@dataclass
class RoomScore:
    """The figures of one method over one or more rooms."""

    method: str
    mics: str
    seeds: list[int]
    counts: ResultCounts = field(default_factory=ResultCounts)
    faces_visible: int = 0
    faces_found: int = 0
    errors_m: list[float] = field(default_factory=list, repr=False)
    rooms: list[dict[str, Any]] = field(default_factory=list)
    speech: str = ""
    faces: str = ""
    noise: str = ""
    mouths: bool = False

    def merge(self, other: RoomScore) -> None:
        self.seeds += other.seeds
        self.counts.add(other.counts)
        self.faces_visible += other.faces_visible
        self.faces_found += other.faces_found
        self.errors_m += other.errors_m
        self.rooms += other.rooms

    @property
    def face_recall(self) -> float:
        return self.faces_found / self.faces_visible if self.faces_visible else math.nan

    @property
    def median_error_m(self) -> float:
        return float(np.median(self.errors_m)) if self.errors_m else math.nan

    def as_dict(self) -> dict[str, Any]:
        return {"method": self.method, "mics": self.mics, "seeds": list(self.seeds), "mouths_move": self.mouths,
                "speaking": self.counts.as_dict(),
                "face_recall": None if math.isnan(self.face_recall) else round(self.face_recall, 4),
                "face_median_error_m": None if math.isnan(self.median_error_m) else round(self.median_error_m, 4),
                "speech_clips": self.speech, "face_images": self.faces, "noise": self.noise, "rooms": self.rooms}


def evaluate_room(seed: int, *, method: str = "avhear", config: PipelineConfig | None = None,
                  mic_array: str = "pair", lips: bool = False, camera: str = "stereo",
                  duration_s: float | None = None, data_dir: str | None = None, image_scale: float = 1.0,
                  mics: MicPair | None = None, progress: Progress | None = None) -> RoomScore:
    """Draw room ``seed``, run it through the pipeline with ``method`` and score it (module docstring).

    lips : the people's mouths move with their speech (else the faces are still); reading them is the config's
    ``lips``. mic_array : a name of :data:`avcore.geometry.ARRAY_PRESETS` ("pair": the 12 cm pair). image_scale :
    the camera's pixels per degree against the default's (0.5: far faces, :meth:`SimSource.from_room`). mics : the
    pair with an audio-visual correction (section 5.3, e.g. :func:`app.eval.scenarios.calibrate_on_preset`'s), heard
    with instead of the nominal pair; None: the nominal microphones."""
    cfg = method_config(config or PipelineConfig(), method)
    if mics is not None and MicArray.preset(mic_array).n_pairs != 1:
        raise ValueError("an audio-visual correction (mics) applies to one pair; use a preset of one pair with it")
    sim = SimSource.from_room(seed, duration_s=duration_s, mics=mic_array, camera=camera, lips=lips,
                              data_dir=data_dir, image_scale=image_scale, progress=progress)
    if mics is not None:
        sim.mics = mics
    source = StreamAdapter(sim, realtime=False)
    fused: list[Result] = []
    Pipeline(source, cfg, lambda r: fused.append(r.without_image())).run(whole=True)
    scenario = sim.scenario
    fused.sort(key=lambda r: r.stamp_s)
    n = len(scenario.actors)
    stamps = np.array([r.stamp_s for r in fused], dtype=np.float64)
    states = np.full((len(fused), n), -1)
    visible = np.zeros((len(fused), n), dtype=bool)
    score = RoomScore(method, mic_array, [seed], mouths=lips)
    for j, r in enumerate(fused):
        truth = scenario.truth(float(r.stamp_s))
        visible[j] = truth.visible
        match = match_clusters(r.positions, truth.positions_m, tau_loc=TAU_LOC_M)
        for (g, d), err in zip(match.pairs, match.errors_m):
            states[j, g] = int(bool(r.speaking[d]))
            if truth.visible[g]:
                score.errors_m.append(float(err))
        score.faces_visible += int(truth.visible.sum())
        score.faces_found += sum(int(truth.visible[g]) for g, _ in match.pairs)
    speech = [[(e.start_s, e.end_s) for e in scenario.events if e.kind == "speech" and e.actor == i]
              for i in range(n)]
    period = float(np.median(np.diff(sim.frame_stamps_s))) if len(sim.frame_stamps_s) > 1 else 1 / 30
    score.counts = result_counts(stamps, states, visible, speech, half_span_s=period / 2)
    c = score.counts
    score.rooms = [dict(sim.meta["room"], overlap_share=round(overlap_share(scenario.events), 3),
                        face_recall=round(score.face_recall, 4), precision_forgiven=_rounded(c.precision_forgiven),
                        recall_forgiven=_rounded(c.recall_forgiven), utterances=c.utterances, heard=c.heard,
                        false_stretches=c.false_stretches,
                        faces_found_each=[round(float(np.mean(states[visible[:, i], i] >= 0)), 3)
                                          if visible[:, i].any() else None for i in range(n)])]
    score.speech, score.faces, score.noise = str(sim.meta["speech"]), str(sim.meta["faces"]), str(sim.meta["noise"])
    return score


def _rounded(x: float) -> float | None:
    return None if math.isnan(x) else round(x, 4)
