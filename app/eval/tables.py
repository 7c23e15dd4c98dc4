"""The tables of `avhear eval`: the paper's figures beside avhear's, as text and as JSON."""
from __future__ import annotations

import math

from app.pipeline import PipelineConfig
from app.eval.scenarios import PAPER_PERCENT, PAPER_SCENARIOS, CalibrationFit
from app.eval.scoring import INTERVAL_S, ITD_TOLERANCE_S, TIMING_REFERENCE_S, ScenarioScore
from app.eval.rooms import RoomScore
from app.eval.synthetic import PAPER_AUDIO, PAPER_VISUAL, SequenceScore

__all__ = ["format_face_table", "format_room_table", "format_scenario_table", "format_tables", "scenario_targets", "signed_us",
           "synthetic_json"]

VARIANT_LABELS = {"paper": "paper's method", "avhear": "avhear"}


def synthetic_json(scores: list[SequenceScore], seeds: list[int]) -> dict[str, object]:
    sequences = list(dict.fromkeys(s.sequence for s in scores))  # in the order run, so that the output is stable
    return {
        "seeds": seeds,
        "results": [s.as_dict() for s in scores],
        "paper": {"visual": {k: PAPER_VISUAL[k] for k in sequences}, "audio": {k: PAPER_AUDIO[k] for k in sequences}},
    }


def signed_us(x_us: float) -> str:
    """``x_us`` with its sign and one decimal; a value that rounds to zero prints as +0.0, never -0.0."""
    return f"{round(x_us, 1) + 0.0:+.1f}"


def _pct(count: float, total: float) -> str:
    return f"({100.0 * count / total:4.1f}%)" if total else "(  - )"


def format_tables(scores: list[SequenceScore], seeds: list[int]) -> str:
    """Tables 1 and 2 of section 7.1; our counts are per sequence (averaged over the seeds)."""
    n = len(seeds)
    lines = [
        (f"Table 1 - visual evaluation (section 7.1). Counts per 136-interval sequence, averaged over seeds "
         f"{', '.join(map(str, seeds))}; TP % = TP / (TP + FN)."),
        f"{'Seq.':8s} {'method':22s} {'FP':>7s} {'FN':>16s} {'TP':>16s} {'ALE [m]':>8s}",
    ]
    for name in dict.fromkeys(s.sequence for s in scores):
        p = PAPER_VISUAL[name]
        lines.append(f"{name:8s} {'paper (published)':22s} {p['fp']:7.0f} {p['fn']:6.0f} "
                     f"{_pct(p['fn'], p['fn'] + p['tp']):>9s} {p['tp']:6.0f} {_pct(p['tp'], p['fn'] + p['tp']):>9s} "
                     f"{p['ale_m']:8.2f}")
        for s in scores:
            if s.sequence != name:
                continue
            t = s.totals
            lines.append(f"{'':8s} {VARIANT_LABELS.get(s.variant, s.variant):22s} {t.fp / n:7.1f} {t.fn / n:6.1f} "
                         f"{_pct(t.fn, t.n_truth):>9s} {t.tp / n:6.1f} {_pct(t.tp, t.n_truth):>9s} {t.ale_m:8.3f}")
    lines += [
        "",
        "Table 2 - auditory state (section 7.1), over the true-positive clusters. TP % = TP / (TP + FN).",
        f"{'Seq.':8s} {'method':22s} {'FP':>7s} {'FN':>16s} {'TP':>16s}",
    ]
    for name in dict.fromkeys(s.sequence for s in scores):
        p = PAPER_AUDIO[name]
        lines.append(f"{name:8s} {'paper (published)':22s} {p['fp']:7.0f} {p['fn']:6.0f} "
                     f"{_pct(p['fn'], p['fn'] + p['tp']):>9s} {p['tp']:6.0f} {_pct(p['tp'], p['fn'] + p['tp']):>9s}")
        for s in scores:
            if s.sequence != name:
                continue
            lines.append(_audio_row("", VARIANT_LABELS.get(s.variant, s.variant), s, n))
    return "\n".join(lines)


def _audio_row(first: str, label: str, score: SequenceScore, n: int) -> str:
    """One row of speaking-state counts per sequence (FP, FN with %, TP with %)."""
    t = score.totals
    speak = t.audio_tp + t.audio_fn
    return (f"{first:8s} {label:22s} {t.audio_fp / n:7.1f} {t.audio_fn / n:6.1f} {_pct(t.audio_fn, speak):>9s} "
            f"{t.audio_tp / n:6.1f} {_pct(t.audio_tp, speak):>9s}")


def format_face_table(scores: list[SequenceScore], seeds: list[int]) -> str:
    """Table 3 (avhear's): Algorithm 2's speaking states with the faces given, per variant."""
    n = len(seeds)
    lines = [
        "Table 3 - Face-Guided Robot Hearing (Algorithm 2), faces = visible people + 1 cm noise; speaking states.",
        "paper = means free, tau_A = K/(N+2); anchored = means kept at the faces; avhear = anchored + outlier-aware.",
        f"{'Seq.':8s} {'variant':22s} {'FP':>7s} {'FN':>16s} {'TP':>16s}",
    ]
    for name in dict.fromkeys(s.sequence for s in scores):
        for s in scores:
            if s.sequence != name:
                continue
            lines.append(_audio_row(name if s is scores[0] or s.variant == "paper" else "", s.variant, s, n))
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------------------------
# avhear eval scenarios (section 7.3)


def _fp_share(fp: float, speaking: float) -> float:
    """FP per speaking count, FP / (TP + FN): comparable between the paper's counts and ours, whose units differ."""
    return fp / speaking if speaking else math.nan


def _rounded(x: float) -> float | None:
    return None if math.isnan(x) else round(x, 4)


def _target_row(tp: int, fn: int, fp: int, scenario: str) -> dict[str, object]:
    """The targets of one scenario; one the paper has not (S6) has no FP target (null)."""
    p = PAPER_SCENARIOS.get(scenario)
    ours = _fp_share(fp, tp + fn)
    paper = _fp_share(p["fp"], p["tp"] + p["fn"]) if p else math.nan
    return {
        "tp_rate": _rounded(tp / (tp + fn)) if tp + fn else None,
        "tp_at_least_95": bool(tp + fn and tp / (tp + fn) >= 0.95),
        "fp_per_speaking_count": _rounded(ours),
        "paper_fp_per_speaking_count": _rounded(paper),
        "fp_at_most_half_paper": bool(not math.isnan(ours) and ours <= paper / 2) if p else None,
    }


def scenario_targets(scores: list[ScenarioScore]) -> dict[str, object]:
    """The scenarios' accuracy targets: TP >= 95 % and FP at most half the paper's (per speaking count) on every
    scenario, per interval and per spoken number; in S4 the unseen talker turns silent visible people into speakers no more often
    than S2's silent people are turned (per interval)."""
    out: dict[str, object] = {
        "per_interval": {s.scenario: _target_row(s.counts.tp, s.counts.fn, s.counts.fp, s.scenario) for s in scores},
        "per_spoken_number": {s.scenario: _target_row(s.utterances.tp, s.utterances.fn, s.utterances.fp, s.scenario)
                              for s in scores},
    }
    by = {s.scenario: s for s in scores}
    if "S4" in by and "S2" in by:
        s4, s2 = by["S4"].counts.unseen_fp_rate, by["S2"].counts.fp_rate
        out["s4_unseen_fp_rate"] = _rounded(s4)
        out["s2_fp_rate"] = _rounded(s2)
        out["s4_not_worse_than_s2"] = bool(not math.isnan(s4) and not math.isnan(s2) and s4 <= s2)
    return out


def _paper_row(name: str) -> str:
    if name not in PAPER_SCENARIOS:
        return f"{name:6s} {'paper: not in it':24s}"
    p = PAPER_SCENARIOS[name]
    fn_pct, tp_pct = PAPER_PERCENT[name]
    return (f"{name:6s} {'paper (NAO, published)':24s} {p['fp']:5d} {p['fn']:4d} {f'({fn_pct:4.1f}%)':>8s} "
            f"{p['tp']:5d} {f'({tp_pct:4.1f}%)':>8s}  {p['fp'] / (p['tp'] + p['fn']):6.3f}")


_HEAD = f"{'Scen.':6s} {'method':24s} {'FP':>5s} {'FN':>13s} {'TP':>14s}  {'FP/spk':>6s}"


def _count_row(label: str, fp: int, fn: int, tp: int) -> str:
    n = tp + fn
    return (f"{'':6s} {label:24s} {fp:5d} {fn:4d} {_pct(fn, n):>8s} {tp:5d} {_pct(tp, n):>8s}  "
            f"{_fp_share(fp, n):6.3f}")


def _header_lines(n_seeds: int, config: PipelineConfig, calibration: CalibrationFit | None) -> list[str]:
    correction = (f"fitted on the calibration preset, c1 = {calibration.mics.c1:.4f}, "
                  f"c0 = {signed_us(calibration.mics.c0 * 1e6)} us" if calibration else "none (c1 = 1, c0 = 0)")
    return [
        (f"Speaking states per scenario (section 7.3), summed over {n_seeds} seed(s); TP % = TP / (TP + FN); "
         "FP/spk = FP / (TP + FN)."),
        "The paper's counts come from hand-annotated recordings on NAO (its caption: 'the total number of counts').",
        f"ITD: {config.itd_method}; AV correction: {correction}.",
    ]


def _data_lines(scores: list[ScenarioScore]) -> list[str]:
    """What the simulated room ran on: photographed faces (../shared/data) or drawn ones, real speech or synthetic."""
    kinds = sorted({(s.faces, s.speech) for s in scores if s.faces or s.speech})
    if not kinds:
        return []
    return ["Data: " + "; ".join(f"{faces or '?'} faces, {speech or '?'} speech" for faces, speech in kinds) +
            " (photographed faces need ../shared/data beside the clone; the speech avhear ships)."]


def _per_number_lines(scores: list[ScenarioScore], label: str) -> list[str]:
    lines = [
        ("Per spoken number (the paper's unit, its people counting to 16): TP = a number judged spoken by its "
         "visible speaker, FN = not; FP = a stretch judged speaking that overlaps none of the person's numbers."),
        f"{_HEAD}  {'FN face missed':>14s} {'FN overlap':>10s}",
    ]
    for s in scores:
        u = s.utterances
        lines += [_paper_row(s.scenario),
                  f"{_count_row(label, u.fp, u.fn, u.tp)}  {u.fn_missed_face:14d} {u.fn_overlap:10d}"]
    return lines


def _per_interval_lines(scores: list[ScenarioScore], label: str, reference: str) -> list[str]:
    ms = TIMING_REFERENCE_S * 1e3
    lines = [
        (f"Per interval (a stricter view): one count = one visible person during {INTERVAL_S} s (majority of its "
         "frames)."),
        (f"The timing reference row scores the truth itself, each number held {ms:.0f} ms longer at both ends: the "
         "false alarms this view gives for timing alone."),
        ("FP partly spoken: in an interval where the person speaks in fewer than half of the frames (timing); FP "
         "wholly silent: where they say nothing."),
        (f"{_HEAD}  {'FN face missed':>14s} {'FN overlap':>10s}  {'FP partly spoken':>16s}  "
         f"{'FP wholly silent':>16s}  {'silent->spk':>11s}"),
    ]
    for s in scores:
        c = s.counts
        silent = c.fp - c.fp_false_face + c.tn
        r = s.timing_reference
        lines += [_paper_row(s.scenario),
                  (f"{_count_row(label, c.fp, c.fn, c.tp)}  {c.fn_missed_face:14d} {c.fn_overlap:10d}  "
                   f"{c.fp_partly_spoken:16d}  {c.fp_wholly_silent:16d}  "
                   f"{_pct(c.fp - c.fp_false_face, silent):>11s}"),
                  _count_row(reference, r.fp, r.fn, r.tp)]
    return lines


def _front_end_lines(scores: list[ScenarioScore]) -> list[str]:
    lines = [
        ("Front end per scenario, per fused frame: faces = frames with every visible face found; recall = visible "
         f"faces found; ITD = ITDs within {ITD_TOLERANCE_S * 1e6:.0f} us of the talker's true ITD (windows with one "
         "talker); bias = median extracted - true; pull = median pull towards 0 of talkers off to the side "
         "(|ITD| >= 50 us); depth = median relative depth error of the faces 1-3 m away."),
        (f"{'Scen.':6s} {'frames':>7s} {'faces':>7s} {'recall':>7s} {'F3D med [m]':>12s} {'depth':>7s} "
         f"{'ITD windows':>12s} {'ITD +-40us':>10s} {'bias [us]':>10s} {'pull [us]':>10s}"),
    ]
    for s in scores:
        lines.append(f"{s.scenario:6s} {s.n_frames:7d} {_pct1(s.all_found_share):>7s} {_pct1(s.face_recall):>7s} "
                     f"{_num(s.f3d_median_m, '.3f'):>12s} {_pct1(s.depth_error_1_3m):>7s} {len(s.itd_errors_s):12d} "
                     f"{_pct1(s.itd_accuracy):>10s} "
                     f"{_num(s.itd_bias_s * 1e6, '+.1f'):>10s} {_num(s.itd_pull_s * 1e6, '+.1f'):>10s}")
    return lines


def _identity_lines(scores: list[ScenarioScore]) -> list[str]:
    motion = any(s.inference == "motion" for s in scores)
    lines = [("Who is who over time, per result: IDF1 = 2 IDTP / (2 IDTP + IDFP + IDFN) under the best one-to-one map "
              "of true people to avhear's ids; switches = a person matched to another id than before; ALE = mean "
              "distance of the people found to their truth: the faces, or (motion-guided) the paper's, each "
              "person's mean of its own HM3D points" + ("; body = to the centre of the visible moving body "
                                                        "instead." if motion else "."))]
    lines.append(f"{'Scen.':6s} {'IDF1':>7s} {'switches':>9s} {'IDTP':>7s} {'IDFP':>6s} {'IDFN':>6s} {'ALE [m]':>8s}"
                 + (f" {'body [m]':>8s}" if motion else ""))
    for s in scores:
        i = s.identity
        ale = s.people_ale_paper_m if s.inference == "motion" else s.people_ale_m
        body = f" {_num(s.people_ale_m, '.3f'):>8s}" if s.inference == "motion" else f" {'-':>8s}"
        lines.append(f"{s.scenario:6s} {_num(i.idf1, '.3f'):>7s} {i.id_switches:9d} {i.idtp:7d} {i.idfp:6d} "
                     f"{i.idfn:6d} {_num(ale, '.3f'):>8s}" + (body if motion else ""))
    return lines


def _voice_lines(scores: list[ScenarioScore]) -> list[str]:
    """The voices out of view (several pairs), where a run reports them."""
    with_voices = [s for s in scores if s.voices is not None]
    if not with_voices:
        return []
    header = (f"{'Scen.':6s} {'talking':>8s} {'found':>7s} {'share':>7s} {'median err':>11s} {'<=10 deg':>9s} "
              f"{'quiet':>7s} {'false':>6s} {'stretches':>10s} {'per spoken':>11s}")
    lines = ["Voices out of view (several pairs), per result: found = a voice within 15 degrees of the unseen talker's "
             "azimuth; false = a voice while nobody out of view talks (0.4 s either side); stretches = those results "
             "in runs, per spoken number of the people in view.", header]
    for s in with_voices:
        v = s.as_dict()["voices_out_of_view"]  # the JSON's figures, the table's too
        share, median, within, per = (math.nan if v[k] is None else v[k] for k in (
            "found_share", "median_azimuth_error_deg", "within_10deg_share", "false_voice_stretches_per_spoken_number"))
        lines.append(f"{s.scenario:6s} {v['results_unseen_talking']:8d} {v['found_within_15deg']:7d} "
                     f"{_pct1(share):>7s} {_num(median, '.1f'):>11s} {_pct1(within):>9s} "
                     f"{v['results_nobody_unseen_talking']:7d} {v['false_voice_results']:6d} "
                     f"{v['false_voice_stretches']:10d} {_num(per, '.3f'):>11s}")
    return lines


def _lip_lines(scores: list[ScenarioScore]) -> list[str]:
    """The lips' cue alone as a speaking detector, where the run read the lips."""
    with_lips = [s for s in scores if s.lips is not None]
    if not with_lips:
        return []
    lines = ["The lips alone (no sound), per result and found visible face: AUC = chance that a talker's lip activity "
             "is above a non-talker's; moving = activity at or above the veto's threshold; no opinion = mesh found no "
             "face or too few frames.",
             f"{'Scen.':6s} {'faces':>7s} {'no opinion':>11s} {'AUC':>6s} {'talkers moving':>15s} "
             f"{'others moving':>14s}"]
    for s in with_lips:
        v = s.lips.as_dict()
        share, auc, talk, other = (math.nan if v[k] is None else v[k]
                                   for k in ("no_opinion_share", "auc", "talkers_moving", "others_moving"))
        lines.append(f"{s.scenario:6s} {v['face_results']:7d} {_pct1(share):>11s} {_num(auc, '.3f'):>6s} "
                     f"{_pct1(talk):>15s} {_pct1(other):>14s}")
    return lines


def _target_lines(scores: list[ScenarioScore], reference: str) -> list[str]:
    t = scenario_targets(scores)
    lines = [("Targets (beyond the paper's table): TP >= 95 %; FP/spk at most half the paper's; S4's unseen "
              "talker no worse than S2.")]
    held = {("per_interval", s.scenario): f"; {reference}: "
            f"{_rounded(_fp_share(s.timing_reference.fp, s.timing_reference.tp + s.timing_reference.fn))}; "
            f"FP/spk wholly silent: {_rounded(_fp_share(s.counts.fp_wholly_silent, s.counts.tp + s.counts.fn))}"
            for s in scores}
    for view in ("per_spoken_number", "per_interval"):
        rows = t[view]
        assert isinstance(rows, dict)
        for name, r in rows.items():
            tp = r["tp_rate"]
            lines.append(f"  {view.replace('_', ' '):17s} {name}: TP {'-' if tp is None else f'{100 * tp:5.1f} %'} "
                         f"[{'met' if r['tp_at_least_95'] else 'NOT met'}], FP/spk {r['fp_per_speaking_count']} vs "
                         f"paper {r['paper_fp_per_speaking_count']} "
                         f"[{'met' if r['fp_at_most_half_paper'] else 'NOT met'}]" + held.get((view, name), ""))
    if "s4_unseen_fp_rate" in t:
        lines.append(f"  S4: silent visible people judged speaking while the unseen person talks: "
                     f"{t['s4_unseen_fp_rate']} of their intervals, vs S2's silent people: {t['s2_fp_rate']} "
                     f"[{'met' if t['s4_not_worse_than_s2'] else 'NOT met'}]")
    return lines


def format_scenario_table(scores: list[ScenarioScore], config: PipelineConfig,
                          calibration: CalibrationFit | None) -> str:
    """The table of section 7.3 with the paper's rows beside ours (per spoken number, then per 0.4 s interval), the
    per-scenario front-end figures, and the targets."""
    label = ("paper's Alg. 1 (here)" if config.inference == "motion" and config.motion_variant == "paper"
             else f"avhear {config.inference}-guided")
    reference = f"truth held +-{TIMING_REFERENCE_S * 1e3:.0f} ms"
    sections = [_header_lines(len(scores[0].seeds) if scores else 0, config, calibration) + _data_lines(scores),
                _per_number_lines(scores, label), _per_result_lines(scores),
                _per_interval_lines(scores, label, reference),
                _front_end_lines(scores), _identity_lines(scores), _voice_lines(scores), _lip_lines(scores),
                _target_lines(scores, reference)]
    return "\n\n".join("\n".join(section) for section in sections if section)


def _per_result_lines(scores: list[ScenarioScore]) -> list[str]:
    """Per result x visible person (face-guided; :mod:`app.eval.per_result`): what a robot acts on."""
    rows = [s for s in scores if s.per_result.calls or s.per_result.inner]
    if not rows:
        return []
    lines = ["Per result and visible person (edges of each person's speech forgiven by 0.3 s):",
             f"{'':<10}{'precision':>10}{'recall':>8}{'prec. (forg.)':>15}{'rec. (forg.)':>14}{'false str./utt.':>17}"]
    for s in rows:
        c = s.per_result
        lines.append(f"{s.scenario:<10}{_num(c.precision, '.3f'):>10}{_num(c.recall, '.3f'):>8}"
                     f"{_num(c.precision_forgiven, '.3f'):>15}{_num(c.recall_forgiven, '.3f'):>14}"
                     f"{_num(c.false_stretches_per_utterance, '.2f'):>17}")
    return lines


def _pct1(x: float) -> str:
    return "-" if math.isnan(x) else f"{100 * x:.1f}%"


def _num(x: float, fmt: str) -> str:
    return "-" if math.isnan(x) else format(x, fmt)


def format_room_table(scores: list[RoomScore]) -> str:
    """The rooms' table: per method, the speaking states per result x person (plain and with the edges forgiven by
    0.3 s), the utterances heard and the false stretches per utterance; the faces found and their error."""
    if not scores:
        return "(no rooms run)"
    first = scores[0]
    lines = [f"Rooms {', '.join(str(s) for s in first.seeds)} ({first.mics}; mouths "
             f"{'moving' if first.mouths else 'still'}; speech: {first.speech}, faces: {first.faces}, noise: "
             f"{first.noise}), per result x visible person, edges of each person's speech forgiven by 0.3 s:",
             "",
             f"{'method':<16}{'precision':>10}{'recall':>8}{'prec. (forg.)':>15}{'rec. (forg.)':>14}"
             f"{'heard':>12}{'false str./utt.':>17}{'faces found':>13}{'error':>9}"]
    for s in scores:
        c = s.counts
        lines.append(f"{VARIANT_LABELS.get(s.method, s.method):<16}{_num(c.precision, '.3f'):>10}"
                     f"{_num(c.recall, '.3f'):>8}{_num(c.precision_forgiven, '.3f'):>15}"
                     f"{_num(c.recall_forgiven, '.3f'):>14}{f'{c.heard}/{c.utterances}':>12}"
                     f"{_num(c.false_stretches_per_utterance, '.2f'):>17}{_num(s.face_recall, '.3f'):>13}"
                     f"{_num(100 * s.median_error_m, '.1f') + ' cm':>9}")
    lines += ["", "Targets (issue 55, held-out seeds 100-119, still faces): precision and recall (forgiven) >= 0.95, "
                  "false stretches <= 0.1 per utterance."]
    return "\n".join(lines)


def format_voice_table(mics: str, seeds: list[int], summary: dict[str, dict[str, float]],
                       scenarios: list[str] | None = None) -> str:
    """Each voice candidate's SI-SDR improvement (dB, mean over the seconds, and the worst person's), alone and in
    overlap (:func:`app.eval.voices.summarise`), of the rooms ``seeds`` or of ``scenarios`` drawn with them."""
    from app.eval.voices import CANDIDATES

    where = "rooms" if not scenarios else f"{', '.join(scenarios)} seeds"
    lines = [f"Each person's voice, {where} {', '.join(str(s) for s in seeds)} ({mics}): SI-SDR improvement over the "
             "reference microphone, dB (against the dry speech; mean over the seconds / worst person), and STOI", "",
             f"{'candidate':<14}" + "".join(f"{kind + ' (' + _num(summary[kind]['seconds'], '.0f') + ' s)':>22}"
                                            f"{'STOI':>7}" for kind in summary)]
    for name in ("reference", *CANDIDATES):
        cells = [(f"{_num(summary[kind][name], '+.1f')} / {_num(summary[kind][name + ' worst'], '+.1f')}"
                  if name != "reference" else "", _num(summary[kind][name + " stoi"], ".2f")) for kind in summary]
        lines.append(f"{name:<14}" + "".join(f"{c:>22}{s:>7}" for c, s in cells))
    lines += ["", "Targets (issue 59, held-out rooms): in overlap >= +6 dB with four or more microphones (>= +4 dB "
                  "with the pair) and 3 dB more than delay-and-sum; alone never under +1 dB."]
    return "\n".join(lines)


def format_words_table(rows: list) -> str:
    """cpWER of avhear's words, the reference microphone's and the dry speech's, per run
    (:func:`app.eval.words.evaluate_words`)."""
    lines = ["Who said what: cpWER (speaker-attributed word error rate, meeteval), lower is better", "",
             f"{'run':<14}{'words':>7}{'avhear':>9}{'ref. mic':>10}{'dry':>7}{'utterances':>12}"]
    for r in rows:
        name = f"{r.name} {r.seed}" if r.name == "room" else f"{r.name} seed {r.seed}"
        lines.append(f"{name:<14}{r.reference_words:>7}{r.cpwer('avhear'):>9.2f}{r.cpwer('reference-mic'):>10.2f}"
                     f"{r.cpwer('dry'):>7.2f}{r.utterances:>12}")
    lines += ["", "Targets (issue 60): where one talks (S1-S4) within 1.3 times the dry speech's; where two talk at "
                  "once (S5, the rooms) at most half the reference microphone's."]
    return "\n".join(lines)
