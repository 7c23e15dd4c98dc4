"""Speaking states scored per result and person: what a robot acts on, many times a second.

The paper's unit is the spoken number (:class:`app.eval.scenarios.UtteranceCounts`); a robot that turns its head or
passes audio to a recogniser acts on each result. Here one count is one *visible person in one result*: the truth is
whether that person speaks at the result's stamp (:meth:`sim.scenario.Scenario.speaking_at`), the judgement whether
avhear called them speaking (a person not found is judged silent).

Plain
    TP, FP, FN, TN of those counts; precision TP / (TP + FP), recall TP / (TP + FN).
Edges forgiven (``forgive_s``, 0.3 s: the team's decision)
    The speaking state lags the speech (the ITD window, the +-0.2 s time frame, the vote): a call within
    ``forgive_s`` of the person's own speech is no false alarm, and a silence within ``forgive_s`` of either edge of
    it is no miss. Precision (forgiven) is the share of speaking calls that lie within the person's speech
    +- ``forgive_s``; recall (forgiven) the share of the results at least ``forgive_s`` inside the person's speech
    that are called speaking (inside an utterance shorter than 4 ``forgive_s``, a spoken digit, its middle half).
False stretches
    A run of consecutive results calling a found person speaking that lies wholly outside that person's speech
    +- ``forgive_s`` (each result standing for +- ``half_span_s``); reported per utterance of visible people.
Utterances heard
    An utterance of a visible person is heard when they are called speaking in at least half of the results during
    it (as the per-number count).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["FORGIVE_S", "ResultCounts", "result_counts"]

FORGIVE_S = 0.3


def _clean(x: float) -> float | None:
    return None if not math.isfinite(x) else round(float(x), 4)


@dataclass
class ResultCounts:
    """Counts per result x visible person (see the module docstring); they add up over runs."""

    tp: int = 0
    fp: int = 0
    fn: int = 0
    tn: int = 0
    calls: int = 0  # results x persons called speaking
    calls_near_speech: int = 0  # of them, within forgive_s of the person's own speech
    inner: int = 0  # results x persons at least forgive_s inside the person's speech
    inner_called: int = 0  # of them, called speaking
    utterances: int = 0
    heard: int = 0
    false_stretches: int = 0

    def add(self, other: ResultCounts) -> None:
        for name in self.__dataclass_fields__:
            setattr(self, name, getattr(self, name) + getattr(other, name))

    @property
    def precision(self) -> float:
        return self.tp / (self.tp + self.fp) if self.tp + self.fp else math.nan

    @property
    def recall(self) -> float:
        return self.tp / (self.tp + self.fn) if self.tp + self.fn else math.nan

    @property
    def precision_forgiven(self) -> float:
        return self.calls_near_speech / self.calls if self.calls else math.nan

    @property
    def recall_forgiven(self) -> float:
        return self.inner_called / self.inner if self.inner else math.nan

    @property
    def heard_share(self) -> float:
        return self.heard / self.utterances if self.utterances else math.nan

    @property
    def false_stretches_per_utterance(self) -> float:
        return self.false_stretches / self.utterances if self.utterances else math.nan

    def as_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {name: getattr(self, name) for name in self.__dataclass_fields__}
        d.update(precision=_clean(self.precision), recall=_clean(self.recall),
                 precision_forgiven=_clean(self.precision_forgiven), recall_forgiven=_clean(self.recall_forgiven),
                 heard_share=_clean(self.heard_share),
                 false_stretches_per_utterance=_clean(self.false_stretches_per_utterance))
        return d


def _within(t: np.ndarray, spans: Sequence[tuple[float, float]], before: float, after: float) -> np.ndarray:
    """(T,) bool: ``t`` inside some span widened by ``before`` at its start and ``after`` at its end (negative
    values narrow it)."""
    out = np.zeros(t.shape, dtype=bool)
    for s, e in spans:
        out |= (t >= s - before) & (t < e + after)
    return out


def result_counts(stamps_s: np.ndarray, states: np.ndarray, visible: np.ndarray,
                  speech: Sequence[Sequence[tuple[float, float]]], *, half_span_s: float,
                  forgive_s: float = FORGIVE_S) -> ResultCounts:
    """Score one run. stamps_s : (R,) result stamps, seconds; states : (R, N) per result and person, -1 not found,
    0 judged silent, 1 judged speaking; visible : (R, N) the truth's visibility at each stamp; speech : per person,
    their utterances as (start, end) seconds; half_span_s : the time one result stands for (half a frame)."""
    stamps = np.asarray(stamps_s, dtype=np.float64).reshape(-1)
    order = np.argsort(stamps, kind="stable")
    stamps = stamps[order]
    states = np.asarray(states).reshape(stamps.size, -1)[order]
    visible = np.asarray(visible, dtype=bool).reshape(stamps.size, -1)[order]
    c = ResultCounts()
    for i, spans in enumerate(speech):
        vis = visible[:, i]
        called = states[:, i] == 1
        truth = _within(stamps, spans, 0.0, 0.0)
        near = _within(stamps, spans, forgive_s, forgive_s)
        inner = np.zeros(stamps.shape, dtype=bool)
        for s, e in spans:  # a short utterance keeps its middle half
            cut = min(forgive_s, 0.25 * (e - s))
            inner |= (stamps >= s + cut) & (stamps < e - cut)
        c.tp += int(np.sum(vis & called & truth))
        c.fp += int(np.sum(vis & called & ~truth))
        c.fn += int(np.sum(vis & ~called & truth))
        c.tn += int(np.sum(vis & ~called & ~truth))
        c.calls += int(np.sum(vis & called))
        c.calls_near_speech += int(np.sum(vis & called & near))
        c.inner += int(np.sum(vis & inner))
        c.inner_called += int(np.sum(vis & inner & called))
        for s, e in spans:
            during = (stamps + half_span_s > s) & (stamps - half_span_s < e)
            if not (during & vis).any() or vis[during].mean() < 0.5:
                continue  # an utterance of a person out of view is nobody's to hear
            c.utterances += 1
            st = states[during & vis, i]
            c.heard += int(np.sum(st == 1) >= st.size / 2)
        c.false_stretches += _stretches_outside(stamps, states[:, i], spans, half_span_s, forgive_s)
    return c


def _stretches_outside(stamps: np.ndarray, states: np.ndarray, spans: Sequence[tuple[float, float]],
                       half_span_s: float, forgive_s: float) -> int:
    """Runs of consecutive found results called speaking (a result not found ends no run) that lie wholly outside
    every span +- ``forgive_s``."""
    n, run = 0, []
    for j in list(np.flatnonzero(states >= 0)) + [-1]:  # -1 closes the last run
        if j >= 0 and states[j] == 1:
            run.append(j)
            continue
        if run:
            a, b = stamps[run[0]] - half_span_s, stamps[run[-1]] + half_span_s
            n += not any(s - forgive_s < b and e + forgive_s > a for s, e in spans)
            run = []
    return n
