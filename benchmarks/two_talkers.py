"""Two people speaking at once, heard by a microphone array: who speaks, per 0.4 s interval, with every pair of the
array against its left-right pair alone (issue 19's benchmark).

    python benchmarks/two_talkers.py                     # NAO's microphones, 6 rooms of 30 s
    python benchmarks/two_talkers.py --mics respeaker4 --rooms 3 --duration 20

Each room (``sim.roomsim``: image-source reverberation, RT60 0.4-0.6 s, the robot's fan, a diffuse kitchen noise)
holds three seated people in front of the robot at random places; two of them talk, each on their own timeline of
CMU ARCTIC sentences (speech other than the paper's digits) with pauses of 0.3-2 s, so that they often talk at
once; the third stays silent. The faces are given (their true positions: this benchmark is about hearing). The
ITDs are extracted as the pipeline does (gcc-phat-robust, 150 ms windows every 20 ms, the single 32 ms frames and
their bands, and with the array the frames' bins on every pair), and :class:`avcore.inference.FaceGuidedHearing`
decides each 0.4 s interval on them, once with the array (every pair) and once with its first pair (the widest
left-right one). The bin look's thresholds (``SpeakingTest.bin_*``) were chosen on rooms 0-5 (seeds 0-5, the
default); ``--first-seed 6`` gives rooms that played no part in the choice.

Truth per interval and person (``sim.roomsim.window_truth`` on the dry signals): speaking when the person is the
loudest active talker, or active within 10 dB of the loudest, in at least half of the interval's windows; silent when
never active in it. Intervals in between (a few windows) are not scored.

Targets (issue 19): with every pair, >= 90 % of the speaking (interval, person) found, false alarms on <= 10 % of
the silent ones, and better than the left-right pair alone on both.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy.signal import fftconvolve

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from avcore.geometry import MicArray  # noqa: E402
from avcore.inference import FaceGuidedHearing  # noqa: E402
from avcore.itd import FrameBins, PairsItdStream  # noqa: E402
from sim.roomsim import AcousticRoom, fan_noise, load_speech, noise_positions, pink_noise  # noqa: E402

FS = 16000
INTERVAL_S = 0.4
WINDOW_S, HOP_S = 0.15, 0.02


def timeline(utterances: list[np.ndarray], n: int, rng: np.random.Generator) -> np.ndarray:
    """One talker's dry signal: sentences at unit RMS over their loud part, pauses of 0.3-2 s."""
    out = np.zeros(n)
    pos = int(rng.uniform(0.0, 1.5) * FS)
    while True:
        u = utterances[int(rng.integers(len(utterances)))]
        if pos + u.size > n:
            return out
        loud = np.abs(u) > 0.05 * np.abs(u).max()
        out[pos:pos + u.size] = u / np.sqrt(np.mean(u[loud] ** 2))
        pos += u.size + int(rng.uniform(0.3, 2.0) * FS)


def activity(dry: np.ndarray, active_db: float = -10.0) -> tuple[np.ndarray, np.ndarray]:
    """Window centres (W,) and (T, W) bool: talker t active in window w (power within ``active_db`` of its mean
    power over its speech)."""
    w, hop = round(WINDOW_S * FS), round(HOP_S * FS)
    n_windows = 1 + (dry.shape[1] - w) // hop
    csum = np.concatenate([np.zeros((dry.shape[0], 1)), np.cumsum(dry**2, axis=1)], axis=1)
    starts = np.arange(n_windows) * hop
    power = (csum[:, starts + w] - csum[:, starts]) / w
    speech_power = np.array([np.mean(d[np.abs(d) > 0] ** 2) for d in dry])
    return (starts + 0.5 * w) / FS, power >= speech_power[:, None] * 10 ** (active_db / 10)


def make_room(seed: int, array: MicArray, utterances: list[np.ndarray], noise: np.ndarray | None,
              duration_s: float) -> dict:
    rng = np.random.default_rng([seed, 19])
    room = AcousticRoom(dims_m=(5.0, 5.0, 2.7), rt60_s=float(rng.uniform(0.4, 0.6)), head_m=(2.5, 0.8, 1.0),
                        mic_positions_m=array.positions)
    # three seated people 1.4-2.6 m away, at least 25 degrees apart in azimuth
    while True:
        az = np.sort(rng.uniform(-45.0, 45.0, 3))
        if np.all(np.diff(az) >= 25.0):
            break
    depth = rng.uniform(1.4, 2.6, 3)
    faces = np.stack([depth * np.sin(np.radians(az)), rng.uniform(-0.2, -0.05, 3), depth * np.cos(np.radians(az))],
                     axis=1)
    talkers = rng.choice(3, size=2, replace=False)
    n = round(duration_s * FS)
    dry = np.stack([timeline(utterances, n, rng) for _ in talkers])
    noise_src = noise_positions(room, "diffuse")
    sources = np.vstack([faces[talkers], noise_src, [(0.02, -0.04, -0.06)]])
    rirs, _ = room.impulse_responses(sources)
    q = rirs.shape[1]
    out = np.zeros((q, n))
    for t in range(2):
        for m in range(q):
            out[m] += 0.1 * fftconvolve(dry[t], rirs[t, m])[:n]  # 0.1 RMS at 1 m (the direct path is 1/r)
    speech_rms = float(np.sqrt(np.mean(out[0][np.abs(out[0]) > 1e-4] ** 2)))
    for j in range(noise_src.shape[0]):
        start = int(rng.integers(0, max(1, noise.size - n))) if noise is not None else 0
        excerpt = np.resize(noise[start:start + n], n) if noise is not None else pink_noise(n, rng)
        img = np.stack([fftconvolve(excerpt, rirs[2 + j, m])[:n] for m in range(q)])
        out += img * (speech_rms * 10 ** (-20 / 20) / max(np.sqrt(np.mean(img[0] ** 2)), 1e-12) / noise_src.shape[0])
    fan = np.stack([fftconvolve(fan_noise(n, FS, rng), rirs[-1, m])[:n] for m in range(q)])
    out += fan * (speech_rms * 10 ** (-25 / 20) / max(np.sqrt(np.mean(fan[0] ** 2)), 1e-12))
    out += 1e-4 * rng.standard_normal(out.shape)
    # the truth: each talker's dry signal delayed to the head (direct path, plus pyroomacoustics' 40 samples)
    aligned = np.zeros((3, n))
    for t, who in enumerate(talkers):
        d = round(np.linalg.norm(faces[who]) / array.speed_of_sound * FS) + 40
        aligned[who, d:] = dry[t, :n - d]
    return {"audio": out.T, "faces": faces, "aligned": aligned, "talkers": talkers}


def decide(room: dict, array: MicArray, use_array: bool) -> tuple[np.ndarray, np.ndarray]:
    """(I, 3) judged speaking per interval and person, and the interval starts (I,)."""
    hearing_array = array if use_array else MicArray(array.positions, (array.pairs[0],), array.speed_of_sound)
    stream = PairsItdStream(hearing_array, FS, method="gcc-phat-robust", window_s=WINDOW_S, hop_s=HOP_S,
                            energy_threshold=1e-3, frame_itds=True, frame_bins=use_array)
    audio = room["audio"]
    times, vectors, f_times, f_vectors, b_times, b_vectors, bins = [], [], [], [], [], [], []
    for i in range(0, audio.shape[0], 512):
        t, v = stream.push(audio[i:i + 512])
        times.append(t)
        vectors.append(v)
        ft, fv = stream.pop_frame_itds()
        bt, bv = stream.pop_band_itds()
        f_times.append(ft)
        f_vectors.append(fv)
        b_times.append(bt)
        b_vectors.append(bv)
        if use_array:
            bins.append(stream.pop_frame_bins())
    times, vectors = np.concatenate(times), np.concatenate(vectors)
    f_times, f_vectors = np.concatenate(f_times), np.concatenate(f_vectors)
    b_times, b_vectors = np.concatenate(b_times), np.concatenate(b_vectors)
    all_bins = FrameBins.concatenate(bins) if use_array else None
    hearing = FaceGuidedHearing(hearing_array if use_array else hearing_array.pair(0))
    starts = np.arange(0.0, audio.shape[0] / FS - INTERVAL_S + 1e-9, INTERVAL_S)
    judged = np.zeros((starts.size, 3), dtype=bool)
    for k, t0 in enumerate(starts):
        sel = (times >= t0) & (times < t0 + INTERVAL_S)
        fsel = (f_times >= t0) & (f_times < t0 + INTERVAL_S)
        bsel = (b_times >= t0) & (b_times < t0 + INTERVAL_S)
        if use_array:
            out = hearing.step(room["faces"], vectors[sel], None, f_vectors[fsel], b_vectors[bsel],
                               all_bins.within(t0 + INTERVAL_S / 2, INTERVAL_S / 2))
        else:
            a = vectors[sel, 0]
            out = hearing.step(room["faces"], a[np.isfinite(a)], None, f_vectors[fsel, 0], b_vectors[bsel, 0])
        judged[k] = out.speaking
    return judged, starts


def truth(room: dict, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(I, 3) speaking and silent per interval and person (see the module docstring)."""
    centres, active = activity(room["aligned"][room["talkers"]])
    speaking = np.zeros((starts.size, 3), dtype=bool)
    silent = np.ones((starts.size, 3), dtype=bool)
    for k, t0 in enumerate(starts):
        inside = (centres >= t0) & (centres < t0 + INTERVAL_S)
        for t, who in enumerate(room["talkers"]):
            share = active[t, inside].mean() if inside.any() else 0.0
            speaking[k, who] = share >= 0.5
            silent[k, who] = share == 0.0
    return speaking, silent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mics", default="nao", help="array preset (default nao)")
    parser.add_argument("--rooms", type=int, default=6)
    parser.add_argument("--duration", type=float, default=30.0, help="seconds per room")
    parser.add_argument("--first-seed", type=int, default=0)
    args = parser.parse_args()
    array = MicArray.preset(args.mics)
    utterances = load_speech(FS, "arctic")
    if not utterances:
        sys.exit("needs ../shared/data/speech/arctic (CMU ARCTIC sentences); set AVHEAR_DATA")
    from sim.roomsim import read_wav, resolve_data_dir

    noise_file = resolve_data_dir() / "noise" / "doing_the_dishes.wav"
    noise = read_wav(noise_file, FS) if noise_file.is_file() else None
    print(f"{args.rooms} rooms of {args.duration:.0f} s, two of three people talking on their own timelines, "
          f"microphones {args.mics} ({array.n_pairs} pairs); per 0.4 s interval and person")
    totals = {True: np.zeros(4), False: np.zeros(4)}  # found, speaking, false alarms, silent
    overlap_share = []
    for seed in range(args.first_seed, args.first_seed + args.rooms):
        t0 = time.perf_counter()
        room = make_room(seed, array, utterances, noise, args.duration)
        row = []
        for use_array in (False, True):
            judged, starts = decide(room, array, use_array)
            speaking, silent = truth(room, starts)
            counts = np.array([(judged & speaking).sum(), speaking.sum(), (judged & silent).sum(), silent.sum()])
            totals[use_array] += counts
            row.append(f"{'all pairs' if use_array else 'first pair'}: found {counts[0]}/{counts[1]}, false "
                       f"alarms {counts[2]}/{counts[3]}")
        both = speaking[:, room["talkers"]].all(axis=1)
        overlap_share.append(both.mean())
        print(f"  room {seed}: {'; '.join(row)}; both talk in {100 * both.mean():.0f} % of the intervals "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)
    print(f"\n{'':<12} {'speaking found':>16} {'false alarms on silent':>24}")
    for use_array, name in ((False, "first pair"), (True, "all pairs")):
        f, s, fa, si = totals[use_array]
        print(f"{name:<12} {f:>6.0f}/{s:<5.0f} {100 * f / s:5.1f} % {fa:>8.0f}/{si:<5.0f} {100 * fa / si:5.1f} %")
    print(f"two talkers at once in {100 * np.mean(overlap_share):.0f} % of the intervals; targets with all pairs: found "
          ">= 90 %, false alarms <= 10 %, both better than the first pair")


if __name__ == "__main__":
    main()
