"""How far each simulated person's mouth is open at each moment: with their own speech, and now and then without.

A talker's mouth opens with the envelope of their own dry speech (the clip's RMS in 30 ms windows, every 10 ms,
over the 90th percentile of their speech's envelope, clipped to [0, 1]) and leads the sound by ``lead_s`` (the
mouth moves 50-100 ms before the sound it shapes: Chandrasekaran et al. 2009, "The natural statistics of audiovisual
speech"). A listener's mouth moves now and then without sound (a smile, chewing, mouthing words): bouts of
0.6-1.5 s, ``bouts_per_min`` a minute on average, opening and closing at 2-4 Hz to 0.3-0.7, never while that person
speaks. One person who speaks covers the mouth with a hand for ``hand_s`` seconds, from a little before one of
their numbers (``covered``). Heads turn now and then (``yaw_rad``): ``turns_per_min`` bouts a person and minute,
each held 1-3 s at 20-60 degrees to either side, turning in and out over 0.3 s. Everything is drawn from the
scenario's seed (the mouths, the hand and the turns each from their own stream), so a scenario's faces are the same
at every run.
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
    hand_s : (shortest, longest) seconds of the hand over one talker's mouth (``(0, 0)``: nobody covers it).
    turns_per_min : head turns per person and minute; max_turn_deg : the widest turn.
    """

    scenario: Scenario
    bank: ClipBank
    lead_s: float = 0.075
    bouts_per_min: float = 4.0
    hand_s: tuple[float, float] = (3.0, 6.0)
    turns_per_min: float = 3.0
    max_turn_deg: float = 60.0
    _speech: np.ndarray = field(init=False, repr=False)
    _silent: np.ndarray = field(init=False, repr=False)
    _covered: np.ndarray = field(init=False, repr=False)
    _yaw: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not 0.0 <= self.lead_s <= 0.3:
            raise ValueError(f"lead_s must be in [0, 0.3] seconds, got {self.lead_s!r}")
        if not 0.0 <= self.hand_s[0] <= self.hand_s[1]:
            raise ValueError(f"hand_s must be (shortest, longest) seconds with 0 <= shortest <= longest, got "
                             f"{self.hand_s!r}")
        if not 20.0 <= self.max_turn_deg <= 90.0:
            raise ValueError(f"max_turn_deg must be in [20, 90] degrees (turns are drawn from 20), got "
                             f"{self.max_turn_deg!r}")
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
        self._covered = self._hand(t)
        self._yaw = self._turns(t)

    def _hand(self, t: np.ndarray) -> np.ndarray:
        sc, covered = self.scenario, np.zeros((len(self.scenario.actors), t.size), bool)
        speech = [e for e in sc.events if e.kind == "speech"]
        if not speech or not 0.0 < self.hand_s[1]:
            return covered
        rng = np.random.default_rng([sc.seed, 42])
        e = speech[rng.integers(len(speech))]
        start = e.start_s - rng.uniform(0.5, 1.5)
        covered[e.actor] = (t >= start) & (t < start + rng.uniform(*self.hand_s))
        return covered

    def _turns(self, t: np.ndarray) -> np.ndarray:
        sc, yaw = self.scenario, np.zeros((len(self.scenario.actors), t.size))
        rng = np.random.default_rng([sc.seed, 43])
        for i in range(len(sc.actors)):
            for _ in range(rng.poisson(self.turns_per_min * sc.duration_s / 60.0)):
                start, hold = rng.uniform(0.0, sc.duration_s), rng.uniform(1.0, 3.0)
                angle = np.deg2rad(rng.uniform(20.0, self.max_turn_deg)) * rng.choice([-1.0, 1.0])
                ramp = np.clip(np.minimum(t - start, start + hold - t) / 0.3, 0.0, 1.0)
                bout = angle * 0.5 * (1.0 - np.cos(np.pi * ramp))
                yaw[i] = np.where(np.abs(bout) > np.abs(yaw[i]), bout, yaw[i])
        return yaw

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

    def covered(self, t: float) -> np.ndarray:
        """(N,) bool: whose mouth a hand covers at ``t``."""
        return self._at(self._covered, t)

    def yaw_rad(self, t: float) -> np.ndarray:
        """(N,) radians: how far each actor's head is turned at ``t`` (about the vertical axis)."""
        return self._at(self._yaw, t)
