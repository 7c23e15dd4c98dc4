"""`avhear calibrate`: calibration of the sensors (paper section 5.3).

``avhear calibrate stereo`` calibrates the stereo rig from chessboard picture pairs and writes the rig YAML.
``avhear calibrate av RECORDING --rig rig.yaml -o rig.yaml`` fits the affine audio-visual correction c1, c0 of
eq. (itd_up) on a recording of a person carrying a white-noise loudspeaker in a zig-zag (the work is in
:mod:`app.av_calibration`); ``avhear calibrate signal -o FILE.wav`` writes what that loudspeaker plays. Each kind is
one sub-command with its own ``add_*_parser`` below.
"""
from __future__ import annotations

import argparse
import glob
import logging
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from app.errors import UserError
from app.commands.options import count, duration, itd_methods
from app.commands.paths import distinct_outputs, output_file
from app.pipeline_config import DEFAULT_ITD_METHOD
from avcore.calibration import CALIBRATION_BURST_S, calibration_signal

if TYPE_CHECKING:
    from app.av_calibration import CalibrationResult
    from app.config import RigConfig
    from avcore.stereo import StereoCalibration

log = logging.getLogger(__name__)

MIN_VIEWS = 3


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "calibrate", help="calibrate the sensors (stereo cameras, audio-visual correction)",
        description="Calibrate the sensors of the rig and write the rig YAML file.",
    )
    kinds = parser.add_subparsers(dest="kind", metavar="KIND")
    kinds.required = True
    add_stereo_parser(kinds)
    add_av_parser(kinds)
    add_signal_parser(kinds)


def add_stereo_parser(kinds: argparse._SubParsersAction) -> None:
    p = kinds.add_parser(
        "stereo", help="stereo rig from chessboard picture pairs",
        description=(
            "Calibrate the two cameras and their relative pose from pictures of a chessboard taken by both cameras "
            "at the same time (pairs matched by sorted file name). Prints the reprojection error of every view, "
            "flags the bad ones, writes the rig YAML and a picture of the detected corners to check by eye."
        ),
    )
    p.add_argument("--left", required=True, help="glob of the left pictures, quoted: 'dir/left*.jpg'")
    p.add_argument("--right", required=True, help="glob of the right pictures, quoted: 'dir/right*.jpg'")
    p.add_argument("--pattern", required=True, type=_pattern_arg,
                   help="inner corners COLSxROWS, e.g. 9x6 for a board of 10x7 squares")
    p.add_argument("--square", required=True, type=_positive_float, help="side of one square, metres (e.g. 0.025)")
    p.add_argument("-o", "--output", required=True, type=Path,
                   help="rig YAML to write; its 'microphones' section, if any, is kept")
    p.add_argument("--corners-image", type=Path, default=None,
                   help="picture of the detected corners (default: next to the output, *_corners.png)")
    p.add_argument("--max-view-error", type=_positive_float, default=1.0,
                   help="flag views whose reprojection RMS exceeds this many pixels (default 1.0) "
                        "or three times the median")
    p.set_defaults(func=run_stereo)


def _pattern_arg(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m or int(m.group(1)) < 2 or int(m.group(2)) < 2:
        raise argparse.ArgumentTypeError(f"expected inner corners as COLSxROWS like 9x6, got {text!r}")
    return (int(m.group(1)), int(m.group(2)))


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def _expand(pattern: str, option: str) -> list[Path]:
    files = sorted(Path(f) for f in glob.glob(pattern))
    if not files:
        raise UserError(f"{option} {pattern!r} matches no file; quote the glob and check the folder")
    return files


def _read(path: Path) -> np.ndarray:
    import cv2

    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise UserError(f"{path}: cannot read this picture (missing, corrupt or not an image); "
                        "remove it or replace it")
    return img


def _corners_mosaic(images: list[np.ndarray], corners: list[np.ndarray | None], pattern: tuple[int, int],
                    names: list[str]) -> np.ndarray:
    """All left pictures with their detected corners drawn, tiled four per row at half size."""
    import cv2

    tiles = []
    for img, c, name in zip(images, corners, names):
        colour = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
        if c is not None:
            cv2.drawChessboardCorners(colour, pattern, c.reshape(-1, 1, 2), True)
        tile = cv2.resize(colour, (colour.shape[1] // 2, colour.shape[0] // 2), interpolation=cv2.INTER_AREA)
        if c is None:
            cv2.putText(tile, "NOT FOUND", (10, 40), cv2.FONT_HERSHEY_SIMPLEX, 1.0, (0, 0, 255), 2)
        cv2.putText(tile, name, (6, tile.shape[0] - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 255, 255), 2)
        tiles.append(tile)
    per_row = 4
    blank = np.zeros_like(tiles[0])
    while len(tiles) % per_row:
        tiles.append(blank)
    rows = [np.hstack(tiles[i:i + per_row]) for i in range(0, len(tiles), per_row)]
    return np.vstack(rows)


def _load_pairs(args: argparse.Namespace) -> tuple[list[Path], list[Path], list[np.ndarray], list[np.ndarray]]:
    """The left and right pictures, paired by sorted name, all of one size."""
    lefts = _expand(args.left, "--left")
    rights = _expand(args.right, "--right")
    if len(lefts) != len(rights):
        raise UserError(f"--left matches {len(lefts)} pictures but --right matches {len(rights)}; the pictures go "
                        "in pairs (matched by sorted name): remove the unpaired ones")
    images_l = [_read(p) for p in lefts]
    images_r = [_read(p) for p in rights]
    size = images_l[0].shape[::-1]
    for p, img in zip(lefts + rights, images_l + images_r):
        if img.shape[::-1] != size:
            raise UserError(f"{p}: size {img.shape[1]}x{img.shape[0]} differs from {lefts[0]} "
                            f"({size[0]}x{size[1]}); all pictures must come from the same two cameras")
    return lefts, rights, images_l, images_r


def _detect_pairs(args: argparse.Namespace, lefts: list[Path], rights: list[Path], images_l: list[np.ndarray],
                  images_r: list[np.ndarray]) -> tuple[list[np.ndarray], list[np.ndarray], list[int],
                                                       list[np.ndarray | None]]:
    """The chessboard's corners in both pictures of each pair: those of the usable pairs, their indices, and the
    left corners of every pair (None where not found) for the mosaic."""
    from avcore.stereo import find_chessboard

    print(f"detecting {args.pattern[0]}x{args.pattern[1]} inner corners in {len(lefts)} pairs ...")
    found_l, found_r, used = [], [], []
    all_l: list[np.ndarray | None] = []
    for i, (pl, pr, il, ir) in enumerate(zip(lefts, rights, images_l, images_r)):
        cl, cr = find_chessboard(il, args.pattern), find_chessboard(ir, args.pattern)
        all_l.append(cl)
        if cl is None or cr is None:
            missing = " and ".join(p.name for p, c in ((pl, cl), (pr, cr)) if c is None)
            print(f"  skipped pair {pl.name} / {pr.name}: chessboard not found in {missing}")
            continue
        found_l.append(cl)
        found_r.append(cr)
        used.append(i)
    if not used:
        raise UserError(
            f"no chessboard with {args.pattern[0]}x{args.pattern[1]} inner corners found in any of the "
            f"{len(lefts)} pairs; check --pattern (count the INNER corners, columns x rows: a board of 10x7 squares "
            "is 9x6) and that the whole board is visible in both pictures")
    if len(used) < MIN_VIEWS:
        raise UserError(f"the chessboard was found in only {len(used)} pair(s); calibration needs at least "
                        f"{MIN_VIEWS} (10-20 is better): take more pairs with the board at different angles")
    return found_l, found_r, used, all_l


def _print_views(cal: StereoCalibration, used: list[int], names: list[str], max_view_error: float) -> None:
    """One line per usable pair (reprojection RMS, pose deviation), bad views flagged."""
    per_view = cal.per_view_rms_px
    worst = per_view.max(axis=1)
    limit = max(max_view_error, 3.0 * float(np.nanmedian(worst)))
    print(f"\n{'pair':<28} {'left px':>8} {'right px':>9} {'pose deg':>9} {'pose T':>7}")
    n_bad = 0
    for k, i in enumerate(used):
        flag = ""
        if not cal.used[k]:
            flag = "  <-- bad view, left out: its two pictures disagree with the others (not taken together?)"
            n_bad += 1
        elif worst[k] > limit:
            flag = "  <-- bad view: remove this pair and calibrate again"
            n_bad += 1
        rms_l = f"{per_view[k, 0]:8.3f}" if cal.used[k] else f"{'-':>8}"
        rms_r = f"{per_view[k, 1]:9.3f}" if cal.used[k] else f"{'-':>9}"
        dev_r, dev_t = cal.pose_deviation[k]
        print(f"{names[i]:<28} {rms_l} {rms_r} {dev_r:9.2f} {100 * dev_t:6.1f}%{flag}")
    if n_bad:
        print(f"{n_bad} view(s) flagged (left out of the stereo step, or reprojection RMS > {limit:.2f} px)")


def _print_rig(cal: StereoCalibration) -> None:
    """The intrinsics of both cameras and the stereo fit."""
    import cv2

    rig = cal.rig
    angle_deg = float(np.degrees(np.linalg.norm(cv2.Rodrigues(rig.rotation)[0])))
    for name, result, k in (("left camera ", cal.left, rig.camera_matrix_left),
                            ("right camera", cal.right, rig.camera_matrix_right)):
        print(f"{name}  rms {result.rms_px:.3f} px   fx {k[0, 0]:.1f}  fy {k[1, 1]:.1f}  cx {k[0, 2]:.1f}  "
              f"cy {k[1, 2]:.1f}")
    print(f"stereo        rms {cal.rms_px:.3f} px over {int(cal.used.sum())} pairs   baseline {rig.baseline_m:.4f} m   "
          f"rotation {angle_deg:.2f} deg   rectified focal {rig.focal_px:.1f} px")
    if cal.rms_px > 1.0:
        print("warning: stereo RMS above 1 px; check the flagged views, the --square value and that both "
              "pictures of each pair were taken at the same moment")


def _save_stereo(args: argparse.Namespace, cal: StereoCalibration) -> None:
    """Write the rig file, keeping the microphones of an existing one."""
    from app.config import RigConfig, load_rig, save_rig

    microphones = None
    if args.output.exists():
        try:
            microphones = load_rig(args.output).microphones
        except UserError as exc:
            raise UserError(f"{exc}\n(the output file exists but is not a valid rig file; move it away or "
                            "choose another -o)") from None
    header = (f"avhear rig calibration: stereo from {int(cal.used.sum())} chessboard pairs ({args.left}, {args.right}), "
              f"pattern {args.pattern[0]}x{args.pattern[1]}, square {args.square} m, stereo RMS {cal.rms_px:.3f} px")
    save_rig(args.output, RigConfig(stereo=cal.rig, microphones=microphones), header=header)
    print(f"\nwrote {args.output}")


def run_stereo(args: argparse.Namespace) -> int:
    import cv2
    from avcore.stereo import calibrate_stereo

    corners_path = args.corners_image or args.output.with_name(args.output.stem + "_corners.png")
    distinct_outputs(("-o", args.output), ("--corners-image", corners_path))
    output_file(args.output, "-o")
    output_file(corners_path, "--corners-image")
    lefts, rights, images_l, images_r = _load_pairs(args)
    found_l, found_r, used, all_l = _detect_pairs(args, lefts, rights, images_l, images_r)
    cal = calibrate_stereo(found_l, found_r, args.pattern, args.square, images_l[0].shape[::-1], min_views=MIN_VIEWS)
    _print_views(cal, used, [f"{pl.name} / {pr.name}" for pl, pr in zip(lefts, rights)], args.max_view_error)
    print()
    _print_rig(cal)
    _save_stereo(args, cal)
    mosaic = _corners_mosaic(images_l, all_l, args.pattern, [p.name for p in lefts])
    if not cv2.imwrite(str(corners_path), mosaic):
        raise UserError(f"{corners_path}: cannot write the corners picture; choose another --corners-image")
    print(f"wrote {corners_path} (detected corners in the left pictures: check them by eye)")
    return 0


# ---------------------------------------------------------------------------------------------------------------
# avhear calibrate av


def add_av_parser(kinds: argparse._SubParsersAction) -> None:
    p = kinds.add_parser(
        "av", help="audio-visual correction c1, c0 from a recording (white-noise loudspeaker in a zig-zag)",
        description=(
            "Audio-visual calibration (paper section 5.3). RECORDING shows one person holding a loudspeaker that "
            "plays white-noise bursts (`avhear calibrate signal`) just below the face, walking a zig-zag across the "
            "whole field of view (about one minute; `avhear simulate calibration` makes one). Each frame with "
            "exactly one face gives an F3D position, each audio window an ITD; the ITDs are paired with the face "
            "of their instant and c1, c0 of eq. (itd_up) are fitted so that c1 * A(face) + c0 follows the ITDs. "
            "The hand-measured microphone positions come from --rig; the faces are located with the recording's "
            "own stereo calibration. Writes the output rig (the stereo section of --rig, or of the recording, "
            "kept), the paper's calibration figure as a PNG and an .rrd next to it, and prints the fit."
        ),
    )
    p.add_argument("recording", type=Path, metavar="RECORDING", help="recording folder (recordings/FORMAT.md)")
    p.add_argument("--rig", required=True, type=Path,
                   help="rig YAML with the hand-measured microphone positions ('microphones' section)")
    p.add_argument("-o", "--output", required=True, type=Path,
                   help="rig YAML to write (may be the same file as --rig): its c1, c0 are replaced")
    p.add_argument("--method", choices=("robust", "lstsq"), default="robust",
                   help="robust (default: Tukey-biweight line from a least-median start, insensitive to "
                        "reverberation outliers) or lstsq (the paper's plain least squares)")
    p.add_argument("--refine-positions", action="store_true",
                   help="also move the microphone positions (prior: 2 cm around --rig) to remove the parallax error "
                        "that c1, c0 cannot absorb; needs the full one-minute sequence; a refinement that moves a "
                        "microphone more than 5 cm is rejected and only c1, c0 are written")
    p.add_argument("--itd-method", default=DEFAULT_ITD_METHOD, choices=itd_methods(), metavar="METHOD",
                   help="ITD extractor: gcc-phat-robust (the default, as `avhear run`), correlogram, gcc-phat, "
                        "correlogram-robust")
    p.add_argument("--energy-threshold", type=_positive_float, default=1e-3,
                   help="audio windows with less mean power yield no ITD (paper's E_A, default 0.001)")
    p.add_argument("--pair-window", type=_positive_float, default=None, metavar="S",
                   help="an ITD is paired with a face at most S seconds away (default: half the frame interval)")
    p.add_argument("--figure", type=Path, default=None,
                   help="calibration figure PNG (default: next to the output, *_av_calibration.png; the .rrd "
                        "goes beside it)")
    p.add_argument("--no-rrd", action="store_true", help="do not write the Rerun .rrd of the figure")
    p.set_defaults(func=run_av)


def _check_av_inputs(args: argparse.Namespace) -> tuple[RigConfig, Path]:
    """The rig (with microphones), the recording's existence and every output path, before any work; returns the
    rig and the figure's path."""
    from app.config import MICROPHONES_HINT, load_rig

    rig = load_rig(args.rig)
    if rig.microphones is None and rig.array is None:
        raise UserError(f"{args.rig}: has no 'microphones' section: {MICROPHONES_HINT}")
    if not args.recording.exists():
        raise UserError(f"{args.recording}: no such recording folder; record the calibration sequence (a person "
                        "carrying a loudspeaker playing `avhear calibrate signal`'s white-noise bursts in a zig-zag "
                        f"across the view), or simulate one with `avhear simulate calibration -o {args.recording}`")
    figure = args.figure or args.output.with_name(args.output.stem + "_av_calibration.png")
    distinct_outputs(("-o", args.output), ("--figure", figure),
                     ("the figure's .rrd", None if args.no_rrd else figure.with_suffix(".rrd")))
    output_file(args.output, "-o")
    output_file(figure, "--figure")
    if not args.no_rrd:
        output_file(figure.with_suffix(".rrd"), "the figure's .rrd (--no-rrd to skip it)")
    return rig, figure


def _frame_progress() -> Callable[[int, int], None]:
    """A progress callback that prints at most every 2 s, and at the end."""
    last = [time.perf_counter()]

    def progress(done: int, total: int) -> None:
        now = time.perf_counter()
        if now - last[0] >= 2.0 or done == total:
            last[0] = now
            print(f"  faces: frame {done}/{total}", flush=True)
    return progress


def _print_av_report(result: CalibrationResult, args: argparse.Namespace) -> None:
    """What was found (faces, ITDs, pairs), the fit, and warnings a user can act on."""
    faces, rep = result.faces, result.report
    n_none = int((faces.n_faces == 0).sum())
    n_many = int((faces.n_faces > 1).sum())
    n_bad = int((faces.n_faces < 0).sum())
    print(f"faces   {int(faces.single.sum())} of {faces.n_faces.size} frames with exactly one face "
          f"({n_none} with none, {n_many} with several{f', {n_bad} unreadable' if n_bad else ''})")
    print(f"ITDs    {len(result.itds)} windows passed the energy gate ({result.itd_method}, W 150 ms, hop 20 ms)")
    print(f"pairs   {len(result.pairs)} face/ITD pairs")
    print(f"fit     {rep.method}: c1 = {rep.c1:.4f}   c0 = {rep.c0 * 1e6:+.2f} us   "
          f"inliers {int(rep.inliers.sum())}/{rep.n_pairs} ({100 * rep.inlier_share:.1f} %)")
    print(f"median |ITD residual| over the inliers: before {rep.median_abs_before_s * 1e6:.1f} us, "
          f"after {rep.median_abs_after_s * 1e6:.1f} us")
    if result.rejected_shift_m is not None:
        print(f"refinement rejected: it moved a microphone by {100 * result.rejected_shift_m:.1f} cm, far more than a "
              "hand measurement is off (1-2 cm), so the data cannot pin the positions down (too short a sequence, or "
              "ITDs that reverberation or a head make differ from free field); the measured positions are kept and "
              "only c1, c0 are fitted (printed above)")
    elif args.refine_positions:
        shift = rep.position_shift_m * 100
        print(f"microphones moved by {np.linalg.norm(shift[0]):.2f} cm (left) and {np.linalg.norm(shift[1]):.2f} "
              f"cm (right): left {_xyz(rep.mics.left)} m, right {_xyz(rep.mics.right)} m")
    if rep.c1 < 0.5 or rep.c1 > 1.5:
        print(f"warning: c1 = {rep.c1:.3f} is far from 1; check the microphone positions in {args.rig} and the "
              "speed of sound")


def run_av(args: argparse.Namespace) -> int:
    from app.config import RigConfig, save_rig

    from app.av_calibration import calibrate_recording
    from app.sources.recording import open_recording

    rig, figure = _check_av_inputs(args)
    if rig.array is not None:
        return _run_av_array(args, rig, figure)
    recording = open_recording(args.recording)
    mics = rig.microphones
    print(f"calibrating {args.recording}: {len(recording.frame_stamps_s)} frames, "
          f"{recording.n_samples / recording.samplerate_hz:.1f} s of audio; microphones from {args.rig} "
          f"({mics.distance_m * 100:.1f} cm apart)", flush=True)
    try:
        result = calibrate_recording(recording, mics, method=args.method, refine_positions=args.refine_positions,
                                     itd_method=args.itd_method, energy_threshold=args.energy_threshold,
                                     max_gap_s=args.pair_window, progress=_frame_progress())
    finally:
        recording.close()
    _print_av_report(result, args)
    rep = result.report
    header = (f"avhear rig calibration: audio-visual c1, c0 ({rep.method}) from {args.recording}, "
              f"{rep.n_pairs} face/ITD pairs, median |ITD residual| {rep.median_abs_before_s * 1e6:.1f} -> "
              f"{rep.median_abs_after_s * 1e6:.1f} us"
              + ("; microphone positions refined" if args.refine_positions and result.rejected_shift_m is None
                 else ""))
    stereo = rig.stereo if rig.stereo is not None else recording.stereo
    save_rig(args.output, RigConfig(stereo=stereo, microphones=rep.mics), header=header)
    print(f"\nwrote {args.output}")
    _save_av_figures(result, figure, args.no_rrd)
    return 0


def _save_av_figures(result: CalibrationResult, figure: Path, no_rrd: bool, what: str = "") -> None:
    """The calibration's figure (PNG) and, unless ``no_rrd``, its ``.rrd`` beside it; ``what`` says whose they
    are when that is not obvious."""
    from app.console.calibration import log_calibration_rrd
    from app.eval.calibration_figure import save_calibration_figure

    save_calibration_figure(result, figure)
    print(f"wrote {figure} ({what}extracted ITDs red, faces before blue, after green)")
    if not no_rrd:
        rrd = figure.with_suffix(".rrd")
        log_calibration_rrd(result, rrd, figure_png=figure)
        print(f"wrote {rrd} (open with `rerun {rrd}`)")


def _run_av_array(args: argparse.Namespace, rig: RigConfig, figure: Path) -> int:
    """``calibrate av`` with a microphone array in the rig: c1, c0 of every pair (:func:`calibrate_array`), one table
    row per pair (a pair the fit refuses keeps its values, and the row says why); the rig file gets them in its
    ``array`` section; the figure and ``.rrd`` show the first pair fitted."""
    from app.config import RigConfig, save_rig

    from app.av_calibration import calibrate_array
    from app.sources.recording import open_recording

    array = rig.array
    assert array is not None
    if args.refine_positions:
        raise UserError("--refine-positions refines one pair's two microphones; with an array in the rig, measure "
                        "its placement (rotation, translation_m) instead, and leave the flag out")
    recording = open_recording(args.recording)
    print(f"calibrating {args.recording}: {len(recording.frame_stamps_s)} frames, "
          f"{recording.n_samples / recording.samplerate_hz:.1f} s of audio; the array of {args.rig}: "
          f"{len(array.positions)} microphones, {array.n_pairs} pairs", flush=True)
    try:
        fitted, results = calibrate_array(recording, array, method=args.method, itd_method=args.itd_method,
                                          energy_threshold=args.energy_threshold, max_gap_s=args.pair_window,
                                          progress=_frame_progress())
    finally:
        recording.close()
    fitted_results = [r for r in results if not isinstance(r, str)]
    first = fitted_results[0]
    _print_av_report(first, args)
    print(f"\n{'pair':>4} {'mics':>6} {'cm':>5} {'face/ITD pairs':>15} {'c1':>8} {'c0 [us]':>8} "
          f"{'median |residual| [us]':>24}")
    for k, ((i, j), r) in enumerate(zip(array.pairs, results)):  # type: ignore[arg-type]
        head = f"{k:>4} {f'{i}-{j}':>6} {array.pair(k).distance_m * 100:5.1f}"
        if isinstance(r, str):
            print(f"{head}   kept c1 {fitted.c1[k]:.4f}, c0 {fitted.c0[k] * 1e6:+.2f} us: {r}")  # type: ignore[index]
            continue
        rep = r.report
        print(f"{head} {rep.n_pairs:>15} {rep.c1:8.4f} {rep.c0 * 1e6:+8.2f} {rep.median_abs_before_s * 1e6:11.1f} -> "
              f"{rep.median_abs_after_s * 1e6:5.1f}")
    header = (f"avhear rig calibration: audio-visual c1, c0 ({first.report.method}) of {len(fitted_results)} of the "
              f"array's {array.n_pairs} pairs from {args.recording}")
    stereo = rig.stereo if rig.stereo is not None else recording.stereo
    save_rig(args.output, RigConfig(stereo=stereo, microphones=rig.microphones, array=fitted), header=header)
    print(f"\nwrote {args.output} (the array's c1, c0 per pair"
          + ("; its 'microphones' pair is copied unchanged)" if rig.microphones is not None else ")"))
    _save_av_figures(first, figure, args.no_rrd, "the first pair fitted; ")
    return 0


def _xyz(p: tuple[float, float, float]) -> str:
    return "(" + ", ".join(f"{v:+.4f}" for v in p) + ")"


def add_signal_parser(kinds: argparse._SubParsersAction) -> None:
    on, off = CALIBRATION_BURST_S
    p = kinds.add_parser(
        "signal", help="write the WAV that the calibration loudspeaker plays (white-noise bursts)",
        description=(
            f"Write the signal for the audio-visual calibration (section 5.3): white-noise bursts of {on * 1000:.0f} "
            f"ms every {on + off:.1f} s, as the simulated calibration uses. Bursts rather than the paper's "
            "continuous noise: the default ITD extractor weights onsets, as it must for speech, and continuous "
            "noise gives it ITDs pulled further towards zero by the room (avcore.calibration.CALIBRATION_BURST_S). "
            "Play it from a small loudspeaker held just below the face and record with `avhear record`."
        ),
    )
    p.add_argument("-o", "--output", required=True, type=Path, help="WAV file to write (mono, 16-bit)")
    p.add_argument("--duration", type=duration(3600.0), default=90.0, help="seconds (default 90, at most 3600)")
    p.add_argument("--samplerate", type=count(8000, 192000), default=48000, help="hertz (default 48000)")
    p.add_argument("--level", type=float, default=-18.0, metavar="DBFS",
                   help="RMS level of the bursts, dB below full scale (default -18)")
    p.add_argument("--seed", type=count(0), default=0, help="seed of the noise (default 0)")
    p.set_defaults(func=run_signal)


def run_signal(args: argparse.Namespace) -> int:
    import wave

    try:
        signal = calibration_signal(args.samplerate, args.duration, seed=args.seed, level_dbfs=args.level)
    except ValueError as exc:
        raise UserError(f"avhear calibrate signal: {exc}") from exc
    if args.output.suffix.lower() != ".wav":
        raise UserError(f"{args.output}: the output must be a .wav file")
    output_file(args.output, "-o")
    pcm = np.round(signal * 32767).astype("<i2")
    try:
        with open(args.output, "wb") as raw, wave.open(raw, "wb") as f:
            f.setnchannels(1)
            f.setsampwidth(2)
            f.setframerate(args.samplerate)
            f.writeframes(pcm.tobytes())
    except OSError as exc:
        raise UserError(f"cannot write {args.output}: {exc.strerror or exc}") from None
    on, off = CALIBRATION_BURST_S
    print(f"wrote {args.output}: {args.duration:g} s at {args.samplerate} Hz, {on * 1000:.0f} ms bursts every "
          f"{on + off:.1f} s at {args.level:g} dBFS RMS")
    return 0
