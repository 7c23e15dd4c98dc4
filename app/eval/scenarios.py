"""The scenario evaluation of the paper's section 7.3 ("Results on NAO") on the simulated room.

Each scenario S1-S5 (:mod:`sim.scenario`) is simulated and replayed as fast as possible (nothing lost) through the
real :class:`~app.pipeline.Pipeline` (face- or motion-guided), and the results are scored against the simulator's
truth in two units: per spoken number (:class:`UtteranceCounts`, the paper's unit) and per visible person and 0.4 s
interval (a stricter view, with a timing reference: the truth itself held 25 ms longer). Per scenario also: the
share of frames with every visible face found, the F3D error and the ITD accuracy. With ``calibration`` the fusion
uses the c1, c0 fitted on the ``calibration`` preset (section 5.3), as a user of the rig would.

Running here; scoring in :mod:`app.eval.scoring` (the protocol in full: docs/architecture.md, "Scoring the
scenarios"), the counts in :mod:`app.eval.counts`, the tables in :mod:`app.eval.tables`.
"""
from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np

from app.eval.scoring import ScenarioScore, score_run, speech_line, voice_counts
from app.pipeline import Pipeline, PipelineConfig
from app.result import Result
from app.sources.open import StreamAdapter, open_source
from avcore.calibration import fit_av_calibration_report
from avcore.geometry import MicArray, MicPair
from sim.presets import SCENARIO_CHOICES, SCENARIOS
from sim.scenario import Scenario

log = logging.getLogger(__name__)

__all__ = ["PAPER_PERCENT", "PAPER_SCENARIOS", "SCENARIOS", "SCENARIO_CHOICES", "CalibrationFit",
           "calibrate_on_preset", "evaluate_scenario"]

PAPER_PERCENT: dict[str, tuple[float, float]] = {
    # the table's own FN % and TP % (its S2 row rounds 31 / 207 to 14.9 %)
    "S1": (13.4, 86.6), "S2": (14.9, 85.1), "S3": (11.3, 88.7), "S4": (6.7, 93.3), "S5": (19.0, 81.0),
}
PAPER_SCENARIOS: dict[str, dict[str, int]] = {
    # section 7.3, table "scenarios": FP, FN, TP of the speaking states on NAO (hand-annotated recordings)
    "S1": {"fp": 13, "fn": 23, "tp": 149},
    "S2": {"fp": 22, "fn": 31, "tp": 176},
    "S3": {"fp": 19, "fn": 20, "tp": 157},
    "S4": {"fp": 37, "fn": 12, "tp": 166},
    "S5": {"fp": 53, "fn": 32, "tp": 136},
}

Progress = Callable[[str], None]
Positions = Callable[[float], np.ndarray]



@dataclass(frozen=True)
class CalibrationFit:
    """c1, c0 fitted on the ``calibration`` preset (section 5.3) and the residuals before and after."""

    mics: MicPair
    n_pairs: int
    inlier_share: float
    median_abs_before_s: float
    median_abs_after_s: float

    def as_dict(self) -> dict[str, Any]:
        return {"c1": round(self.mics.c1, 6), "c0_us": round(self.mics.c0 * 1e6, 3), "pairs": self.n_pairs,
                "inlier_share": round(self.inlier_share, 4),
                "median_abs_residual_before_us": round(self.median_abs_before_s * 1e6, 2),
                "median_abs_residual_after_us": round(self.median_abs_after_s * 1e6, 2)}


def _open(name: str, seed: int, duration_s: float | None, progress: Progress | None,
          mic_array: str = "pair", bodies: bool = False, camera: str = "stereo", lips: bool = False) -> StreamAdapter:
    source = open_source(f"sim:{name}", realtime=False, duration_s=duration_s, seed=seed, mics=mic_array,
                         bodies=bodies, camera=camera, lips=lips, progress=progress)
    assert isinstance(source, StreamAdapter)
    return source


def _point_means(stream: Any, interval_s: float, result: Result) -> np.ndarray:
    return stream.point_means(result.xyz, result.stamp_s, interval_s)


def calibrate_on_preset(*, seed: int = 0, duration_s: float | None = None, config: PipelineConfig | None = None,
                        progress: Progress | None = None, camera: str = "stereo",
                        mic_array: str = "pair") -> CalibrationFit:
    """Fit the affine correction c1, c0 (eq. itd_up) as a user would: run the ``calibration`` preset through the
    pipeline (F3D faces, ITDs of each frame's time window), pair the one face of each frame with each of its ITDs,
    and fit robustly (:func:`avcore.calibration.fit_av_calibration_report`). ``mic_array``: a preset of one pair
    (the default pair, a laptop's)."""
    if MicArray.preset(mic_array).n_pairs != 1:
        raise ValueError(f"the calibration fits one pair; {mic_array!r} has several")
    cfg = replace(config or PipelineConfig(), inference="face")
    source = _open("calibration", seed, duration_s, progress, mic_array, camera=camera)
    faces: list[np.ndarray] = []
    itds: list[float] = []

    def keep(result: Result) -> None:
        if result.xyz.shape[0] == 1:
            for itd in result.itds_s[:, 0]:  # the source's pair, the first
                faces.append(result.xyz[0])
                itds.append(float(itd))

    Pipeline(source, cfg, keep).run(whole=True)
    if len(itds) < 10:
        raise RuntimeError(f"the calibration run gave only {len(itds)} face-ITD pairs; cannot fit c1, c0")
    report = fit_av_calibration_report(np.asarray(faces), np.asarray(itds), source.mics)
    return CalibrationFit(report.mics, report.n_pairs, report.inlier_share, report.median_abs_before_s,
                          report.median_abs_after_s)


def evaluate_scenario(name: str, seed: int = 0, *, duration_s: float | None = None,
                      config: PipelineConfig | None = None, mics: MicPair | None = None,
                      mic_array: str = "pair", bodies: bool = True, camera: str = "stereo", lips: bool = False,
                      array_yaw_deg: float = 0.0, progress: Progress | None = None) -> ScenarioScore:
    """Simulate scenario ``name`` (S1-S5) with ``seed``, run it through the pipeline and score it (section 7.3).

    duration_s : seconds of scenario (default the preset's, 20-25 s). config : the pipeline's settings (default
    face-guided, the paper's on NAO). mics : the microphone pair with an audio-visual correction (e.g.
    :func:`calibrate_on_preset`); default the simulator's nominal pair with c1 = 1, c0 = 0. mic_array : the
    robot's microphones (:data:`avcore.geometry.ARRAY_PRESETS`); with several pairs the fusion uses them all and
    ``mics`` must be None (the simulated microphones are exact). bodies : people with a torso, arms and hands that
    gesture, the seated behind a table (the default, as ``avhear eval scenarios``; False: flat heads); camera : the
    stereo pair or an RGB-D camera (:class:`app.sources.sim.SimSource`). array_yaw_deg : the pipeline is told the
    array is turned this much about the vertical from where the room has it (a wrong rig file;
    :meth:`avcore.geometry.MicArray.turned`). A motion-guided run is matched and scored against the centre of each
    person's visible moving body (:meth:`app.sources.sim.SimSource.body_centres`), and scored against the paper's
    truth too (each person's mean of the result's HM3D points on them,
    :meth:`~app.sources.sim.SimSource.point_means`); a face-guided one against the faces.
    """
    if mics is not None and MicArray.preset(mic_array).n_pairs != 1:
        raise ValueError("an audio-visual correction (mics) applies to one pair; use a preset of one pair with it")
    if name not in SCENARIO_CHOICES:
        raise ValueError(f"scenario must be one of {', '.join(SCENARIO_CHOICES)}, got {name!r}")
    cfg = config or PipelineConfig()
    source = _open(name, seed, duration_s, progress, mic_array, bodies, camera, lips)
    if mics is not None:
        source.mics = mics
    if array_yaw_deg:
        if source.array is None:
            raise ValueError("array_yaw_deg turns an array of several pairs; this source has one pair")
        source.array = source.array.turned(math.radians(array_yaw_deg))
    fused: list[Result] = []

    def keep(result: Result) -> None:
        fused.append(result.without_image())

    stats = Pipeline(source, cfg, keep).run(whole=True)
    log.info("%s seed %d: %s", name, seed, stats.summary())
    stream = source.stream
    scenario: Scenario = stream.scenario  # type: ignore[attr-defined]
    audio = np.concatenate([b.samples for b in stream.audio_blocks()], axis=0).astype(np.float64)
    positions_at: Positions | None = None
    points_truth: Callable[[Result], np.ndarray] | None = None
    if cfg.inference == "motion":  # the centre of the visible moving body over the result's interval
        positions_at = partial(stream.body_centres, interval_s=cfg.interval_s)  # type: ignore[attr-defined]
        points_truth = partial(_point_means, stream, cfg.interval_s)  # the paper's: each person's own points
    score = score_run(scenario, fused, audio[:, list(source.channels)], float(stream.samplerate_hz), source.mics,
                      cfg, frame_stamps_s=np.asarray(stream.frame_stamps_s), positions_at=positions_at,
                      points_truth=points_truth)
    score.seeds = [seed]
    score.voices = voice_counts(scenario, fused)
    if stats.self_calibration:
        state = dict(stats.self_calibration[0], seed=seed)
        if source.array is None or source.array.n_pairs == 1:  # what speech itself says of the first pair's line
            line = speech_line(scenario, fused, source.mics, reach_s=cfg.frame_window_s + cfg.window_s)
            state["speech_line"] = None if line is None else {"c1": line.c1, "c0_s": line.c0}
        if state.get("array_yaw_deg") is not None:  # the learned turn undoes the wrong one: what is left
            state["array_yaw_error_deg"] = array_yaw_deg + state["array_yaw_deg"]
        score.self_calibration = [state]
    meta = getattr(stream, "meta", {})
    score.speech, score.faces = str(meta.get("speech", "")), str(meta.get("faces", ""))
    return score
