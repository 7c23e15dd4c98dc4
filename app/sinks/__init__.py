"""The sinks: everything that takes a :class:`app.result.Result` as it is. The results file
(:mod:`app.sinks.results_file`), the bus (:mod:`app.sinks.bus`), the Rerun console (:mod:`app.console`); :class:`Sinks`
hands each result to the ones a run asked for."""
from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from app.console import Console
    from app.console.viewer import ViewerSession
    from app.pipeline import Pipeline
    from app.result import Result
    from app.sinks.bus import ResultPublisher
    from app.sinks.results_file import ResultsWriter

__all__ = ["Sinks"]


class Sinks:
    """Hands every result, as it is, to the sinks the user asked for: the results file, the bus, the console."""

    def __init__(self, session: ViewerSession, console: Console | None, results: ResultsWriter | None,
                 publisher: ResultPublisher | None) -> None:
        self.session, self.console, self.results, self.publisher = session, console, results, publisher
        self.pipeline: Pipeline | None = None

    def __call__(self, result: Result) -> None:
        if self.results is not None:
            self.results.write(result)
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
        if self.session.part_due():
            self.session.next_part()
            self.console.new_part()
        from app.console import ConsoleFrame  # the console's module loads Rerun: only a run with a console needs it

        self.console.log(ConsoleFrame.from_result(result, diagnostics))
