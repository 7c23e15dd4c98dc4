"""The sinks: everything that takes a :class:`app.result.Result` as it is. The results file
(:mod:`app.sinks.results_file`), the bus (:mod:`app.sinks.bus`), the Rerun console (:mod:`app.console`); and the
people's voices (:class:`avcore.separation.VoiceChunk`): a WAV a person (:mod:`app.sinks.voices_dir`) and the bus.
:class:`Sinks` hands each to the ones a run asked for."""
from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from app.console.process import ConsoleProcess
    from app.pipeline import Pipeline
    from app.result import Result
    from app.sinks.bus import ResultPublisher
    from app.sinks.results_file import ResultsWriter
    from app.sinks.voices_dir import VoicesWriter
    from app.speech.transcriber import Transcriber
    from avcore.separation import VoiceChunk

__all__ = ["Sinks"]


class Sinks:
    """Hands every result, as it is, to the sinks the user asked for: the results file, the bus, the console."""

    def __init__(self, console: ConsoleProcess | None, results: ResultsWriter | None,
                 publisher: ResultPublisher | None, voices: VoicesWriter | None = None,
                 transcriber: Transcriber | None = None) -> None:
        self.console, self.results, self.publisher = console, results, publisher
        self.voices, self.transcriber = voices, transcriber
        self.utterances: list = []  # every final Words of the run (the WebVTT of avhear transcribe)
        self._held: tuple | None = None  # with words: the last result and its utterances, not yet written
        self.pipeline: Pipeline | None = None

    def voice(self, chunk: VoiceChunk) -> None:
        """One chunk of a person's voice (the pipeline's voices thread) to the WAV files and the bus."""
        if self.voices is not None:
            self.voices.write(chunk)
        if self.publisher is not None:
            self.publisher.publish_voice(chunk)
        if self.transcriber is not None:
            self.transcriber.voice(chunk)

    def _words(self, result: Result) -> list:
        """The words that came since the last result (partial and final), to the bus and the console."""
        if self.transcriber is None:
            return []
        self.transcriber.result(result.stamp_s, [(p.id, p.speaking) for p in result.people])
        return self.take_words(result.stamp_s, self.transcriber.events())

    def take_words(self, stamp_s: float, words: list) -> list:
        """Hand ``words`` to the bus and the console, keep the final ones; the final ones' records."""
        if self.publisher is not None:
            for w in words:
                self.publisher.publish_words(stamp_s, w)
        if self.console is not None and words:
            self.console.log_words(words)
        final = [w for w in words if w.final]
        self.utterances += final
        return [w.as_dict() for w in final]

    def finish(self) -> None:
        """The run is over: the words still coming (every open utterance ends), and the last result's line."""
        if self.transcriber is None:
            return
        stamp = self._held[0].stamp_s if self._held is not None else 0.0
        late = self.take_words(stamp, self.transcriber.close())
        if self._held is not None and self.results is not None:
            self.results.write(self._held[0], self._held[1] + late)
        self._held = None

    def __call__(self, result: Result) -> None:
        utterances = self._words(result)
        if self.results is not None:
            if self.transcriber is None:
                self.results.write(result, utterances)
            else:  # one line held back, so that the last one takes the words that end with the run
                if self._held is not None:
                    self.results.write(*self._held)
                self._held = (result, utterances)
        if self.publisher is not None:
            self.publisher.publish(result)
        if self.console is None:
            return
        assert self.pipeline is not None
        diagnostics = {f"queue_depth/{name}": float(n) for name, n in self.pipeline.queue_depths().items()}
        if result.latency_s == result.latency_s:
            diagnostics["latency_ms/fusion"] = result.latency_s * 1e3
        for p, pair in enumerate(self.pipeline.self_calibration_state() or []):  # --self-calibrate: where it stands
            diagnostics[f"self_calibration/pair{p}/c1"] = pair["c1"]
            diagnostics[f"self_calibration/pair{p}/c0_us"] = pair["c0_s"] * 1e6
            diagnostics[f"self_calibration/pair{p}/inliers"] = float(pair["inliers"])
            if p == 0 and pair.get("array_yaw_deg") is not None:  # several pairs: the array's turn, once
                diagnostics["self_calibration/array_yaw_deg"] = pair["array_yaw_deg"]
        from app.console import ConsoleFrame  # the console's module loads Rerun: only a run with a console needs it

        self.console.log(ConsoleFrame.from_result(result, diagnostics))
