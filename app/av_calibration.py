"""Audio-visual calibration of a recording (paper section 5.3): faces and ITDs paired, c1 and c0 fitted.

``avhear calibrate av RECORDING --rig rig.yaml -o rig.yaml`` (``app/commands/calibrate.py``) runs the steps below on a
recording of the section 5.3 protocol -- a person holding a loudspeaker that plays white noise just below the face,
walking a zig-zag across the whole field of view (the noise in bursts, as ``avhear calibrate signal`` writes it: see
:data:`avcore.calibration.CALIBRATION_BURST_S`):

1. :func:`locate_recording_faces`: F3D (section 5.2) on every stereo frame; only frames with exactly one face count
   (with two faces, or none, we cannot tell whose position the ITD belongs to).
2. :func:`extract_recording_itds`: the ITDs (section 5.1) of the whole WAV, stamped on the recording's clock.
3. :func:`pair_faces_with_itds`: each ITD (the centre of its window) with the face at that instant, interpolated
   between the two single-face frames around it (or the nearest one), within ``max_gap_s``.
4. :func:`avcore.calibration.fit_av_calibration_report`: c1 and c0 of eq. (itd_up), robust by default, the paper's
   least squares with ``method="lstsq"``.
5. :func:`app.eval.calibration_figure.draw_calibration_figure` and
   :func:`app.console.calibration.log_calibration_rrd`: the paper's figure "calibration" -- extracted ITDs
   (red circles), the faces projected with eq. (itd) before the correction (blue) and with eq. (final_av_mapping)
   after it (green), over time -- as a PNG drawn with OpenCV and as time series in a Rerun ``.rrd``.

Everything here is batch processing of a finished recording; nothing runs in real time.
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import UserError
from app.pipeline import DEFAULT_ITD_METHOD
from app.sources.recording import Recording
from avcore.calibration import CalibrationReport, fit_av_calibration_report
from avcore.faces import FaceDetector, locate_faces
from avcore.geometry import MicArray, MicPair
from avcore.itd import ItdTrack, extract_itds, geometry_options

__all__ = [
    "CalibrationPairs",
    "CalibrationResult",
    "FaceTrack",
    "MAX_REFINE_SHIFT_M",
    "MIN_PAIRS",
    "calibrate_array",
    "calibrate_recording",
    "draw_calibration_figure",
    "extract_recording_itds",
    "locate_recording_faces",
    "log_calibration_rrd",
    "pair_faces_with_itds",
    "save_calibration_figure",
]

log = logging.getLogger(__name__)

# Fewer pairs than this cannot support a robust line fit worth writing into a rig file (a one-minute sequence gives
# thousands).
MIN_PAIRS = 20
# A hand measurement is off by 1-2 cm; a refinement that moves a microphone further than this is fitting
# something else (reverberation compressing the ITDs, a head between the microphones) and is not written.
MAX_REFINE_SHIFT_M = 0.05


@dataclass(frozen=True)
class FaceTrack:
    """F3D faces of every frame of a recording.

    stamps_s : (F,) float, seconds on the recording's clock (the left image's capture time);
    n_faces : (F,) int, faces located in 3D in each frame (-1: the frame could not be processed);
    points_xyz : (F, 3) float, metres, scene frame: the face of frames with exactly one face, NaN otherwise.
    """

    stamps_s: np.ndarray
    n_faces: np.ndarray
    points_xyz: np.ndarray

    @property
    def single(self) -> np.ndarray:
        """(F,) bool: frames with exactly one face."""
        return self.n_faces == 1


@dataclass(frozen=True)
class CalibrationPairs:
    """Face/ITD pairs of the same instants.

    times_s : (N,) float, seconds, the ITD window centres on the recording's clock;
    faces_xyz : (N, 3) float, metres, the face at that instant; itds_s : (N,) float, seconds.
    """

    times_s: np.ndarray
    faces_xyz: np.ndarray
    itds_s: np.ndarray

    def __len__(self) -> int:
        return int(self.itds_s.shape[0])


@dataclass(frozen=True)
class CalibrationResult:
    """Everything the command prints, writes and draws.

    measured : the input microphones (hand-measured positions and their current correction);
    faces, itds, pairs : the intermediate data; report : the fit (``report.mics`` is the calibrated pair);
    itd_method : the extractor used; timings_s : seconds spent per step;
    rejected_shift_m : when ``refine_positions`` was asked but moved a microphone by more than
    ``MAX_REFINE_SHIFT_M``, that largest shift (metres), and ``report`` is the fit without the refinement; else None.

    There is no comparison with a simulation's ground-truth ITDs on purpose: those are the free-field ITDs of
    eq. (itd), while the fusion compares mapped faces with *measured* ITDs, which reverberation pulls towards zero
    (c1 < 1). The residuals against the measured ITDs are the figure of merit.
    """

    measured: MicPair
    faces: FaceTrack
    itds: ItdTrack
    pairs: CalibrationPairs
    report: CalibrationReport
    itd_method: str
    timings_s: dict[str, float] = field(default_factory=dict)
    rejected_shift_m: float | None = None


# ---------------------------------------------------------------------------------------------------------------
# the steps


def locate_recording_faces(recording: Recording, *, detector: FaceDetector | None = None,
                           progress: Callable[[int, int], None] | None = None) -> FaceTrack:
    """F3D (section 5.2) on every stereo frame of ``recording``, as the pipeline does it.

    A frame that cannot be processed (wrong size, corrupt) is counted with ``n_faces = -1`` and skipped.
    ``progress(done, total)`` is called after each frame. ``detector``: the pipeline's default by default
    (:func:`app.hearing.face_detector`).
    """
    if detector is None:
        from app.hearing import face_detector
        from app.pipeline import PipelineConfig

        detector = face_detector(PipelineConfig())
    total = len(recording.frame_stamps_s)
    stamps = np.empty(total)
    counts = np.full(total, -1, dtype=int)
    points = np.full((total, 3), np.nan)
    k = 0
    for k, frame in enumerate(recording.frames(realtime=False)):
        stamps[k] = frame.stamp_s
        try:
            faces = locate_faces(frame.left, frame.right, recording.stereo, detector=detector)
        except ValueError as exc:
            log.warning("frame %d skipped: %s", frame.index, exc)
        else:
            counts[k] = len(faces)
            if len(faces) == 1:
                points[k] = faces.points[0]
        if progress is not None:
            progress(k + 1, total)
    n = min(total, k + 1) if total else 0
    return FaceTrack(stamps[:n], counts[:n], points[:n])


def extract_recording_itds(recording: Recording, mics: MicPair, *, method: str = DEFAULT_ITD_METHOD,
                           window_s: float = 0.15, hop_s: float = 0.02, energy_threshold: float = 1e-3,
                           channels: tuple[int, int] | None = None) -> ItdTrack:
    """The ITDs (section 5.1) of the recording's left and right channels (or the pair of ``channels``), window
    centres on the recording's clock.

    Same extractor settings as the pipeline (``app.pipeline``): lags within 1.2 times the largest ITD the
    microphones allow, and for the ``*-robust`` methods their distance and the speed of sound.
    """
    left, right = channels if channels is not None else (recording.channels["left"], recording.channels["right"])
    blocks = [np.asarray(b.samples, dtype=np.float64) for b in recording.audio_blocks(realtime=False)]
    if not blocks:
        return ItdTrack.empty()
    samples = np.concatenate(blocks, axis=0)
    samples = np.nan_to_num(samples, nan=0.0, posinf=0.0, neginf=0.0)
    extra = geometry_options(method, mics.distance_m, mics.speed_of_sound)
    if samples.shape[0] < int(round(window_s * recording.samplerate_hz)):
        return ItdTrack.empty()
    track = extract_itds(samples[:, left], samples[:, right], recording.samplerate_hz, method=method,
                         window_s=window_s, hop_s=hop_s, energy_threshold=energy_threshold,
                         max_itd_s=1.2 * mics.max_itd_s, **extra)
    return ItdTrack(track.times_s + recording.audio_start_s, track.itds_s, track.confidence, track.energy)


def pair_faces_with_itds(faces: FaceTrack, itds: ItdTrack, *, max_gap_s: float | None = None) -> CalibrationPairs:
    """Each ITD with the face at the centre of its window (the ``TimeFrame`` idea of docs/architecture.md, in batch).

    When the frames just before and just after the ITD's instant both hold exactly one face and lie within
    ``2 * max_gap_s`` of each other, the face is interpolated linearly between them (a walking person moves a few
    centimetres per frame, several microseconds of ITD); otherwise the nearest frame is used when it holds exactly
    one face and lies within ``max_gap_s``. ITDs with no such frame are left out.

    max_gap_s : seconds; default half the median frame interval (every ITD finds its frame in a steady stream).
    """
    stamps = faces.stamps_s
    if len(itds) == 0 or stamps.size == 0:
        return CalibrationPairs(np.zeros(0), np.zeros((0, 3)), np.zeros(0))
    if max_gap_s is None:
        max_gap_s = 0.5 * float(np.median(np.diff(stamps))) if stamps.size > 1 else 0.02
    if not (np.isfinite(max_gap_s) and max_gap_s > 0):
        raise ValueError(f"max_gap_s must be a positive number of seconds, got {max_gap_s!r}")
    t = itds.times_s
    after = np.searchsorted(stamps, t, side="left")  # first frame at or after t
    before = after - 1
    n = stamps.size
    b = np.clip(before, 0, n - 1)
    a = np.clip(after, 0, n - 1)
    has_b = (before >= 0) & faces.single[b]
    has_a = (after < n) & faces.single[a]
    gap_b = np.where(before >= 0, t - stamps[b], np.inf)
    gap_a = np.where(after < n, stamps[a] - t, np.inf)

    interp = has_b & has_a & (stamps[a] > stamps[b]) & (stamps[a] - stamps[b] <= 2 * max_gap_s)
    span = np.where(interp, stamps[a] - stamps[b], 1.0)
    w = np.where(interp, gap_b / span, 0.0)[:, None]
    xyz = np.where(interp[:, None], (1 - w) * faces.points_xyz[b] + w * faces.points_xyz[a], np.nan)

    use_b = ~interp & has_b & (gap_b <= max_gap_s) & ~(has_a & (gap_a < gap_b) & (gap_a <= max_gap_s))
    use_a = ~interp & ~use_b & has_a & (gap_a <= max_gap_s)
    xyz[use_b] = faces.points_xyz[b[use_b]]
    xyz[use_a] = faces.points_xyz[a[use_a]]
    ok = interp | use_b | use_a
    return CalibrationPairs(t[ok].copy(), xyz[ok], itds.itds_s[ok].copy())


def _too_few_pairs_message(faces: FaceTrack, itds: ItdTrack, pairs: CalibrationPairs, folder: Path) -> str:
    n_frames = faces.n_faces.size
    n_single = int(faces.single.sum())
    where = (f"{folder}: only {len(pairs)} face/ITD pairs ({n_frames} frames, {n_single} with exactly one face; "
             f"{len(itds)} ITDs); the fit needs at least {MIN_PAIRS}, and a one-minute sequence gives thousands. ")
    if n_single == 0:
        many = int((faces.n_faces > 1).sum())
        return where + ("No frame shows exactly one face" + (f" ({many} show several)" if many else "") +
                        ": record one person, alone in the view, facing the cameras (section 5.3), and check that "
                        "the recording's rig.yaml holds the stereo calibration of these cameras")
    if len(itds) == 0:
        return where + ("No audio window passed the energy gate: the loudspeaker must play its white-noise "
                        "bursts loudly during the whole sequence; check the WAV's left/right channels "
                        "(recording.json) or lower --energy-threshold")
    return where + ("The faces and the ITDs do not overlap in time: check the audio clock (audio_start_s in "
                    "recording.json) and record longer")


def calibrate_recording(recording: Recording, mics: MicPair, *, method: str = "robust",
                        refine_positions: bool = False, itd_method: str = DEFAULT_ITD_METHOD,
                        window_s: float = 0.15, hop_s: float = 0.02, energy_threshold: float = 1e-3,
                        max_gap_s: float | None = None, detector: FaceDetector | None = None,
                        progress: Callable[[int, int], None] | None = None, faces: FaceTrack | None = None,
                        channels: tuple[int, int] | None = None) -> CalibrationResult:
    """Section 5.3 on one recording: F3D faces, ITDs, pairs, and the fit of c1, c0 (eq. itd_up).

    mics : the hand-measured microphones (from the rig file); their c1, c0 are the "before" mapping.
    method, refine_positions : see :func:`avcore.calibration.fit_av_calibration_report`.
    faces : the faces already located in this recording (:func:`locate_recording_faces`), to fit several pairs on
    one pass of F3D; None: located here. channels : the recording's channels of ``mics`` (left, right); None: the
    recording's left and right.

    Raises
    ------
    UserError
        Too few pairs (no face, no ITD, no overlap), or data the fit refuses (faces at one azimuth, channels
        swapped), with what to do.
    """
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    if faces is None:
        faces = locate_recording_faces(recording, detector=detector, progress=progress)
    timings["faces"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    itds = extract_recording_itds(recording, mics, method=itd_method, window_s=window_s, hop_s=hop_s,
                                  energy_threshold=energy_threshold, channels=channels)
    timings["itds"] = time.perf_counter() - t0
    pairs = pair_faces_with_itds(faces, itds, max_gap_s=max_gap_s)
    if len(pairs) < MIN_PAIRS:
        raise UserError(_too_few_pairs_message(faces, itds, pairs, recording.folder))
    t0 = time.perf_counter()
    rejected = None
    try:
        report = fit_av_calibration_report(pairs.faces_xyz, pairs.itds_s, mics, method=method,
                                           refine_positions=refine_positions)
        shift = float(np.linalg.norm(report.position_shift_m, axis=1).max())
        if refine_positions and shift > MAX_REFINE_SHIFT_M:
            log.info("the position refinement moved a microphone by %.1f cm; kept the measured positions",
                     100 * shift)
            rejected = shift
            report = fit_av_calibration_report(pairs.faces_xyz, pairs.itds_s, mics, method=method)
    except ValueError as exc:
        raise UserError(f"{recording.folder}: the calibration fit failed: {exc}") from None
    timings["fit"] = time.perf_counter() - t0
    return CalibrationResult(mics, faces, itds, pairs, report, itd_method, timings, rejected)


def calibrate_array(recording: Recording, array: MicArray, **options: Any
                    ) -> tuple[MicArray, list[CalibrationResult | str]]:
    """Section 5.3 on every pair of a microphone array: each pair is a microphone pair of its own (eq. itd on its
    two positions), so each gets its own c1, c0 of eq. (itd_up), fitted on the same faces (F3D runs once) and the
    ITDs of its two channels (``array.channels``). The recording must hold every channel the array names.

    A pair whose fit is refused keeps its c1, c0: a pair along the cameras' axis (NAO's front and rear microphones)
    hears every face in view at nearly the same ITD, and a person walking across the view cannot calibrate it.

    options : those of :func:`calibrate_recording` (positions are not refined: the array's geometry is shared by
    its pairs). Returns the array with the fitted pairs' c1, c0, and for each pair (in the order of ``array.pairs``)
    its result or the reason its fit was refused. Raises :class:`UserError` when no pair could be fitted.
    """
    need = max(array.channels)  # type: ignore[arg-type]
    if recording.n_channels <= need:
        raise UserError(f"{recording.folder}: the rig's array uses channels {list(array.channels)} but the recording "
                        f"has {recording.n_channels}: record with every microphone of the array (avhear record with "
                        "the same rig), or give the rig of the microphones that made this recording")
    options.pop("refine_positions", None)
    faces = options.pop("faces", None)
    if faces is None:
        faces = locate_recording_faces(recording, detector=options.pop("detector", None),
                                       progress=options.pop("progress", None))
    results: list[CalibrationResult | str] = []
    for k, (i, j) in enumerate(array.pairs):  # type: ignore[union-attr]
        try:
            results.append(calibrate_recording(recording, array.pair(k), faces=faces,
                                               channels=(array.channels[i], array.channels[j]),  # type: ignore[index]
                                               **options))
        except UserError as exc:
            results.append(str(exc).split(": ", 1)[-1])
    if all(isinstance(r, str) for r in results):
        raise UserError(f"{recording.folder}: no pair of the array could be calibrated; the first said: {results[0]}")
    c1 = tuple(array.c1[k] if isinstance(r, str) else r.report.c1 for k, r in enumerate(results))  # type: ignore
    c0 = tuple(array.c0[k] if isinstance(r, str) else r.report.c0 for k, r in enumerate(results))  # type: ignore
    return MicArray(array.positions, array.pairs, array.speed_of_sound, c1, c0, array.channels), results
