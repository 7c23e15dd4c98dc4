"""`avhear transcribe`: who said what in a recording, as a WebVTT transcript."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from app.commands.paths import output_file
from app.errors import UserError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("transcribe", help="who said what in a recording: a WebVTT transcript, a cue per utterance "
                                          "with its speaker",
                       description="Replays RECORDING (a folder of avhear record or simulate) as fast as possible "
                       "through the pipeline with each person's voice and their words (pocketsphinx, US English), "
                       "and writes a WebVTT file: one cue per utterance, '<v person N>' its speaker, its times from "
                       "the recording's start.")
    p.add_argument("recording", help="the recording folder (or sim:S1..S6 for a simulated room)")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="FILE.vtt", help="the WebVTT file to write")
    p.add_argument("--words", type=Path, default=None, metavar="FILE",
                   help="recognise only the words of FILE (whitespace or commas between them); default the general "
                        "language model")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS",
                   help="a simulated room's length (sim:...; a recording is transcribed whole)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from app.pipeline import Pipeline, PipelineConfig
    from app.sinks.webvtt import write_vtt
    from app.sources.open import open_source
    from app.speech.open import open_transcriber

    spec = args.recording if args.recording.startswith("sim:") else f"replay:{args.recording}"
    if not spec.startswith("sim:") and not Path(args.recording).is_dir():
        raise UserError(f"{args.recording} is not a recording folder: give one that avhear record or avhear "
                        "simulate wrote (or sim:S1..S6)")
    if args.output.suffix.lower() != ".vtt":
        raise UserError(f"-o {args.output}: a WebVTT file ends in .vtt")
    output_file(args.output, "-o")
    transcriber = open_transcriber(args.words)
    finals: list = []
    try:
        with open_source(spec, realtime=False, duration_s=args.duration) as source:
            def on_result(result: object) -> None:
                transcriber.result(result.stamp_s,  # type: ignore[attr-defined]
                                   [(p.id, p.speaking) for p in result.people])  # type: ignore[attr-defined]
                finals.extend(w for w in transcriber.events() if w.final and w.text)

            pipeline = Pipeline(source, PipelineConfig(voices=True), on_result, on_voice=transcriber.voice)
            print(f"avhear: transcribing {spec} ...", file=sys.stderr, flush=True)
            started = time.perf_counter()
            stats = pipeline.run()
            origin = float(getattr(getattr(source, "stream", None), "start_s", 0.0) or 0.0)  # the first stamp
    finally:
        finals.extend(w for w in transcriber.close() if w.final and w.text)
    write_vtt(args.output, finals, origin)
    speakers = sorted({w.person_id for w in finals})
    print(f"avhear: {len(finals)} utterances of {len(speakers)} people in {args.output} ({stats.results} results "
          f"in {time.perf_counter() - started:.1f} s)")
    return 130 if stats.interrupted else 0
