"""Speaking states of the AV objects: eq. (audio_act) with the paper's tau_A, and avhear's outlier-aware test."""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

__all__ = ["ARRAY_THRESHOLDS", "COUNT_BY", "Decision", "RescueContinuity", "SpeakingTest", "SpeakingVote",
           "bin_shares", "speaking_threshold", "vote_speaking"]


def speaking_threshold(n_itds: int, n_objects: int) -> float:
    """tau_A = K / (N + 2) (section 6, implementation details), the threshold of eq. (audio_act)."""
    return n_itds / (n_objects + 2.0)


COUNT_BY: tuple[str, ...] = ("posterior", "nearest", "window")  # SpeakingTest.count_by: how an ITD counts


def bin_shares(bins: np.ndarray, freqs_hz: np.ndarray, means_s: np.ndarray, agreement: float = 0.9) -> np.ndarray:
    """Each person's share of the time-frequency bins whose phases agree with them on every pair at once.

    The paper's conclusion: "each microphone pair yields one ITD space and combining these 1D spaces would provide a
    much more robust algorithm". The ITDs of a window or a frame are peaks, one per pair, and where two people talk
    at once a pair's peak may belong to the louder one or fall between them (a phantom); the bins are finer. Speech
    is sparse in time and frequency, so nearly every bin is dominated by one source (W-disjoint orthogonality,
    Yilmaz and Rickard 2004), and that source's direct sound gives the bin, on every pair p, the phase of its ITD:
    ``phi_p(t, f) = -2 pi f tau_p`` (the sign of eq. itd: ``X = L conj(R)``, the left channel late by ``tau``).
    With ``X_p(t, f) = w_p(t, f) exp(i phi_p(t, f))`` the weighted phase transform of frame t, bin f, pair p
    (``ItdStream.pop_frame_bins``), person n, mapped to the ITD vector ``tau_n`` (eq. final_av_mapping on each
    pair), agrees with the bin by

        a_n(t, f) = Re sum_p X_p(t, f) exp(2 i pi f tau_np) / sum_p |X_p(t, f)|,   in [-1, 1].

    The bin votes for the person it agrees with best, when ``a_n >= agreement`` (every pair's phase near the
    person's); its vote weighs ``W(t, f) = sum_p |X_p(t, f)|``. The share is person n's votes over all the bins'
    weight: ``s_n = sum_{t,f} W [bin votes n] / sum_{t,f} W``. A phantom between two talkers on one pair is not a
    direction that the bins of the other pairs agree with, so it gets few votes; a talker that a louder one masks in
    every window and frame still owns the bins where it is louder, on every pair at once.

    bins : (m, P, B) complex, the frames' bins on the P pairs; freqs_hz : (B,); means_s : (N, P) the persons' ITDs
    on each pair. Returns (N,) shares in [0, 1] (zeros with no weight).
    """
    x = np.asarray(bins)
    mu = np.asarray(means_s, dtype=np.float64)
    n = mu.shape[0]
    if x.size == 0 or n == 0:
        return np.zeros(n)
    steer = np.exp(2j * np.pi * np.asarray(freqs_hz, dtype=np.float64)[None, None, :] * mu[:, :, None])  # (N, P, B)
    weight = np.abs(x).sum(axis=1)  # (m, B)
    total = float(weight.sum())
    if total <= 0:
        return np.zeros(n)
    agree = np.einsum("mpb,npb->nmb", x, steer.astype(np.complex64)).real / np.maximum(weight, 1e-30)[None]
    votes = agree.max(axis=0) >= agreement
    return np.bincount(agree.argmax(axis=0)[votes], weights=weight[votes], minlength=n) / total


_LOG_FACT = np.concatenate([[0.0], np.cumsum(np.log(np.arange(1, 401)))])  # log k!, k = 0..400


def _poisson_quantile(q: float, lam: np.ndarray) -> np.ndarray:
    """Smallest k with P(X <= k) >= q for X ~ Poisson(lam), vectorised (scipy.stats' ppf costs ~100 us a call).

    Exact for lam up to about 300 (the sum runs to k = lam + 10 sqrt(lam) + 20, at most 400).
    """
    lam = np.atleast_1d(np.asarray(lam, dtype=np.float64))
    k_max = int(min(400, lam.max(initial=0.0) + 10.0 * np.sqrt(lam.max(initial=0.0)) + 20))
    k = np.arange(k_max + 1)
    log_lam = np.log(np.maximum(lam, 1e-300))[:, None]  # lam = 0 is set below: its quantile is 0
    log_pmf = k[None, :] * log_lam - lam[:, None] - _LOG_FACT[None, : k_max + 1]
    cdf = np.cumsum(np.exp(log_pmf), axis=1)
    cdf[lam == 0] = 1.0
    return (cdf < q).sum(axis=1).astype(np.float64)


class Decision(NamedTuple):
    """:meth:`SpeakingTest.decide_all`: ``speaking`` (N,) bool, ``probability`` (N,) above 0.5 exactly when
    speaking, ``tau_a`` = K / (N + 2), ``rescued`` (N,) bool: speaking by the single frames', bands' or bins' looks
    where the windows' test alone says silent (never with the paper's test, which has no such look)."""

    speaking: np.ndarray
    probability: np.ndarray
    tau_a: float
    rescued: np.ndarray


#: Thresholds chosen for one array's geometry on its own tuning rooms, where the defaults (chosen with the ReSpeaker
#: 4 and the pair) do not fit it. NAO's head (microphones 9.5-12 cm apart) leaves fewer bins agreeing with anyone
#: than the ReSpeaker's 8 cm square does, so every share is smaller there and the default claim misses the quieter
#: of two talkers (measured: docs/experiments.md, wave 4, twenty-second session). Keyed by
#: :attr:`avcore.geometry.MicArray.preset_name`.
ARRAY_THRESHOLDS: dict[str, dict[str, float]] = {"nao": {"bin_claim_share": 0.065}}


@dataclass(frozen=True)
class SpeakingTest:
    """The speaking decision of eq. (audio_act) and avhear's outlier-aware replacement of it.

    The paper: speaking when beta_bar_n > tau_A = K / (N + 2). That threshold fails both ways: with nobody speaking,
    tau_A is small and a cluster fires on a couple of stray ITDs (reverberation, noise); with talkers the cameras do not
    see (or people the vision missed), K grows with ITDs that are nobody's in the model and tau_A silences the visible
    talker. The outlier-aware test (``outlier_aware``) asks instead whether the ITDs within +-``window_sd`` sigma of the
    cluster (sigma at least ``min_sd_s``) are more than chance allows: if a share ``outlier_share`` of the K ITDs were
    spread uniformly over the ITD interval, the count in the window would be Poisson; the count must exceed its
    ``quantile`` and be at least ``min_itds``. ``count_by`` says how much an ITD in the window counts for the person:
    ``"posterior"`` with its posterior beta_kn, so that an ITD between two people is not counted twice; ``"nearest"``
    with its posterior of being anyone's (1 - the outlier's), all of it for the person it lies nearest to; ``"window"``
    fully for everyone whose window holds it.

    ``"nearest"`` is the face-guided default (:class:`avcore.inference.FaceGuidedParams`): two faces closer in ITD
    than the Gaussians' width explain the same ITDs about equally well, and EM then often hands nearly all the
    weight, and so the posterior, to one of them; counting each ITD for the nearest face follows the geometry
    instead of that weight, and keeps the outlier class's share out.

    The bins' look (``bin_share``) keeps a call above ``bin_confirm_share`` and makes one above ``bin_claim_share``,
    with one microphone pair above ``bin_claim_share_one_pair``: a bin then agrees with every ITD whose phase lies
    within ``bin_agreement`` at its frequency (at 500 Hz +-140 us, most of a 12 cm pair's range) and no second pair
    narrows that, so a talker's neighbour collects more of its bins. Nor can one pair tell a phantom from a voice:
    two sounds at once (two talkers, or a talker and a steady voice) put a bin's phase between them. So with one
    pair the bins confirm nothing, and while the other looks hear someone they never outvote them: they claim only
    a person whose share is at most the heard talker's (the quieter voice of an overlap), not the person between.
    With several pairs and ``bin_spill`` (each talker's learned spill onto each neighbour: :mod:`avcore.bin_spill`)
    a claim also needs a share above ``bin_spill_factor`` times the spill that the talkers the other looks hear
    would give the person: a lone talker's neighbour is not claimed for what the talker's own reverberation explains.
    Also with several pairs, two voices at once put each pair's peak between them: a person whose ITD vector lies
    near the chord between two others' (off it by at most ``between_chord`` of its length), each called or with a
    bins' share at least the person's, stays called only by the bins' claim, not by their confirmation.

    ``decide(..., present=mask)`` decides on a subset of the ITDs that fitted the model: the face-guided fusion
    fits on the ITDs of the whole time frame and decides on those near the frame's own instant
    (``FaceGuidedParams.decision_window_s``).

    In full (every part, and why): docs/method.md ("The speaking test").
    """

    outlier_aware: bool = True
    window_sd: float = 2.0
    min_sd_s: float = 20e-6
    outlier_share: float = 0.2
    quantile: float = 0.9
    min_itds: int = 2
    count_by: str = "posterior"
    frame_rescue: bool = True
    frame_within_s: float = 25e-6
    frame_quantile: float = 0.99
    frame_min: int = 3
    frame_spread_s: float = 15e-6
    band_spread_s: float = 30e-6
    bin_agreement: float = 0.9
    bin_confirm_share: float = 0.03
    bin_claim_share: float = 0.1
    bin_claim_share_one_pair: float = 0.25
    bin_spill_factor: float = 1.0
    between_chord: float = 0.3

    def __post_init__(self) -> None:
        if not -1 <= self.bin_agreement <= 1:
            raise ValueError(f"bin_agreement must be in [-1, 1], got {self.bin_agreement!r}")
        for name in ("bin_claim_share", "bin_claim_share_one_pair"):
            if not 0 <= self.bin_confirm_share <= getattr(self, name) <= 1:
                raise ValueError(f"need 0 <= bin_confirm_share <= {name} <= 1, got {self.bin_confirm_share!r} "
                                 f"and {getattr(self, name)!r}")
        if not self.bin_spill_factor >= 0:
            raise ValueError(f"bin_spill_factor must be >= 0, got {self.bin_spill_factor!r}")
        if not self.between_chord >= 0:
            raise ValueError(f"between_chord must be >= 0, got {self.between_chord!r}")
        if self.count_by not in COUNT_BY:
            raise ValueError(f"count_by must be one of {', '.join(COUNT_BY)}, got {self.count_by!r}")
        for name in ("frame_within_s", "frame_spread_s", "band_spread_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0 seconds, got {getattr(self, name)!r}")
        if not 0 < self.frame_quantile < 1:
            raise ValueError(f"frame_quantile must be in (0, 1), got {self.frame_quantile!r}")

    def for_array(self, array: object) -> SpeakingTest:
        """This test with the thresholds chosen for ``array``'s geometry (:data:`ARRAY_THRESHOLDS`), when it is one of
        the presets (wherever it is placed); itself for any other array or one microphone pair."""
        name = getattr(array, "preset_name", None)
        return replace(self, **ARRAY_THRESHOLDS[name]) if name in ARRAY_THRESHOLDS else self

    def _count_test(self, counts: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The window test: a count must exceed the chance quantile of Poisson(lam) and reach ``min_itds`` (the
        1e-9 makes "reach" a strict test)."""
        thr = np.maximum(_poisson_quantile(self.quantile, lam) + 1.0, self.min_itds) - 1e-9
        return counts > thr, counts / (counts + thr)

    def decide(self, beta: np.ndarray, itds: np.ndarray, means: np.ndarray, variances: np.ndarray,
               supports: np.ndarray, present: np.ndarray | None = None, frame_itds: np.ndarray | None = None,
               band_itds: np.ndarray | None = None, bin_share: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, float]:
        """Speaking states (N,), a probability in [0, 1] that is above 0.5 exactly when speaking, and tau_A:
        :meth:`decide_all` without saying which calls the rescues alone made."""
        d = self.decide_all(beta, itds, means, variances, supports, present, frame_itds, band_itds, bin_share)
        return d.speaking, d.probability, d.tau_a

    def decide_all(self, beta: np.ndarray, itds: np.ndarray, means: np.ndarray, variances: np.ndarray,
                   supports: np.ndarray, present: np.ndarray | None = None, frame_itds: np.ndarray | None = None,
                   band_itds: np.ndarray | None = None, bin_share: np.ndarray | None = None,
                   bin_spill: np.ndarray | None = None) -> Decision:
        """The :class:`Decision`: speaking states (N,), a probability in [0, 1] above 0.5 exactly when speaking,
        tau_A, and ``rescued``, the calls that the windows' test did not make and the later looks did.

        One microphone pair is an array of one pair: ITDs are vectors, one value per pair.
        beta : (K, N) the auditory posteriors of the N persons (eq. beta_kn, outlier column dropped).
        itds : (K, P) one vector per window (NaN where a pair has none); means, variances : (N, P) each person's
        Gaussian on each pair; supports : (P, 2) each pair's ITD interval.
        present : (K,) bool, the ITDs the decision counts (K and tau_A are theirs); None: all.
        frame_itds : (M, P) the ITDs of the single frames of the same time (``ItdStream.pop_frame_itds``), for
            ``frame_rescue``; None: the window ITDs alone decide.
        band_itds : (L, P) the peaks of the frames' frequency bands (``ItdStream.pop_band_itds``; a band's peaks
            are not matched across pairs, so a band row has one pair), a third look with the same test and a spread
            of ``band_spread_s``; None: not used.
        bin_share : (N,) each person's :func:`bin_shares` over the same time, the fourth look (confirm and claim,
            see the class); None: not used.

        With several pairs a person's window is the box of +-``window_sd`` sigma on every pair a vector has, and a
        vector counts for the person it lies nearest to (summed squares over its pairs). Chance is the same
        Poisson count with each interval's share replaced by the box's, bounded by its tightest pair: the smallest
        of the pairs' shares, and for the spill-over from another person the smallest of the per-pair spills. The
        product (independent pairs) would be far too small: the ITDs of one sound on every pair follow from one
        direction (two degrees of freedom), so a reflection or a stray sound is as consistent across the pairs as
        a talker. Rows with different pairs count separately, and their counts and Poisson means add up.
        """
        x = np.asarray(itds, dtype=np.float64).reshape(len(beta), means.shape[1])
        if present is not None:
            beta, x = beta[present], x[present]
        beta_counts = beta.sum(axis=0)
        n, k = beta_counts.size, x.shape[0]
        tau = speaking_threshold(k, n)
        denominator = beta_counts + tau
        prob = np.divide(beta_counts, denominator, out=np.zeros(n), where=denominator > 0)
        speaking = beta_counts > tau
        if not (self.outlier_aware and n):
            return Decision(speaking, prob, tau, np.zeros(n, dtype=bool))
        u = 1.0 / (supports[:, 1] - supports[:, 0])
        half = self.window_sd * np.maximum(np.sqrt(variances), self.min_sd_s)  # (N, P)
        counts, lam = np.zeros(n), np.zeros(n)
        for rows, pairs in _groups(x):
            xr = x[rows]
            d = xr[:, None, pairs] - means[None, :, pairs]
            inside = (np.abs(d) <= half[None, :, pairs]).all(axis=2)
            b = beta[rows]
            if self.count_by == "posterior":
                share = b
            elif self.count_by == "nearest":
                share = b.sum(axis=1, keepdims=True) * _nearest(d)
            else:
                share = np.ones_like(b)
            counts += (share * inside).sum(axis=0)
            lam += self.outlier_share * len(xr) * np.minimum(2.0 * half[:, pairs] * u[pairs], 1.0).min(axis=1)
        speaking, prob = self._count_test(counts, lam)
        by_windows = speaking
        if self.frame_rescue and frame_itds is not None and len(frame_itds):
            speaking, prob = self._rescue(speaking, prob, np.asarray(frame_itds, dtype=np.float64), means, u,
                                          self.frame_spread_s)
        if self.frame_rescue and band_itds is not None and len(band_itds):
            # two people talking at once put the bands they share at a phantom between them: nobody lying
            # between two speaking people (on every pair) is called speaking on the bands
            lo = means[None, :, :] < means[:, None, :]  # (person, other, pair): the other is below
            hi = means[None, :, :] > means[:, None, :]
            between = np.zeros(n, dtype=bool)
            for i in range(n):
                for a in np.flatnonzero(speaking):
                    for b2 in np.flatnonzero(speaking):
                        if (lo[i, a] & hi[i, b2]).all() or (hi[i, a] & lo[i, b2]).all():
                            between[i] = True
            found, found_prob = self._rescue(speaking, prob, np.asarray(band_itds, dtype=np.float64), means, u,
                                             self.band_spread_s)
            speaking = np.where(between, speaking, found)
            prob = np.where(between, prob, found_prob)
        if bin_share is not None:
            speaking, prob = self._bins(speaking, prob, np.asarray(bin_share, dtype=np.float64).reshape(n),
                                        one_pair=means.shape[1] == 1, spill=bin_spill, means=means)
        return Decision(speaking, prob, tau, speaking & ~by_windows)

    def _bins(self, speaking: np.ndarray, prob: np.ndarray, share: np.ndarray, one_pair: bool = False,
              spill: np.ndarray | None = None, means: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The fourth look: confirmed by ``bin_confirm_share`` (not a person between two others: ``means``),
        claimed by ``bin_claim_share`` and above the heard talkers' learned ``spill``; with ``one_pair`` claimed by
        ``bin_claim_share_one_pair`` without outvoting the other looks' talkers, and never confirmed (see the
        class). Where the look changes a state, the probability is the share against the threshold that decided
        (above 0.5 exactly when speaking)."""
        if one_pair:
            claim, kept = self.bin_claim_share_one_pair, speaking
            top = share[speaking].max() if speaking.any() else np.inf  # the largest share of those heard
            claimed = (share > claim) & (share <= top)
        else:
            claim, kept = self.bin_claim_share, speaking & (share > self.bin_confirm_share)
            claimed = share > claim
            if spill is not None:
                ratio = np.nan_to_num(np.asarray(spill, dtype=np.float64).reshape(len(share), len(share)))
                np.fill_diagonal(ratio, 0.0)
                claimed &= share > self.bin_spill_factor * (ratio.T @ np.where(speaking, share, 0.0))
            if means is not None and self.between_chord > 0:
                kept &= ~_between(np.asarray(means, dtype=np.float64), kept | claimed, share, self.between_chord)
        out = kept | claimed
        with np.errstate(invalid="ignore", divide="ignore"):
            thr = np.where(speaking, self.bin_confirm_share, claim)
            by_share = np.where(share + thr > 0, share / (share + thr), 0.0)
        by_share = np.where(out, np.maximum(by_share, 0.5 + 1e-9), np.minimum(by_share, 0.5))
        return out, np.where(out == speaking, prob, by_share)

    def _rescue(self, speaking: np.ndarray, prob: np.ndarray, obs: np.ndarray, means: np.ndarray, u: np.ndarray,
                b: float) -> tuple[np.ndarray, np.ndarray]:
        """The second look at the single frames: a person also speaks when more frame ITDs lie within
        ``frame_within_s`` of their mean (on every pair a row has), and nearer to it than to any other person's,
        than chance allows. Chance is a Poisson count (above its ``frame_quantile`` and at least ``frame_min``)
        whose mean adds the frames that stray uniformly over the ITD interval (a share ``outlier_share`` of the M;
        the box's tightest pair) and those that the other people's frames spill over to this person (frame ITD
        errors Laplacian, of scale ``b``; the smallest spill over the pairs): a source at distance g sends a frame
        within delta of this person, and nearer it than to the source, with P(max(g / 2, g - delta) < e < g +
        delta) = (exp(-lo / b) - exp(-hi / b)) / 2 for e ~ Laplace(b)."""
        delta = self.frame_within_s
        n = means.shape[0]
        counts, lam = np.zeros(n), np.zeros(n)
        gap = np.abs(means[:, None, :] - means[None, :, :])  # (source, person, pair)
        lo, hi = np.maximum(gap / 2, gap - delta), gap + delta
        spill = 0.5 * (np.exp(-lo / b) - np.exp(-hi / b))
        rows_p = obs.reshape(-1, means.shape[1])
        for rows, pairs in _groups(rows_p):
            xr = rows_p[rows]
            d = xr[:, None, pairs] - means[None, :, pairs]
            c = ((np.abs(d) <= delta).all(axis=2) & _nearest(d)).sum(axis=0)
            lam_g = np.full(n, self.outlier_share * len(xr) * np.minimum(2.0 * delta * u[pairs], 1.0).min())
            if n > 1:
                sp = spill[:, :, pairs].min(axis=2)
                np.fill_diagonal(sp, 0.0)
                lam_g += (c / (1.0 - np.exp(-delta / b))) @ sp
            counts += c
            lam += lam_g
        thr = np.maximum(_poisson_quantile(self.frame_quantile, lam) + 1.0, self.frame_min) - 1e-9
        return speaking | (counts > thr), np.maximum(prob, counts / (counts + thr))


@dataclass(eq=False)
class RescueContinuity:
    """The weaker looks may carry a person's speech on, not start it (hysteresis in time, as Canny's on edges).

    The windows' outlier-aware test is rarely wrong; the single frames', bands' and bins' looks
    (:meth:`SpeakingTest.decide_all` ``rescued``) hear the talker a louder one masks while two talk at once, but a
    lone talker's reverberation and spread put the same evidence on a silent neighbour some 15 degrees away. In a
    conversation the masked talker was heard on their own just before (turns overlap at their ends), or is heard
    again within a moment. So a rescued call stands only while the same person's last call that stood is at most
    ``gap_s`` old: a call of the windows' test always stands, and a chain of rescued calls may follow it. Nor does
    a chain run on for more than ``chain_s`` after the person's last call by the windows' test: once a person has
    stopped, a neighbour's spill would otherwise keep them called through the neighbour's whole turn (the tail of
    their speech). The others become silent, their probability at most 0.5. Causal: it adds no wait. Keyed by the
    people's ids (:mod:`avcore.tracking`); an id unseen for ``memory_s`` is forgotten.

    ``update(stamp_s, ids, speaking, probability, rescued)`` -> ``(speaking, probability)``, once per result, in
    stamp order.
    """

    gap_s: float = 0.1
    chain_s: float = 1.0
    memory_s: float = 10.0
    _last: dict[int, float] = field(default_factory=dict, init=False, repr=False)  # id -> stamp of its last call
    _heard: dict[int, float] = field(default_factory=dict, init=False, repr=False)  # ... of its last windows' call

    def __post_init__(self) -> None:
        for name in ("gap_s", "chain_s", "memory_s"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0 seconds, got {getattr(self, name)!r}")

    def update(self, stamp_s: float, ids: np.ndarray, speaking: np.ndarray, probability: np.ndarray,
               rescued: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ids = np.asarray(ids).reshape(-1)
        speaking = np.asarray(speaking, dtype=bool).reshape(-1).copy()
        probability = np.asarray(probability, dtype=np.float64).reshape(-1).copy()
        rescued = np.asarray(rescued, dtype=bool).reshape(-1)
        if not ids.shape == speaking.shape == probability.shape == rescued.shape:
            raise ValueError(f"ids, speaking, probability and rescued must have one entry per person, got "
                             f"{ids.shape}, {speaking.shape}, {probability.shape} and {rescued.shape}")
        stamp = float(stamp_s)
        for k, pid in enumerate(ids.tolist()):
            if not speaking[k]:
                continue
            if rescued[k] and not (stamp - self._last.get(pid, -np.inf) <= self.gap_s + 1e-6  # stamps' rounding
                                   and stamp - self._heard.get(pid, -np.inf) <= self.chain_s + 1e-6):
                speaking[k] = False
                probability[k] = min(probability[k], 0.5)
                continue
            self._last[pid] = stamp
            if not rescued[k]:
                self._heard[pid] = stamp
        self._last = {i: t for i, t in self._last.items() if stamp - t <= self.memory_s}
        self._heard = {i: t for i, t in self._heard.items() if stamp - t <= self.memory_s}
        return speaking, probability


def _groups(x: np.ndarray) -> list[tuple[np.ndarray | slice, np.ndarray | slice]]:
    """Rows of ``x`` (K, P) grouped by which pairs they have (finite entries): ``(rows, pairs)`` masks (or slices
    when every row has every pair), empty rows (no pair) left out."""
    seen = np.isfinite(x)
    if x.shape[0] and seen.all():  # the common case: every row has every pair (slices: views, no copies)
        return [(slice(None), slice(None))]
    patterns, inverse = np.unique(seen, axis=0, return_inverse=True)
    inverse = np.asarray(inverse).reshape(-1)
    return [(inverse == g, pat) for g, pat in enumerate(patterns) if pat.any()]


def _between(means: np.ndarray, called: np.ndarray, share: np.ndarray, chord: float) -> np.ndarray:
    """(N,) True for each person i whose ITD vector lies near the chord between two others a and b, each of them
    called or with a bins' share at least i's: projected strictly inside the chord, at most ``chord`` times its
    length off it (means (N, P); called, share (N,))."""
    n = means.shape[0]
    if n < 3:
        return np.zeros(n, dtype=bool)
    v = means[None, :, :] - means[:, None, :]  # (a, b, P): b - a
    length2 = np.einsum("abp,abp->ab", v, v)
    w = v  # (a, i, P): i - a
    dot = np.einsum("abp,aip->abi", v, w)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = dot / length2[:, :, None]
        off2 = (np.einsum("aip,aip->ai", w, w)[:, None, :] - t * dot) / length2[:, :, None]
    near = (t > 0) & (t < 1) & (off2 <= chord * chord)  # (a, b, i); a = b gives NaN, never near
    ends = called[None, :] | (share[None, :] >= share[:, None])  # (i, a)
    np.fill_diagonal(ends, False)
    return np.einsum("abi,ia,ib->i", near, ends, ends).astype(bool) if near.any() else np.zeros(n, dtype=bool)


def _nearest(d: np.ndarray) -> np.ndarray:
    """(K, N) True for the person each vector lies nearest to (summed squares over the pairs of ``d`` (K, N, P))."""
    dist2 = (d * d).sum(axis=2)
    return dist2 == dist2.min(axis=1, keepdims=True)


def vote_speaking(ids: np.ndarray, speaking: np.ndarray, probability: np.ndarray,
                  window: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Each person's speaking state as the majority of their states over a window of consecutive results (beyond
    the paper, which decides each time interval alone).

    ids, speaking, probability : (N,) the person ids (:mod:`avcore.tracking`), states and probabilities of the
    result decided. window : ``(ids, speaking)`` of every result of the window, this one included. A person speaks
    when judged speaking in more than half of the window's results that hold their id. Where the vote changes a
    state, the probability becomes the share of speaking votes (so it stays above 0.5 exactly when speaking).

    A spoken digit lasts 0.2-0.7 s, so a speaking state of two or three frames is noise or a neighbour's sound,
    and a one-frame gap inside a number is a miss: the vote removes both, which lets the speaking test look harder
    for quiet talkers (``SpeakingTest`` ``band_itds``) without the isolated false alarms that brings.
    """
    ids = np.asarray(ids).reshape(-1)
    speaking = np.asarray(speaking, dtype=bool).reshape(-1)
    if ids.shape != speaking.shape:
        raise ValueError(f"ids and speaking must have one entry per person, got {ids.shape} and {speaking.shape}")
    votes = np.zeros(ids.size)
    seen = np.zeros(ids.size)
    for other_ids, other_speaking in window:
        where = {int(i): k for k, i in enumerate(np.asarray(other_ids).reshape(-1))}
        other = np.asarray(other_speaking, dtype=bool).reshape(-1)
        for n, pid in enumerate(ids):
            k = where.get(int(pid))
            if k is not None:
                seen[n] += 1
                votes[n] += other[k]
    seen = np.maximum(seen, 1.0)
    voted = votes > seen / 2
    share = votes / seen
    return voted, np.where(voted == speaking, np.asarray(probability, dtype=np.float64), share)


class SpeakingVote:
    """:func:`vote_speaking` over a stream: each result is held until the ``frames // 2`` results after it are in,
    then leaves with its states voted over the ``frames`` results centred on it (fewer at the stream's ends); with
    ``trailing`` each result leaves at once, voted over itself and the ``frames - 1`` results before it (low latency).

    ``push(item, ids, speaking, probability)`` returns the results whose vote is complete, as ``(item, speaking,
    probability)``, oldest first (none while the first ``frames // 2`` wait); ``flush()`` returns the rest at the end
    of the stream. ``frames`` is odd; 1 passes every result through at once.
    """

    def __init__(self, frames: int, *, trailing: bool = False) -> None:
        if not (isinstance(frames, int) and frames >= 1 and frames % 2 == 1):
            raise ValueError(f"frames must be an odd number of results >= 1, got {frames!r}")
        self.half = frames // 2
        self.trailing = trailing
        self._window: deque[tuple[object, np.ndarray, np.ndarray, np.ndarray]] = deque()
        self._waiting = 0  # results of the window not yet returned

    @property
    def waiting(self) -> int:
        """Results pushed whose vote is not complete yet."""
        return self._waiting

    def push(self, item: object, ids: np.ndarray, speaking: np.ndarray, probability: np.ndarray
             ) -> list[tuple[object, np.ndarray, np.ndarray]]:
        if self.half == 0:
            return [(item, np.asarray(speaking, dtype=bool), np.asarray(probability, dtype=float))]
        if self.trailing:
            self._window.append((item, np.asarray(ids), np.asarray(speaking, dtype=bool), np.asarray(probability)))
            while len(self._window) > 2 * self.half + 1:
                self._window.popleft()
            voted, prob = vote_speaking(np.asarray(ids), np.asarray(speaking, dtype=bool), np.asarray(probability),
                                        [(w[1], w[2]) for w in self._window])
            return [(item, voted, prob)]
        self._window.append((item, np.asarray(ids), np.asarray(speaking, dtype=bool), np.asarray(probability)))
        self._waiting += 1
        out = [self._release()] if self._waiting > self.half else []
        while len(self._window) > 2 * self.half + 1:
            self._window.popleft()
        return out

    def flush(self) -> list[tuple[object, np.ndarray, np.ndarray]]:
        out = []
        while self._waiting:
            out.append(self._release())
        return out

    def _release(self) -> tuple[object, np.ndarray, np.ndarray]:
        window = list(self._window)
        i = len(window) - self._waiting
        item, ids, speaking, probability = window[i]
        around = [(w[1], w[2]) for w in window[max(i - self.half, 0):i + self.half + 1]]
        voted, prob = vote_speaking(ids, speaking, probability, around)
        self._waiting -= 1
        return item, voted, prob
