"""Visual speech activity: whether each visible face's lips move, from its mouth's opening over the last moments.

A talker's mouth opens and closes with the syllables (3-8 a second); a listener's stays still, or moves without
sound now and then (a smile, chewing). :class:`LipTracks` follows each face from frame to frame (the nearest box
centre, within half a face of where it was) and gives its **lip activity**: the standard deviation of its mouth's
opening (:func:`avcore.facemesh.mouth_opening`, the gap over the mouth's width) over the last ``window_s``. A face
with fewer than ``min_samples`` openings in that window (just arrived, turned away, the mesh lost) has no opinion
(NaN), never "still". Its **synchrony** (:func:`lip_synchrony`) is the correlation of its opening with the
sound's log energy ``lead_s`` later (:class:`SoundEnvelope`): a talker's mouth moves about 75 ms before the sound it
shapes, a listener's mouthing moves with nothing heard.

:func:`veto_still_lips` is how the speaking test uses them: a face that the ITDs call speaking but whose lips are
clearly still (activity under ``still_below``, or within the face's own still level) is not speaking; moving lips
without sound (mouthing, chewing) do not make a speaker, and no opinion changes nothing. Where two talk at once the
direction gives the words to the louder: :func:`lips_with_the_words` lets a face speak too whose ITDs give it some
support, whose lips move clearly and with the sound, while another face is heard speaking.

Where direction cannot tell faces apart at all (:func:`same_direction_groups`: their mouths' ITDs within an ITD's
accuracy on every pair, one behind the other), the hearing takes them as one object and :func:`choose_by_lips`
gives that object's words to the face whose lips move most *for that face*: each track's activity placed between
its own still and moving levels (:attr:`LipTracks.relative`), since a distant face's mesh jitters more than a near
one's and a face's range depends on its photograph.

Still lips are not always silent ones: a hand over the mouth, a mask or a mesh that has lost the lips read as a
closed mouth. :class:`HiddenLips` gives a face's lips an opinion only once they have moved with its own voice, heard
alone for a second (:meth:`HiddenLips.update`), and drops it while they stay still through a second of that voice, so
that the veto only takes the brief calls of a listener whose lips are known to show speech; and
:func:`voice_without_lips` drops it at once while a voice is heard, on that face alone, that no lips in view make.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["HiddenLips", "LipTracks", "SoundEnvelope", "choose_by_lips", "frame_powers", "lip_synchrony",
           "lips_move_with_the_sound", "lips_with_the_words", "same_direction_groups", "veto_still_lips",
           "voice_without_lips"]

ENVELOPE_HOP_S = 0.01


def frame_powers(samples: np.ndarray, samplerate_hz: float, hop_s: float = ENVELOPE_HOP_S
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The mean square of the channels' mean in the block cut into frames of about ``hop_s`` (as many as round to
    it, equal to a sample: a 32 ms block gives three of 10.7 ms, none left short), with each frame's centre in
    seconds from the block's first sample: ``(times_s, powers)``, for :class:`SoundEnvelope`."""
    x = np.asarray(samples, dtype=np.float64)
    x = x.mean(axis=1) if x.ndim == 2 else x.reshape(-1)
    if x.size == 0:
        return np.zeros(0), np.zeros(0)
    n = max(1, round(x.size / (hop_s * samplerate_hz)))
    edges = np.round(np.linspace(0, x.size, n + 1)).astype(int)
    powers = np.add.reduceat(x ** 2, edges[:-1]) / np.diff(edges)
    return 0.5 * (edges[:-1] + edges[1:]) / samplerate_hz, powers


@dataclass(eq=False)
class SoundEnvelope:
    """The sound's log energy over the last ``keep_s``: ``push(times_s, powers)`` the frames' mean squares
    (:func:`frame_powers`, stamped on the source's clock, in order); ``log_energy(times_s)`` the log10 of their mean
    over ``smooth_s`` around each time (NaN where none was heard)."""

    keep_s: float = 3.0
    smooth_s: float = 0.03
    _times: np.ndarray = field(default_factory=lambda: np.zeros(0), init=False, repr=False)
    _powers: np.ndarray = field(default_factory=lambda: np.zeros(0), init=False, repr=False)

    def push(self, times_s: np.ndarray, powers: np.ndarray) -> None:
        t = np.append(self._times, np.asarray(times_s, dtype=np.float64).reshape(-1))
        p = np.append(self._powers, np.asarray(powers, dtype=np.float64).reshape(-1))
        keep = t >= t[-1] - self.keep_s if t.size else np.zeros(0, dtype=bool)
        self._times, self._powers = t[keep], p[keep]

    def log_energy(self, times_s: np.ndarray) -> np.ndarray:
        q = np.asarray(times_s, dtype=np.float64).reshape(-1)
        a = np.searchsorted(self._times, q - self.smooth_s / 2)
        b = np.searchsorted(self._times, q + self.smooth_s / 2, side="right")
        sums = np.append(0.0, np.cumsum(self._powers))
        n = b - a
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(n > 0, np.log10((sums[b] - sums[a]) / np.maximum(n, 1) + 1e-10), np.nan)

    def loud_share(self, start_s: float, end_s: float, above_db: float = 15.0, floor_quantile: float = 10.0
                   ) -> float:
        """The share of the frames heard within ``[start_s, end_s]`` whose log energy is ``above_db`` over the
        floor, the ``floor_quantile`` percentile of every kept frame's (the room's quiet). NaN where no frame was
        heard there."""
        inside = (self._times >= start_s) & (self._times <= end_s)
        if not inside.any():
            return float("nan")
        energy = self.log_energy(self._times)
        floor = float(np.percentile(energy, floor_quantile))
        return float(np.mean(energy[inside] > floor + above_db / 10.0))


@dataclass(eq=False)
class LipTracks:
    """``update(stamp_s, boxes, openings)`` -> each face's lip activity (N,) (NaN: no opinion); :attr:`ids` (N,)
    each face's track, the same number while it is followed.

    After each update, :attr:`relative` (N,) places each face's activity between its track's floor and top, the
    ``floor_quantile`` and ``top_quantile`` of its activities over the last ``floor_window_s`` (0 at the jitter of
    a still mouth at that size, 1 at its lips moving as much as they have lately; NaN with fewer than
    ``min_floor`` activities); :meth:`series` gives each face's openings over the last ``sync_window_s``.
    """

    window_s: float = 0.4
    min_samples: int = 6
    max_jump: float = 0.5  # of the face's width, between two frames
    floor_window_s: float = 10.0
    floor_quantile: float = 20.0
    top_quantile: float = 90.0
    min_floor: int = 15
    sync_window_s: float = 0.6
    relative: np.ndarray = field(default_factory=lambda: np.zeros(0), init=False, repr=False)
    ids: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int), init=False, repr=False)
    # each track: [centre (2,), width, [(t, opening)], [(t, activity)], id]
    _tracks: list = field(default_factory=list, init=False, repr=False)
    _next_id: int = field(default=0, init=False, repr=False)
    _last: list = field(default_factory=list, init=False, repr=False)  # the last update's faces' tracks

    def __post_init__(self) -> None:
        if not self.window_s > 0:
            raise ValueError(f"window_s must be a positive number of seconds, got {self.window_s!r}")
        if not (isinstance(self.min_samples, int) and self.min_samples >= 2):
            raise ValueError(f"min_samples must be a whole number >= 2, got {self.min_samples!r}")

    def update(self, stamp_s: float, boxes: np.ndarray, openings: np.ndarray) -> np.ndarray:
        """boxes (N, 4) x, y, w, h pixels; openings (N,) (NaN where the mesh found no face)."""
        b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        o = np.asarray(openings, dtype=np.float64).reshape(-1)
        if o.shape[0] != b.shape[0]:
            raise ValueError(f"openings must have one value per box ({b.shape[0]}), got {o.shape[0]}")
        centres = b[:, :2] + 0.5 * b[:, 2:]
        kept_s = max(self.window_s, self.sync_window_s)
        self._tracks = [t for t in self._tracks if t[2] and t[2][-1][0] >= stamp_s - self.window_s]
        free = list(range(len(self._tracks)))
        activity = np.full(len(b), np.nan)
        self.relative = np.full(len(b), np.nan)
        self.ids = np.zeros(len(b), dtype=int)
        self._last = [None] * len(b)
        for i in np.argsort(-b[:, 2]):  # the nearest (largest) faces choose first
            best, best_d = None, self.max_jump * b[i, 2]
            for k in free:
                d = float(np.linalg.norm(self._tracks[k][0] - centres[i]))
                if d <= best_d:
                    best, best_d = k, d
            if best is None:
                self._tracks.append([centres[i], b[i, 2], [], [], self._next_id])
                self._next_id += 1
                best = len(self._tracks) - 1
            else:
                free.remove(best)
            track = self._tracks[best]
            self.ids[i], self._last[i] = track[4], track
            track[0], track[1] = centres[i], b[i, 2]
            track[2] = [(t, v) for t, v in track[2] if t > stamp_s - kept_s] + [(float(stamp_s), o[i])]
            values = np.array([v for t, v in track[2] if t > stamp_s - self.window_s])
            values = values[np.isfinite(values)]
            if values.size >= self.min_samples:
                activity[i] = float(np.std(values))
                track[3] = [(t, a) for t, a in track[3] if t > stamp_s - self.floor_window_s]
                track[3].append((float(stamp_s), activity[i]))
                if len(track[3]) >= self.min_floor:
                    floor, top = np.percentile([a for _, a in track[3]], [self.floor_quantile, self.top_quantile])
                    self.relative[i] = (activity[i] - floor) / max(top - floor, 1e-6)
        return activity

    def series(self) -> list[np.ndarray]:
        """For each face of the last update, its (t, opening) rows over the last ``sync_window_s`` (K, 2): a copy
        that another thread may read (:func:`lip_synchrony`)."""
        return [np.array(track[2], dtype=np.float64).reshape(-1, 2) for track in self._last]


def lip_synchrony(series: list[np.ndarray], envelope: SoundEnvelope, lead_s: float = 0.075,
                  min_samples: int = 6) -> np.ndarray:
    """(N,) the correlation of each face's mouth opening (``series``, :meth:`LipTracks.series`) with
    ``envelope``'s log energy ``lead_s`` after each opening; NaN with fewer than ``min_samples`` openings heard, or a
    flat opening or sound."""
    out = np.full(len(series), np.nan)
    for i, rows in enumerate(series):
        t, o = np.asarray(rows, dtype=np.float64).reshape(-1, 2).T
        e = envelope.log_energy(t + lead_s)
        ok = np.isfinite(o) & np.isfinite(e)
        if ok.sum() >= min_samples and np.std(o[ok]) > 1e-9 and np.std(e[ok]) > 1e-9:
            out[i] = float(np.corrcoef(o[ok], e[ok])[0, 1])
    return out


@dataclass(eq=False)
class HiddenLips:
    """Which faces' still lips say nothing. A face is judged by its own voice: the moments it is heard speaking
    alone (no other face heard then), once they span ``heard_s`` (first to last) of the last ``window_s``. Lips whose
    median activity over those moments reaches ``moving_factor`` times the veto's threshold, and (where ``update``
    is given their synchrony with the sound) whose median synchrony over them reaches ``synced_above``, have shown
    that they move with this face's speech: the face is trusted, and its still lips may say "silent" later. Lips that
    stay near still, or move out of step, through that second of their own voice are not seen (a photograph, a hand,
    a mask, a face too far or too small for the mesh, a mesh that has lost them): their stillness is no evidence. A
    photograph's mesh may jitter as much as lips that barely move, but never in step with the voice. The verdict
    stands until the face's own voice says otherwise again, however long it then listens.

    With ``earn_trust`` (the default) a face that has not yet been judged gives no opinion either: abstaining never
    takes a person's words away, and a still face whose voice is heard only beside another's never earns the right
    to veto. Without it an unjudged face's still lips veto, and a face is hidden only while
    the moments in the window show its lips still. With ``synced_s``, lips seen moving with the sound
    (``moving_with_sound``, :func:`lips_move_with_the_sound`) in moments spanning that long of the window earn
    trust too, whoever else is heard: a photograph or a hand does not move with the sound, and a face that talks
    only beside others is judged sooner. A later second of its own voice with still lips takes the trust back.

    A talker's lips move while they speak (3-8 syllables a second). A listener called speaking by a neighbour's
    spill is heard beside the talker: those moments do not count, however often they come. The median, not each
    moment: a hand's mesh jitters about the veto's threshold. ``update`` is called once per result; a track absent
    from the result without a moment in ``window_s`` is forgotten.
    """

    window_s: float = 3.0
    heard_s: float = 1.0
    moving_factor: float = 2.0
    earn_trust: bool = True
    synced_s: float | None = None
    synced_above: float = 0.4
    _marks: dict = field(default_factory=dict, init=False, repr=False)  # track id -> [(t, activity, sync)] heard
    _synced: dict = field(default_factory=dict, init=False, repr=False)  # track id -> [t] lips moving with the sound
    _trusted: dict = field(default_factory=dict, init=False, repr=False)  # track id -> its lips moved with its voice

    def update(self, stamp_s: float, ids: np.ndarray, speaking: np.ndarray, activity: np.ndarray,
               still_below: float, moving_with_sound: np.ndarray | None = None,
               synchrony: np.ndarray | None = None) -> np.ndarray:
        """ids (N,) the faces' tracks (:attr:`LipTracks.ids`); speaking (N,) heard speaking; activity (N,) their lip
        activity (NaN: no opinion); still_below : the veto's threshold; moving_with_sound (N,) bool, read only
        with ``synced_s``; synchrony (N,) the lips' with the sound (:func:`lip_synchrony`). Returns (N,) bool: the
        faces whose lips are hidden."""
        since, now = stamp_s - self.window_s, set(np.asarray(ids).tolist())
        self._marks = {k: [m for m in v if m[0] > since] for k, v in self._marks.items()}
        self._marks = {k: v for k, v in self._marks.items() if v or k in now}
        self._synced = {k: [t for t in v if t > since] for k, v in self._synced.items() if k in self._marks}
        self._trusted = {k: v for k, v in self._trusted.items() if k in self._marks}
        hidden = np.zeros(len(ids), dtype=bool)
        alone = int(np.count_nonzero(speaking)) == 1
        for i, k in enumerate(np.asarray(ids).tolist()):
            marks = self._marks.setdefault(k, [])
            if speaking[i] and alone and np.isfinite(activity[i]):
                marks.append((float(stamp_s), float(activity[i]),
                              np.nan if synchrony is None else float(synchrony[i])))
            if self.synced_s is not None and moving_with_sound is not None and moving_with_sound[i]:
                synced = self._synced.setdefault(k, [])
                synced.append(float(stamp_s))
                if synced[-1] - synced[0] >= self.synced_s:
                    self._trusted[k] = True
            judged = bool(marks) and marks[-1][0] - marks[0][0] >= self.heard_s
            still = False
            if judged:
                synced = [m[2] for m in marks if np.isfinite(m[2])]
                still = (float(np.median([m[1] for m in marks])) < self.moving_factor * still_below
                         or (bool(synced) and float(np.median(synced)) < self.synced_above))
                self._trusted[k] = not still
            hidden[i] = not self._trusted.get(k, False) if self.earn_trust else still
        return hidden


    def trusted(self, ids: np.ndarray) -> np.ndarray:
        """(N,) bool: the faces whose lips have an opinion as of the last :meth:`update` (without ``earn_trust``,
        every face's)."""
        ids = np.asarray(ids).tolist()
        return np.array([True] * len(ids) if not self.earn_trust else [self._trusted.get(k, False) for k in ids],
                        dtype=bool)


def voice_without_lips(speaking: np.ndarray, activity: np.ndarray, still_below: float, loud_share: float,
                       share_above: float = 0.35) -> np.ndarray:
    """(N,) bool: the face whose still lips say nothing because a voice is heard that no visible lips make. It is
    the only face heard speaking, the sound is loud (:meth:`SoundEnvelope.loud_share`) for at least ``share_above``
    of the result's time frame, and no other face's lips move (activity at or above ``still_below``) or lack an
    opinion (NaN: turned away, it may be the talker).

    Someone speaks, the ITDs place the voice on this face alone and no lips in view shape it: the talker's mouth is
    hidden (a hand, a mesh that reads closed lips), and :class:`HiddenLips` would only say so after a second of it,
    too late for a short number. A third of the frame is more than a clap's 80 ms; the ends of a number, which the
    veto trims, are quiet."""
    speaking = np.asarray(speaking, dtype=bool)
    act = np.asarray(activity, dtype=np.float64).reshape(-1)
    out = np.zeros(len(speaking), dtype=bool)
    if np.count_nonzero(speaking) != 1 or not loud_share >= share_above:  # False with a NaN share
        return out
    i = int(np.flatnonzero(speaking)[0])
    others = np.delete(np.nan_to_num(act, nan=np.inf), i)
    out[i] = not np.any(others >= still_below)
    return out


def veto_still_lips(speaking: np.ndarray, probability: np.ndarray, activity: np.ndarray, still_below: float,
                    relative: np.ndarray | None = None, *, relative_below: float = 0.1,
                    relative_cap: float = 0.03) -> tuple[np.ndarray, np.ndarray]:
    """The speaking states and probabilities with the faces whose lips are still not speaking: ``activity`` under
    ``still_below``, or (with ``relative``, :attr:`LipTracks.relative`) while another face is heard speaking too,
    within ``relative_below`` of the face's own still level and under ``relative_cap``. A far face's mesh jitters
    above ``still_below`` with its lips shut, and a neighbour's spill calls it speaking beside the talker; heard
    alone, its words are no one else's (a hand over a talker's mouth jitters at its own floor too). The cap keeps
    lips that move plainly from being called still. Their probability is kept at most 0.5 (the results' promise:
    above 0.5 exactly when speaking)."""
    speaking = np.asarray(speaking, dtype=bool)
    act = np.nan_to_num(np.asarray(activity, dtype=np.float64), nan=np.inf)
    still = act < still_below
    if relative is not None:
        beside = np.count_nonzero(speaking) - speaking.astype(int) >= 1
        still |= beside & (np.nan_to_num(np.asarray(relative, dtype=np.float64), nan=np.inf) < relative_below) \
            & (act < relative_cap)
    veto = np.asarray(speaking, dtype=bool) & still
    return np.asarray(speaking, dtype=bool) & ~veto, np.where(veto, np.minimum(probability, 0.5), probability)


def same_direction_groups(itds_s: np.ndarray, within_s: float,
                          linkable: np.ndarray | None = None) -> list[np.ndarray]:
    """The faces that direction cannot tell apart: groups (index arrays, in order) of the rows of ``itds_s`` (N, P),
    each face's ITD on every pair, linked when two rows are within ``within_s`` on every pair. A row with a NaN is
    alone, and so is one that ``linkable`` (N,) bool says may not be grouped (lips that cannot choose)."""
    x = np.asarray(itds_s, dtype=np.float64)
    x = x.reshape(len(x), x.size // max(len(x), 1))
    ok = np.ones(len(x), dtype=bool) if linkable is None else np.asarray(linkable, dtype=bool)
    label = np.arange(len(x))
    for i in np.flatnonzero(ok):
        for j in np.flatnonzero(ok[i + 1:]) + i + 1:
            if np.all(np.abs(x[i] - x[j]) <= within_s):  # False with a NaN
                label[label == label[j]] = label[i]
    return [np.flatnonzero(label == k) for k in dict.fromkeys(label.tolist())]


def choose_by_lips(speaking: np.ndarray, probability: np.ndarray, relative: np.ndarray,
                   groups: list[np.ndarray], both_above: float) -> tuple[np.ndarray, np.ndarray]:
    """Within each group of faces that speaks as one object, the words go to the face whose lips move most for that
    face (``relative``, :attr:`LipTracks.relative`); another face of the group keeps them only if its own lips move
    at least ``both_above`` of their own range (two talking at once). A group with fewer than two faces with an
    opinion is left as it is. Those that lose the words keep a probability of at most 0.5."""
    speaking = np.asarray(speaking, dtype=bool).copy()
    probability = np.asarray(probability, dtype=np.float64).copy()
    for g in groups:
        seen = g[np.isfinite(relative[g])]
        if len(seen) < 2 or not speaking[g].any():
            continue
        best = seen[np.argmax(relative[seen])]
        lose = seen[(seen != best) & (relative[seen] < both_above)]
        speaking[lose] = False
        probability[lose] = np.minimum(probability[lose], 0.5)
    return speaking, probability


def lips_move_with_the_sound(activity: np.ndarray, relative: np.ndarray, synchrony: np.ndarray, *,
                             moving_above: float = 0.05, relative_above: float = 0.6,
                             synchrony_above: float = 0.3) -> np.ndarray:
    """(N,) bool: lips that move plainly (``activity`` above ``moving_above``, ``relative`` at least
    ``relative_above`` of their own range) and with the sound (``synchrony`` at least ``synchrony_above``):
    :func:`lips_with_the_words`' evidence of a voice, which also makes a call of the speaking test's later looks a
    call that may start speech (:class:`avcore.speaking.RescueContinuity`). NaN: False."""
    with np.errstate(invalid="ignore"):
        return ((np.asarray(activity, dtype=np.float64) > moving_above)
                & (np.asarray(relative, dtype=np.float64) >= relative_above)
                & (np.asarray(synchrony, dtype=np.float64) >= synchrony_above))


def lips_with_the_words(speaking: np.ndarray, probability: np.ndarray, activity: np.ndarray, relative: np.ndarray,
                        synchrony: np.ndarray, *, least_probability: float = 0.2, moving_above: float = 0.05,
                        relative_above: float = 0.6, synchrony_above: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    """Two talking at once: where another face is heard speaking, a face not heard speaking speaks too when its
    ITDs still give it some support (``probability`` at least ``least_probability``) and its lips move plainly
    (``activity`` above ``moving_above``, ``relative`` at least ``relative_above`` of its own range) and with the
    sound (``synchrony``, :func:`lip_synchrony`, at least ``synchrony_above``); its probability becomes just
    over 0.5. The direction gives most of an overlap's windows to the louder talker; a listener's mouthing moves
    with no sound of its own and gets no ITD support, so it stays silent. NaN anywhere: no opinion, no change."""
    speaking = np.asarray(speaking, dtype=bool).copy()
    probability = np.asarray(probability, dtype=np.float64).copy()
    others = np.count_nonzero(speaking) - speaking.astype(int)
    with np.errstate(invalid="ignore"):
        join = (~speaking & (others >= 1) & (probability >= least_probability)
                & lips_move_with_the_sound(activity, relative, synchrony, moving_above=moving_above,
                                           relative_above=relative_above, synchrony_above=synchrony_above))
    speaking[join] = True
    probability[join] = np.maximum(probability[join], np.nextafter(0.5, 1.0))
    return speaking, probability
