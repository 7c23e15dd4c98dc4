"""How far each simulated person's mouth is open at each moment: with their own speech, and now and then without.

A talker's mouth opens with the envelope of their own dry speech (the clip's RMS in 30 ms windows, every 10 ms,
over the 90th percentile of their speech's envelope, clipped to [0, 1]) and leads the sound by ``lead_s`` (the
mouth moves 50-100 ms before the sound it shapes: Chandrasekaran et al. 2009, "The natural statistics of audiovisual
speech"). A listener's mouth moves now and then without sound (a smile, chewing, mouthing words): bouts of
0.6-1.5 s, ``bouts_per_min`` a minute on average, opening and closing at 2-4 Hz to 0.3-0.7, never while that person
speaks. Everything is drawn from the scenario's seed, so a scenario's mouths are the same at every run.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sim.scenario import ClipBank, Scenario

__all__ = ["MouthTracks"]

HOP_S = 0.01
WINDOW_S = 0.03


@dataclass(eq=False)
class MouthTracks:
    """``opening(t)`` -> (N,) in [0, 1] for the scenario's N actors; ``speech_opening`` and ``silent_opening`` apart.

    lead_s : how long the mouth moves before the sound. bouts_per_min : silent mouth movements per person and minute.
    """

    scenario: Scenario
    bank: ClipBank
    lead_s: float = 0.075
    bouts_per_min: float = 4.0
    _speech: np.ndarray = field(init=False, repr=False)
    _silent: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not 0.0 <= self.lead_s <= 0.3:
            raise ValueError(f"lead_s must be in [0, 0.3] seconds, got {self.lead_s!r}")
        sc, fs = self.scenario, self.bank.samplerate_hz
        n_hops = int(np.ceil(sc.duration_s / HOP_S)) + 1
        self._speech = np.zeros((len(sc.actors), n_hops))
        self._silent = np.zeros((len(sc.actors), n_hops))
        window = max(1, round(WINDOW_S * fs))
        for i, actor in enumerate(sc.actors):
            dry = np.zeros(round(sc.duration_s * fs) + window)
            for e in sc.events:
                if e.actor == i and e.kind == "speech":
                    clip = self.bank.clip(actor.voice, e.clip)
                    a = round(e.start_s * fs)
                    n = max(0, min(clip.size, dry.size - a))
                    dry[a:a + n] += clip[:n]
            power = np.convolve(dry.astype(np.float64) ** 2, np.ones(window) / window, mode="same")
            env = np.sqrt(power[np.minimum(np.arange(n_hops) * round(HOP_S * fs), power.size - 1)])
            voiced = env[env > 1e-6]
            if voiced.size:
                self._speech[i] = np.clip(env / np.percentile(voiced, 90), 0.0, 1.0)
        rng = np.random.default_rng([sc.seed, 41])
        t = np.arange(n_hops) * HOP_S
        for i in range(len(sc.actors)):
            for _ in range(rng.poisson(self.bouts_per_min * sc.duration_s / 60.0)):
                start, length = rng.uniform(0.0, sc.duration_s), rng.uniform(0.6, 1.5)
                hz, depth = rng.uniform(2.0, 4.0), rng.uniform(0.3, 0.7)
                inside = (t >= start) & (t < start + length)
                self._silent[i, inside] = depth * 0.5 * (1 - np.cos(2 * np.pi * hz * (t[inside] - start)))
            speaking = sc.speaking_at(t, hold_s=0.3)[:, i] if len(sc.actors) else np.zeros(0, bool)
            self._silent[i, speaking] = 0.0  # a talker's mouth follows their speech alone

    def _at(self, track: np.ndarray, t: float) -> np.ndarray:
        k = int(np.clip(round(t / HOP_S), 0, track.shape[1] - 1))
        return track[:, k]

    def speech_opening(self, t: float) -> np.ndarray:
        """(N,) the opening that each actor's own speech gives at ``t`` (led by ``lead_s``)."""
        return self._at(self._speech, t + self.lead_s)

    def silent_opening(self, t: float) -> np.ndarray:
        """(N,) the opening of the mouth's movements without sound at ``t``."""
        return self._at(self._silent, t)

    def opening(self, t: float) -> np.ndarray:
        """(N,) in [0, 1]: how far each actor's mouth is open at ``t`` seconds."""
        return np.maximum(self.speech_opening(t), self.silent_opening(t))
