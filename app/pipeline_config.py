"""The process's settings (:class:`PipelineConfig`), a floor below the pipeline and its stages so that both read them
without importing each other."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["DEFAULT_ITD_METHOD", "PipelineConfig"]


DEFAULT_ITD_METHOD = "gcc-phat-robust"
"""The application's ITD extractor (the most accurate in reverberant rooms, ``benchmarks/itd_accuracy.py``); the
paper's is ``"correlogram"``, the default of :func:`avcore.itd.extract_itds`."""


@dataclass(frozen=True)
class PipelineConfig:
    """Settings of the process; defaults are the paper's implementation details (section 6). Each setting's why:
    docs/method.md and docs/architecture.md.

    inference : "face" (Algorithm 2, the default, as on NAO) or "motion" (Algorithm 1 on HM3D points).
    itd_method, window_s, hop_s, energy_threshold : the ITD extraction (W = 150 ms, f = 20 ms, E_A = 0.001);
        "gcc-phat-robust" by default, the paper's "correlogram" selectable. Lags are searched within 1.2 times the
        pair's free-field maximum.
    frame_window_s : face-guided: each vision result collects the ITDs within +- this of its stamp.
    decision_window_s : face-guided: decide on the ITDs within +- this of the stamp only (EM still fits on the
        whole time frame; :class:`avcore.inference.FaceGuidedParams`); None: on all of them, as the paper.
    frame_itds : face-guided with "gcc-phat-robust": the speaking test's later looks, at the single 32 ms frames'
        ITDs, their frequency bands' peaks and their bins, one pair's too (:class:`avcore.speaking.SpeakingTest`).
    vote_frames : face-guided: each person's state is the majority over this many results centred on it
        (:func:`avcore.speaking.vote_speaking`): results leave ``vote_frames // 2`` frames later; 1: no vote.
    rescue_gap_s : face-guided: a call only the later looks make stands while the person's last call that stood is
        at most this old (:class:`avcore.speaking.RescueContinuity`); None: every such call stands.
    interval_s : motion-guided: Delta t = 0.4 s of frames per HM3D interval (section 7). motion_variant,
        face_variant : "avhear" (the default) or "paper" (Algorithm 1, or 2's EM and eq. audio_act, as written).
    *_queue : queue lengths (items); a full queue drops its oldest item (in real time; a replay as fast as
        possible waits for room instead). Motion-guided, the frames' queue holds at least one interval at 60 FPS.
    max_audio_lead_s : a replay as fast as possible: the ITD worker waits while its audio is more than this far
        ahead of the last frame vision took. Must exceed the time frame, a window and the vote's wait.
    latency : "default" (the time frame and the vote centred on each result: the method's own wait, about
        0.43 s) or "low" (the past only: a result leaves once its last ITD is extracted).
    face_detector : "auto" (BlazeFace when its model is installed, else Haar's cascade with a notice),
        "blazeface" (:mod:`avcore.blazeface`) or "haar" (OpenCV 4 only); face_model : the BlazeFace model file
        (default: the installed package's); tflite_runtime : "opencv" (OpenCV's DNN) or "litert".
    self_calibrate, own_itds, bin_spill : face-guided: learn every pair's c1, c0 while running (:class:`app.hearing.
        SelfCalibrating`); hear each person where their voice is heard (:class:`avcore.own_itd.OwnItds`); with
        several pairs, claim by the bins only above the heard talkers' learned spill (:mod:`avcore.bin_spill`).
    lips : the face mesh on every face and the lips' cue (:meth:`app.hearing.FaceGuided.step`): still lips (under
        ``lip_still_below``) are not speaking; faces within ``lip_same_direction_s`` on every pair are heard as
        one, whose words go to the moving lips (to a second face too above ``lip_both_above`` of its range);
        ``lip_earn_trust``: still lips veto only once they have moved with their own voice, or for
        ``lip_synced_s`` with the sound (:class:`avcore.lips.HiddenLips`). Motion-guided, a person's face is the
        one within ``lip_face_within_m`` of them horizontally, and the veto applies to the person.
        ``lip_mesh_every``: the face mesh on every n-th frame only (its cost over n; docs/method.md).
    dereverb : the ITDs from dereverberated microphones (:class:`avcore.dereverb.SignalDereverberator`); off.
    voices : each person's voice as a 16 kHz stream, MVDR steered at them (:class:`avcore.separation.
        VoiceSeparator`), from the people ``voice_delay_s`` old (the results' own wait, 0.43 s, fits within it).
    """

    inference: Literal["face", "motion"] = "face"
    itd_method: str = DEFAULT_ITD_METHOD
    window_s: float = 0.15
    hop_s: float = 0.02
    energy_threshold: float = 1e-3
    frame_window_s: float = 0.2
    decision_window_s: float | None = None
    frame_itds: bool = True
    vote_frames: int = 9
    rescue_gap_s: float | None = 0.1
    face_detector: Literal["auto", "haar", "blazeface"] = "auto"
    latency: Literal["default", "low"] = "default"
    self_calibrate: bool = False
    own_itds: bool = True
    bin_spill: bool = False
    dereverb: bool = False
    face_model: str | None = None
    tflite_runtime: Literal["opencv", "litert"] = "opencv"
    lips: bool = False
    lip_still_below: float = 0.012
    lip_same_direction_s: float = 40e-6
    lip_both_above: float = 0.5
    lip_face_within_m: float = 0.35
    lip_earn_trust: bool = True
    lip_synced_s: float | None = None
    lip_mesh_every: int = 1
    voices: bool = False
    voice_delay_s: float = 0.6
    interval_s: float = 0.4
    motion_variant: Literal["avhear", "paper"] = "avhear"
    face_variant: Literal["avhear", "paper"] = "avhear"
    frame_queue: int = 4
    audio_queue: int = 256
    fusion_queue: int = 1024
    max_audio_lead_s: float = 2.0
    join_timeout_s: float = 2.0

    def __post_init__(self) -> None:
        if self.latency not in ("default", "low"):
            raise ValueError(f"latency must be 'default' or 'low', got {self.latency!r}")
        if self.face_detector not in ("auto", "haar", "blazeface"):
            raise ValueError(f"face_detector must be 'auto', 'haar' or 'blazeface', got {self.face_detector!r}")
        if self.tflite_runtime not in ("opencv", "litert"):
            raise ValueError(f"tflite_runtime must be 'opencv' or 'litert', got {self.tflite_runtime!r}")
        if self.inference not in ("face", "motion"):
            raise ValueError(f"inference must be 'face' or 'motion', got {self.inference!r}")
        for name in ("motion_variant", "face_variant"):
            if getattr(self, name) not in ("avhear", "paper"):
                raise ValueError(f"{name} must be 'avhear' or 'paper', got {getattr(self, name)!r}")
        for name in ("window_s", "hop_s", "frame_window_s", "interval_s", "max_audio_lead_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0 seconds, got {getattr(self, name)!r}")
        if not 0 < self.lip_still_below < 1:
            raise ValueError(f"lip_still_below must be a spread of the mouth's opening in (0, 1), got "
                             f"{self.lip_still_below!r}")
        if not 0 <= self.lip_same_direction_s < 1e-3:
            raise ValueError(f"lip_same_direction_s must be an ITD in [0, 1 ms) seconds, got "
                             f"{self.lip_same_direction_s!r}")
        if isinstance(self.lip_mesh_every, bool) or self.lip_mesh_every not in (1, 2, 3):
            raise ValueError(f"lip_mesh_every must be 1, 2 or 3 frames, got {self.lip_mesh_every!r}")
        if self.lip_synced_s is not None and not 0 < self.lip_synced_s <= 3.0:
            raise ValueError(f"lip_synced_s must be None or in (0, 3] seconds, got {self.lip_synced_s!r}")
        if not 0 < self.lip_face_within_m < 2:
            raise ValueError(f"lip_face_within_m must be a horizontal distance in (0, 2) metres, got "
                             f"{self.lip_face_within_m!r}")
        if not 0 < self.lip_both_above <= 1:
            raise ValueError(f"lip_both_above must be a share of a face's own lip range in (0, 1], got "
                             f"{self.lip_both_above!r}")
        from avcore.inference import FaceGuidedParams  # (not at import: the command line's help reads the defaults)

        FaceGuidedParams(decision_window_s=self.decision_window_s)  # the hearing's own check, here at once
        least = max(self.frame_window_s, self.interval_s) + self.window_s + self.hop_s
        if self.max_audio_lead_s <= least:
            raise ValueError(f"max_audio_lead_s must exceed the time frame plus a window ({least:g} s), got "
                             f"{self.max_audio_lead_s!r}")
        if not 0 <= self.voice_delay_s <= 5:
            raise ValueError(f"voice_delay_s must be a time in [0, 5] seconds, got {self.voice_delay_s!r}")
        if self.rescue_gap_s is not None and not 0 <= self.rescue_gap_s < 10:
            raise ValueError(f"rescue_gap_s must be None or a time in [0, 10) seconds, got {self.rescue_gap_s!r}")
        if not (isinstance(self.vote_frames, int) and self.vote_frames >= 1 and self.vote_frames % 2 == 1):
            raise ValueError(f"vote_frames must be an odd number of results >= 1 (1: no vote), got "
                             f"{self.vote_frames!r}")
