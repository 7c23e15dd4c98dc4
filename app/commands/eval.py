"""`avhear eval ...`: accuracy evaluations that print the paper's tables beside ours.

``synthetic``: Algorithm 1 on the synthetic sequences of section 7.1 (tables 1 and 2). ``scenarios``: the simulated
room's scenarios S1-S5 through the real pipeline, the table of section 7.3 (see :mod:`app.eval.scenarios`).
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from app.errors import UserError
from app.commands.options import (MAX_SIMULATED_S, LazyChoices, add_bodies_argument, add_camera_argument,
                                  add_lips_argument, add_method_arguments, add_mics_argument, count, duration,
                                  pipeline_config, wants_bodies, wants_lips)
from app.commands.paths import output_dir
from avcore.geometry import MicArray, MicPair
from sim.presets import INTERVAL_S, SCENARIO_CHOICES, SCENARIOS, SEQUENCES

if TYPE_CHECKING:
    from app.eval.scenarios import CalibrationFit
    from app.pipeline_config import PipelineConfig


def _synthetic_variants() -> LazyChoices:
    def load() -> list[str]:
        from app.eval.synthetic import VARIANTS

        return sorted(VARIANTS)
    return LazyChoices(load)


def _room_methods() -> LazyChoices:
    def load() -> tuple[str, ...]:
        from app.eval.rooms import METHODS

        return METHODS
    return LazyChoices(load)


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser("eval", help="accuracy evaluations (the paper's section 7)")
    kinds = parser.add_subparsers(dest="kind", metavar="KIND")
    kinds.required = True
    syn = kinds.add_parser(
        "synthetic",
        help="Algorithm 1 on the synthetic sequences of section 7.1 (tables 1 and 2)",
        description="Run Motion-Guided Robot Hearing (Algorithm 1) on the four synthetic sequence types of the "
        "paper's section 7.1 and print its tables 1 (visual) and 2 (auditory state) with the paper's published "
        "numbers, the paper's method as implemented here, and avhear's method.",
    )
    syn.add_argument("--sequence", nargs="+", choices=SEQUENCES, default=list(SEQUENCES), metavar="NAME",
                     help=f"sequence types to run (default: all of {', '.join(SEQUENCES)})")
    syn.add_argument("--seed", nargs="+", type=count(0), default=None, metavar="N",
                     help="seeds of the generated sequences (default: 0 1 2)")
    syn.add_argument("--variant", nargs="+", choices=_synthetic_variants(), default=["paper", "avhear"],
                     metavar="VARIANT", help="which variants of the method to run: paper, avhear (default: both)")
    syn.add_argument("--face-guided", action="store_true",
                     help="also run Algorithm 2 (faces given) with its variants on the same sequences (table 3)")
    syn.add_argument("--json", action="store_true", help="print the results as JSON instead of tables")
    syn.set_defaults(func=run_synthetic)
    sce = kinds.add_parser(
        "scenarios",
        help="the simulated room's scenarios S1-S5 through the real pipeline (section 7.3's table)",
        description="Simulate the scenarios S1-S5 of the paper's section 7.3, run each through the real pipeline "
        "(face detection and F3D on the rendered frames, ITD extraction on the simulated audio, face-guided "
        "fusion, or motion-guided with --motion) and print the FP, FN and TP of the speaking states beside the "
        "paper's table, counted per spoken number (the paper's unit) and per visible person and interval of "
        f"{INTERVAL_S} s. Also per scenario: the share of "
        "frames with every visible face found, the median F3D error and the ITD accuracy.",
    )
    sce.add_argument("--scenario", nargs="+", choices=SCENARIO_CHOICES, default=list(SCENARIOS), metavar="NAME",
                     help=f"scenarios to run (default: the paper's {', '.join(SCENARIOS)}; S6: two people in one "
                          "direction, one behind the other)")
    sce.add_argument("--seed", nargs="+", type=count(0), default=[0], metavar="N",
                     help="seeds of the simulated scenarios; counts are summed over them (default: 0)")
    sce.add_argument("--duration", type=duration(MAX_SIMULATED_S), default=None, metavar="SECONDS",
                     help="seconds of each scenario (default: the preset's, 20 s; 25 s for S5)")
    add_method_arguments(sce)
    add_mics_argument(sce)
    add_bodies_argument(sce)
    add_lips_argument(sce)
    add_camera_argument(sce)
    sce.add_argument("--calibrate", action=argparse.BooleanOptionalAction, default=True,
                     help="first fit the audio-visual correction c1, c0 (section 5.3) on the 'calibration' preset "
                          "(40 s), as a user of the rig would, and fuse with it (default); --no-calibrate fuses "
                          "with the nominal microphone pair (c1 = 1, c0 = 0)")
    sce.add_argument("--timeline", type=Path, default=None, metavar="DIR",
                     help="also save each run's speaking states over time, beside the truth, as DIR/S1_seed0.png "
                          "and so on: spoken numbers, misses, false stretches, faces not found")
    sce.add_argument("--array-turned", type=float, default=None, metavar="DEG",
                     help="with an array of several pairs (--mics): tell the pipeline the array is turned DEG degrees "
                          "about the vertical from where the room has it, as a rig file placed wrongly would (default "
                          f"{START_YAW_ERROR_DEG:g} with --self-calibrate, which learns it back, else 0)")
    sce.add_argument("--motion-variant", choices=("avhear", "paper"), default="avhear",
                     help="with --motion: avhear's Algorithm 1 (default) or the paper's as written (its BIC "
                          "search, the determinant test, no 3D refinement), to print beside it")
    sce.add_argument("--json", action="store_true", help="print the results as JSON instead of the table")
    sce.set_defaults(func=run_scenarios)
    rooms = kinds.add_parser(
        "rooms",
        help="rooms drawn from a seed (sizes, reverberation, 2-4 people, sentences overlapping, noise), scored per "
             "result and person",
        description="Draw each room from its seed (4-9 m a side, RT60 0.2-0.7 s, 2-4 people seated or standing in "
        "view, read sentences in turns with 15-40 %% of the speech overlapped, noise 10-30 dB under the speech), run "
        "it through the real pipeline and print, per method, the precision and recall of the speaking states per "
        "result and person (plain, and with the edges of each person's speech forgiven by 0.3 s), the utterances "
        "heard and the false speaking stretches per utterance. Seeds below 100 are for choosing defaults; 100-119 "
        "are held out.",
    )
    _add_room_arguments(rooms)
    rooms.add_argument("--method", nargs="+", choices=_room_methods(), default=None, metavar="METHOD",
                       help="avhear (the options given), paper (Algorithm 2 as written: free means, tau_A, the "
                            "correlogram's ITDs, no vote), all-rescues (avhear with every call of the speaking "
                            "test's later looks standing); default avhear and paper")
    add_method_arguments(rooms)
    add_mics_argument(rooms)
    add_lips_argument(rooms)
    add_camera_argument(rooms)
    rooms.add_argument("--far-faces", action="store_true",
                       help="film the rooms at 320 x 240 (the same 60-degree view): every face 16-45 px wide, as "
                            "small as faces 2-5.6 m away in the 640 x 480 camera (the lips' check of faces too "
                            "small to read)")
    rooms.add_argument("--calibrate", action="store_true",
                       help="first fit the audio-visual correction c1, c0 (section 5.3) on the 'calibration' preset "
                            "(40 s, a room of its own), as a user of the rig would, and hear every room with it; "
                            "by default the rooms are heard with the nominal microphone pair (one pair only)")
    rooms.add_argument("--json", action="store_true", help="print the results as JSON instead of the table")
    rooms.set_defaults(func=run_rooms)
    voices = kinds.add_parser(
        "voices",
        help="each person's voice from the microphones in drawn rooms: SI-SDR improvement of each candidate",
        description="Draw each room from its seed (as eval rooms), keep each talker's own signals, and take every "
        "person's voice from all the microphones by each candidate (delay-and-sum, MVDR from the person's silent "
        "frames, either with the direction mask, the stream avhear hands out; and three oracles that know each "
        "talker's signals: the ideal mask, the talker's own image, the multichannel Wiener filter), steered at the "
        "person's face and told when "
        "they are silent by the truth. Prints each candidate's SI-SDR improvement over the reference microphone "
        "against the person's dry speech, where they talk alone and where another talks at once. With --scenario, "
        "the simulated scenarios S1-S5 (counting; people who walk are steered at each frame's place) instead.",
    )
    _add_room_arguments(voices)
    voices.add_argument("--scenario", nargs="+", default=None, choices=("S1", "S2", "S3", "S4", "S5"),
                        metavar="S", help="scenarios S1..S5 drawn with each --seed, instead of the rooms")
    add_mics_argument(voices)
    voices.add_argument("--json", action="store_true", help="print the results as JSON instead of the table")
    voices.set_defaults(func=run_voices)
    words = kinds.add_parser(
        "words",
        help="who said what: speaker-attributed word error rates (cpWER) of each person's words",
        description="Run simulated scenarios (S1-S5: counting, the digits' grammar) or drawn rooms (--rooms SEED "
        "...: read sentences, the general language model) through the pipeline with each person's voice and words, "
        "and print the cpWER (meeteval) of avhear's words, of the same recogniser on the reference microphone cut "
        "at avhear's utterances, and on each talker's dry speech (the recogniser's ceiling).",
    )
    words.add_argument("--scenario", nargs="+", default=None, choices=("S1", "S2", "S3", "S4", "S5"),
                       metavar="S", help="scenarios S1..S5 (default all five, unless --rooms)")
    words.add_argument("--rooms", nargs="+", type=int, default=None, metavar="SEED", help="drawn rooms' seeds")
    words.add_argument("--seed", type=int, default=0, help="the scenarios' seed (default 0)")
    words.add_argument("--duration", type=float, default=None, metavar="SECONDS",
                       help="shorten each run (default the scenario's or the room's own length)")
    add_mics_argument(words)
    words.add_argument("--json", action="store_true", help="print the results as JSON instead of the table")
    words.set_defaults(func=run_words)


def _add_room_arguments(parser: argparse.ArgumentParser) -> None:
    """--seed and --duration of the drawn rooms (eval rooms, eval voices)."""
    parser.add_argument("--seed", nargs="+", type=count(0), default=[0], metavar="N",
                        help="seeds of the rooms; counts are summed over them (default: 0)")
    parser.add_argument("--duration", type=duration(MAX_SIMULATED_S), default=None, metavar="SECONDS",
                        help="seconds of each room (default 30)")


def _needs_the_simulator(command: str, *modules: str) -> None:
    """One line, before any work, when the simulator's extra (``.[sim]``) is not installed."""
    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    if missing:
        raise UserError(f"avhear {command} needs {', '.join(missing)}: pip install -e '.[sim]'")


def _merged(runs: list):  # noqa: ANN202 - ScenarioScore or RoomScore
    """The first run with every other run's figures added (each score type's own ``merge``)."""
    first, *rest = runs
    for other in rest:
        first.merge(other)
    return first


def _progress(message: str) -> None:
    print(f"  {message}", file=sys.stderr, flush=True)


def run_synthetic(args: argparse.Namespace) -> int:
    from app.eval.synthetic import FACE_VARIANTS, SequenceScore, VARIANTS, evaluate_face_guided, evaluate_sequence
    from app.eval.tables import format_face_table, format_tables, synthetic_json

    seeds = args.seed if args.seed is not None else [0, 1, 2]
    if any(s < 0 for s in seeds):
        raise UserError(f"--seed takes non-negative integers, got {seeds}")
    scores: list[SequenceScore] = []
    start = time.perf_counter()
    if not args.json:
        print(f"Running {len(args.sequence)} sequence type(s) x {len(seeds)} seed(s) x {len(args.variant)} "
              "variant(s) (136 intervals of 0.4 s each)...", file=sys.stderr, flush=True)
    for name in args.sequence:
        for variant in args.variant:
            scores.append(evaluate_sequence(name, seeds, VARIANTS[variant](), variant=variant,
                                            progress=None if args.json else _progress))
    face: list[SequenceScore] = []
    if args.face_guided:
        for name in args.sequence:
            for variant, params in FACE_VARIANTS.items():
                face.append(evaluate_face_guided(name, seeds, params(), variant=variant))
    if args.json:
        out = synthetic_json(scores, seeds)
        out["face_guided"] = [s.as_dict() for s in face]
        print(json.dumps(out, indent=2))
    else:
        print(format_tables(scores, seeds))
        if face:
            print()
            print(format_face_table(face, seeds))
        print(f"\n({time.perf_counter() - start:.1f} s)")
    return 0


START_YAW_ERROR_DEG = 10.0  # an array's self-calibration starts this far turned from where the room has it


def _gap_us(line: dict, mics: MicPair) -> float:
    """The largest difference, microseconds, between a line (``c1``, ``c0_s``: the self-calibrated one, or the
    speech's own) and the mapping of ``mics`` over the cameras' view (faces within 30 degrees of straight ahead: raw
    ITDs up to half the pair's maximum)."""
    x = np.linspace(-0.5, 0.5, 21) * mics.max_itd_s
    return float(np.max(np.abs(line["c1"] * x + line["c0_s"] - (mics.c1 * x + mics.c0))) * 1e6)


def run_scenarios(args: argparse.Namespace) -> int:
    from app.eval.scenarios import CalibrationFit, PAPER_SCENARIOS, evaluate_scenario
    from app.eval.scoring import ITD_TOLERANCE_S, ScenarioScore
    from app.eval.tables import format_scenario_table, scenario_targets, signed_us

    if any(s < 0 for s in args.seed):
        raise UserError(f"--seed takes non-negative integers, got {args.seed}")
    if args.duration is not None and not (2.0 <= args.duration <= 3600.0):
        raise UserError(f"--duration must be between 2 and 3600 seconds, got {args.duration}")
    config = pipeline_config(args)
    if args.motion_variant != "avhear":
        if not args.motion:
            raise UserError("--motion-variant chooses between versions of Algorithm 1: add --motion")
        config = replace(config, motion_variant=args.motion_variant)
    if args.timeline is not None:
        output_dir(args.timeline, "--timeline")
    start = time.perf_counter()
    calibration: CalibrationFit | None = None
    one_pair = MicArray.preset(args.mics).n_pairs == 1
    start_yaw = args.array_turned
    if start_yaw is None:
        start_yaw = START_YAW_ERROR_DEG if config.self_calibrate and not one_pair else 0.0
    elif one_pair:
        raise UserError(f"--array-turned turns an array of several pairs; --mics {args.mics} has one pair")
    elif not -45.0 <= start_yaw <= 45.0:
        raise UserError(f"--array-turned must be within -45..45 degrees, got {start_yaw:g}")
    if args.calibrate and not one_pair:
        _progress(f"--mics {args.mics}: no audio-visual calibration (it fits one pair; the simulated microphones are "
                  "exact)")
    if args.calibrate and one_pair:
        calibration = _calibrate(args, config)
    start_mics = calibration.mics if calibration else None
    if config.self_calibrate and calibration is not None:
        # the self-calibration's start: 20 % off in c1 and 30 us off in c0 from the loudspeaker's fit
        start_mics = calibration.mics.with_correction(1.2 * calibration.mics.c1, calibration.mics.c0 + 30e-6)
        _progress(f"self-calibration from c1 = {start_mics.c1:.4f}, c0 = {signed_us(start_mics.c0 * 1e6)} us")
    if start_yaw:
        _progress(f"the array turned {start_yaw:g} degrees about the vertical from where the room has it"
                  + (" (the self-calibration's start)" if config.self_calibrate else ""))
    scores: list[ScenarioScore] = []
    for name in args.scenario:
        runs: list[ScenarioScore] = []
        for seed in args.seed:
            _progress(f"{name} seed {seed}: simulating and running the {config.inference}-guided pipeline ...")
            t0 = time.perf_counter()
            score = evaluate_scenario(name, seed, duration_s=args.duration, config=config, mics=start_mics,
                                      mic_array=args.mics, bodies=wants_bodies(args), camera=args.camera,
                                      lips=wants_lips(args), array_yaw_deg=start_yaw)
            u = score.utterances  # the table's first unit
            _progress(f"{name} seed {seed}: per spoken number TP {u.tp}, FN {u.fn}, FP {u.fp} "
                      f"({time.perf_counter() - t0:.0f} s)")
            for state in score.self_calibration:
                line = state.get("speech_line")
                if calibration is not None:
                    state["gap_to_loudspeaker_us"] = _gap_us(state, calibration.mics)
                    if line is not None:  # the truth of speech: how far it lies from the loudspeaker, and we from it
                        state["speech_line_gap_to_loudspeaker_us"] = _gap_us(line, calibration.mics)
                        state["gap_to_speech_line_us"] = _gap_us(
                            state, calibration.mics.with_correction(line["c1"], line["c0_s"]))
                _progress(f"{name} seed {seed}: self-calibrated c1 = {state['c1']:.4f}, c0 = "
                          f"{signed_us(state['c0_s'] * 1e6)} us ({state['inliers']} of {state['observations']} "
                          "one-source time frames)" + (f", {state['gap_to_loudspeaker_us']:.1f} us from the "
                                                      "loudspeaker's fit" if calibration is not None else "")
                          + (f" and {state['gap_to_speech_line_us']:.1f} us from the speech's own line (itself "
                             f"{state['speech_line_gap_to_loudspeaker_us']:.1f} us from the loudspeaker's)"
                             if "gap_to_speech_line_us" in state else "")
                          + (f"; the array's turn learned within {abs(state['array_yaw_error_deg']):.1f} degrees"
                             if state.get("array_yaw_error_deg") is not None else ""))
            if args.timeline is not None and score.timeline is not None:
                from app.eval.figure import save_timeline

                path = args.timeline / f"{name}_seed{seed}.png"
                save_timeline(score.timeline, path, f"{name} seed {seed}, {config.inference}-guided, per spoken "
                              f"number: TP {u.tp}, FN {u.fn}, FP {u.fp}")
                _progress(f"{name} seed {seed}: timeline saved to {path}")
            runs.append(score)
        scores.append(_merged(runs))
    if args.json:
        from app.hearing import detector_name

        out = {
            "protocol": {"interval_s": INTERVAL_S, "itd_tolerance_us": ITD_TOLERANCE_S * 1e6,
                         "count": "one number spoken by a visible person (targets); also one visible person during "
                                  "one interval", "tau_loc_m": 0.35},
            "inference": config.inference,
            **({"motion_variant": config.motion_variant} if config.inference == "motion" else {}),
            "itd_method": config.itd_method,
            "face_detector": None if config.inference == "motion" else detector_name(config),
            "tflite_runtime": config.tflite_runtime,
            "seeds": list(args.seed),
            "calibration": calibration.as_dict() if calibration else None,
            "results": [s.as_dict() for s in scores],
            "targets": scenario_targets(scores),
            "paper": {s.scenario: PAPER_SCENARIOS.get(s.scenario) for s in scores},
        }
        print(json.dumps(out, indent=2))
    else:
        print(format_scenario_table(scores, config, calibration))
        print(f"\n({time.perf_counter() - start:.1f} s)")
    return 0



def run_rooms(args: argparse.Namespace) -> int:
    from app.eval.rooms import DEFAULT_METHODS, RoomScore, evaluate_room
    from app.eval.tables import format_room_table, signed_us

    if args.motion:
        raise UserError("avhear eval rooms scores face-guided hearing; leave out --motion")
    _needs_the_simulator("eval rooms", "pyroomacoustics")
    if args.duration is not None and not (5.0 <= args.duration <= 3600.0):
        raise UserError(f"--duration must be between 5 and 3600 seconds, got {args.duration}")
    config = pipeline_config(args)
    start = time.perf_counter()
    if args.calibrate and MicArray.preset(args.mics).n_pairs != 1:
        raise UserError(f"--calibrate fits one microphone pair; --mics {args.mics} has several (leave out "
                        "--calibrate: the simulated arrays are exact)")
    calibration = _calibrate(args, config) if args.calibrate else None
    scores: list[RoomScore] = []
    for method in args.method or DEFAULT_METHODS:
        runs: list[RoomScore] = []
        for seed in args.seed:
            _progress(f"room {seed}, {method}: simulating and running the pipeline ...")
            t0 = time.perf_counter()
            score = evaluate_room(seed, method=method, config=config, mic_array=args.mics, lips=wants_lips(args),
                                  camera=args.camera, duration_s=args.duration,
                                  image_scale=0.5 if args.far_faces else 1.0,
                                  mics=calibration.mics if calibration else None)
            c = score.counts
            _progress(f"room {seed}, {method}: {score.rooms[0]['people']} people, precision {c.precision:.3f} "
                      f"(forgiven {c.precision_forgiven:.3f}), recall {c.recall:.3f} (forgiven "
                      f"{c.recall_forgiven:.3f}), {c.false_stretches} false stretches over {c.utterances} "
                      f"utterances ({time.perf_counter() - t0:.0f} s)")
            runs.append(score)
        scores.append(_merged(runs))
    if args.json:
        print(json.dumps({"protocol": {"unit": "one visible person in one result", "forgive_s": 0.3,
                                       "tau_loc_m": 0.35},
                          "mics": args.mics, "seeds": list(args.seed), "read_lips": config.lips,
                          "mouths_move": wants_lips(args), "far_faces": args.far_faces,
                          "calibration": calibration.as_dict() if calibration else None,
                          "results": [s.as_dict() for s in scores]}, indent=2))
    else:
        print(format_room_table(scores))
        if calibration is not None:
            c = calibration.mics
            print(f"\nHeard with the pair calibrated on the calibration preset (section 5.3): c1 = {c.c1:.4f}, "
                  f"c0 = {signed_us(c.c0 * 1e6)} us.")
        print(f"\n({time.perf_counter() - start:.1f} s)")
    return 0


def _calibrate(args: argparse.Namespace, config: PipelineConfig) -> CalibrationFit:
    """--calibrate of `eval scenarios` and `eval rooms`: the correction c1, c0 fitted on the calibration preset (its
    seed the first of --seed), with its progress lines."""
    from app.eval.scenarios import calibrate_on_preset
    from app.eval.tables import signed_us

    _progress("calibration preset (section 5.3): fitting c1, c0 ...")
    calibration = calibrate_on_preset(seed=args.seed[0], config=config, camera=args.camera, mic_array=args.mics)
    c = calibration.as_dict()
    _progress(f"c1 = {c['c1']:.4f}, c0 = {signed_us(c['c0_us'])} us, median |residual| "
              f"{c['median_abs_residual_before_us']:.1f} -> {c['median_abs_residual_after_us']:.1f} us")
    return calibration


def run_words(args: argparse.Namespace) -> int:
    from app.eval.tables import format_words_table
    from app.eval.words import evaluate_words

    _needs_the_simulator("eval words", "pyroomacoustics", "meeteval", "pocketsphinx")
    if args.duration is not None and not (5.0 <= args.duration <= 3600.0):
        raise UserError(f"--duration must be between 5 and 3600 seconds, got {args.duration}")
    runs = [(s, args.seed) for s in (args.scenario or ([] if args.rooms else ["S1", "S2", "S3", "S4", "S5"]))]
    runs += [("room", seed) for seed in args.rooms or ()]
    start = time.perf_counter()
    rows = [evaluate_words(name, seed=seed, mics=args.mics or "pair", duration_s=args.duration, progress=_progress)
            for name, seed in runs]
    if args.json:
        print(json.dumps({"rows": [r.as_dict() for r in rows]}, indent=2))
    else:
        print(format_words_table(rows))
        print(f"\n({time.perf_counter() - start:.1f} s)")
    return 0


def run_voices(args: argparse.Namespace) -> int:
    from app.eval.tables import format_voice_table
    from app.eval.voices import evaluate_voices, summarise

    _needs_the_simulator("eval voices", "pyroomacoustics", "fast_bss_eval", "pystoi")
    if args.duration is not None and not (5.0 <= args.duration <= 3600.0):
        raise UserError(f"--duration must be between 5 and 3600 seconds, got {args.duration}")
    start = time.perf_counter()
    rows = []
    for scenario in args.scenario or [None]:
        for seed in args.seed:
            name = f"room {seed}" if scenario is None else f"{scenario} seed {seed}"
            _progress(f"{name}: rendering with each talker's own signals, then every person's voice ...")
            found = evaluate_voices(seed, mic_array=args.mics, duration_s=args.duration, scenario=scenario)
            _progress(f"{name}: {len({r.person for r in found})} people, {len(found)} rows")
            rows += found
    if args.json:
        print(json.dumps({"mics": args.mics, "seeds": list(args.seed), "scenarios": args.scenario,
                          "reference": "dry speech, direct path", "summary": summarise(rows),
                          "rows": [r.as_dict() for r in rows]}, indent=2))
    else:
        print(format_voice_table(args.mics, list(args.seed), summarise(rows), args.scenario))
        print(f"\n({time.perf_counter() - start:.1f} s)")
    return 0
