"""Audio-visual calibration (paper section 5.3, issue 5): plain least squares vs the robust fit of c1, c0.

A simulated calibration session (``sim.calibration.simulate_calibration``): a person holding a white-noise
loudspeaker walks a zig-zag across the +-28 x +-20 degree field of view at 1-3 m for a minute; one face/ITD pair per
20 ms hop; true microphones 12 cm apart; ITD noise 10 us; a share of the ITDs replaced by outliers uniform over the
ITD interval. The hand-measured microphone positions are each off by the given distance in a random direction.

Columns (medians over the seeds; ITD quantities in microseconds):

- ``method``: ``lstsq`` is the paper's plain least squares, ``robust`` the default fit (LMedS start, Tukey IRLS),
  ``robust+pos`` the robust fit followed by the refinement of the microphone positions (``refine_positions``,
  beyond the paper);
- ``c1``, ``c0``: the fitted correction of eq. (itd_up);
- ``res before`` / ``res after``: median |ITD - mapped face| over the ITDs that came from the face (the outliers
  excluded by the simulation's truth), with the hand-measured microphones before / after the correction. The
  10 us ITD noise alone gives 6.7 us: this is the floor;
- ``map before`` / ``map after``: median |mapped face - true ITD| along the trajectory, noise-free: the error of
  the mapping itself;
- ``worst map``: the largest ``map after`` over the seeds (some error directions suit the affine model less);
- ``ok``: ``res after <= 8 us`` (the issue's target for 1-2 cm errors and 15 % outliers).

    python benchmarks/av_calibration.py                 # the grid, a few seconds
    python benchmarks/av_calibration.py --seeds 20 --errors-cm 2 --outliers 15
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from avcore.calibration import fit_av_calibration  # noqa: E402
from sim.calibration import CalibrationSession, simulate_calibration  # noqa: E402
from avcore.geometry import MicPair  # noqa: E402

US = 1e-6
# Row label -> options of fit_av_calibration. "robust+pos" also refines the microphone positions (beyond the paper).
METHODS = {
    "lstsq": {"method": "lstsq"},
    "robust": {"method": "robust"},
    "robust+pos": {"method": "robust", "refine_positions": True},
}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--errors-cm", type=float, nargs="+", default=[0.0, 1.0, 1.5, 2.0],
                        help="hand-measurement error of each microphone position, cm")
    parser.add_argument("--outliers", type=float, nargs="+", default=[0.0, 15.0, 30.0],
                        help="share of outlier ITDs, percent")
    parser.add_argument("--seeds", type=int, default=5, help="sessions per cell (default 5)")
    parser.add_argument("--duration", type=float, default=60.0, help="session length, s (the paper: one minute)")
    parser.add_argument("--itd-noise-us", type=float, default=10.0, help="ITD noise, us")
    parser.add_argument("--channel-delay-us", type=float, default=0.0,
                        help="constant inter-channel delay of the sound card, us")
    parser.add_argument("--speed-of-sound", type=float, default=343.0,
                        help="true speed of sound, m/s (the mapping assumes 343)")
    return parser.parse_args(argv)


def residual_us(session: CalibrationSession, mics: MicPair) -> float:
    """Median |ITD - mapped face| over the ITDs that came from the face, microseconds."""
    face = ~session.is_outlier
    return float(np.median(np.abs(session.itds_s - mics.itd(session.faces_xyz))[face]) / US)


def mapping_error_us(session: CalibrationSession, mics: MicPair) -> float:
    """Median |mapped true face - noise-free ITD| along the trajectory, microseconds."""
    return float(np.median(np.abs(mics.itd(session.true_faces_xyz) - session.true_itds_s)) / US)


def run_cell(args: argparse.Namespace, error_cm: float, outlier_pct: float) -> dict[str, np.ndarray]:
    """Per method: an array (seeds, 7) of c1, c0, res before, res after, map before, map after, fit ms."""
    rows: dict[str, list[list[float]]] = {m: [] for m in METHODS}
    for seed in range(args.seeds):
        session = simulate_calibration(
            duration_s=args.duration,
            mic_error_m=error_cm / 100.0,
            outlier_share=outlier_pct / 100.0,
            itd_noise_s=args.itd_noise_us * US,
            channel_delay_s=args.channel_delay_us * US,
            true_speed_of_sound=args.speed_of_sound,
            seed=seed,
        )
        measured = session.measured_mics
        for method, options in METHODS.items():
            start = time.perf_counter()
            fitted = fit_av_calibration(session.faces_xyz, session.itds_s, measured, **options)
            elapsed_ms = 1e3 * (time.perf_counter() - start)
            rows[method].append([fitted.c1, fitted.c0 / US, residual_us(session, measured),
                                 residual_us(session, fitted), mapping_error_us(session, measured),
                                 mapping_error_us(session, fitted), elapsed_ms])
    return {m: np.asarray(r) for m, r in rows.items()}


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    start = time.perf_counter()
    header = (f"{'mic err cm':>10} {'outliers':>8} {'method':>10} {'c1':>6} {'c0 us':>6} {'res before':>10} "
              f"{'res after':>9} {'map before':>10} {'map after':>9} {'worst map':>9} {'fit ms':>6}  ok")
    print(f"AV calibration, {args.seeds} sessions of {args.duration:.0f} s per cell, ITD noise {args.itd_noise_us:g} us, "
          f"channel delay {args.channel_delay_us:g} us, true speed of sound {args.speed_of_sound:g} m/s")
    print(header)
    print("-" * len(header))
    for error_cm in args.errors_cm:
        for outlier_pct in args.outliers:
            cell = run_cell(args, error_cm, outlier_pct)
            for method in METHODS:
                values = cell[method]
                med = np.median(values, axis=0)
                ok = "yes" if med[3] <= 8.0 else "no"
                print(f"{error_cm:>10.1f} {outlier_pct:>7.0f}% {method:>10} {med[0]:>6.3f} {med[1]:>6.1f} "
                      f"{med[2]:>10.1f} {med[3]:>9.1f} {med[4]:>10.1f} {med[5]:>9.1f} {values[:, 5].max():>9.1f} "
                      f"{med[6]:>6.1f}  {ok}")
    print(f"({time.perf_counter() - start:.1f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
