"""avcore.voices: a voice no visible face explains is found in the direction it comes from, with ITD vectors made
here from explicit distances to NAO's four microphones (not through the array's own mapping), and nothing else is."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.geometry import MicArray
from avcore.voices import VoiceTracks, direction_vector, unexplained_voice

SPEED = 343.0


def _itds(array: MicArray, source: np.ndarray, n: int, noise_s: float, rng: np.random.Generator) -> np.ndarray:
    """n ITD vectors of a source at ``source`` (metres): each pair's delay from the distances to its two
    microphones written out (t_i - t_j), plus noise."""
    mics = np.asarray(array.positions)
    out = []
    for i, j in array.pairs:
        delay = (np.linalg.norm(source - mics[i]) - np.linalg.norm(source - mics[j])) / SPEED
        out.append(delay + rng.normal(0.0, noise_s, n))
    return np.stack(out, axis=1)


@pytest.mark.parametrize("azimuth_deg", [-120.0, -53.0, 70.0, 160.0])
def test_a_voice_out_of_view_is_found_where_it_is_even_behind(azimuth_deg: float) -> None:
    """NAO's four microphones (front, back, left, right) tell front from back: a talker 2.5 m away at any azimuth,
    with two faces in view elsewhere, is found within 5 degrees."""
    rng = np.random.default_rng(3)
    array = MicArray.preset("nao", speed_of_sound=SPEED)
    talker = 2.5 * direction_vector(np.radians(azimuth_deg), 0.0)
    faces = np.array([[0.6, -0.1, 2.0], [-0.3, -0.1, 2.2]])
    itds = np.vstack([_itds(array, talker, 12, 5e-6, rng), _itds(array, faces[0], 6, 5e-6, rng)])
    voice = unexplained_voice(itds, array, faces)
    assert voice is not None and voice.windows >= 10
    assert abs(np.degrees(np.angle(np.exp(1j * (voice.azimuth_rad - np.radians(azimuth_deg)))))) < 5.0
    assert voice.elevation_rad is None  # NAO's microphones span 5 cm of height: no elevation told


def test_what_the_faces_explain_is_no_voice() -> None:
    rng = np.random.default_rng(4)
    array = MicArray.preset("nao", speed_of_sound=SPEED)
    faces = np.array([[0.6, -0.1, 2.0], [-0.3, -0.1, 2.2]])
    itds = np.vstack([_itds(array, f, 10, 5e-6, rng) for f in faces])
    assert unexplained_voice(itds, array, faces) is None
    # too few windows agree: no voice either
    far = 2.5 * direction_vector(np.radians(-90.0), 0.0)
    assert unexplained_voice(np.vstack([itds, _itds(array, far, 3, 5e-6, rng)]), array, faces) is None
    # a face's own ITDs off its mapping (30 us on every pair) point near that face: not a voice of their own
    off = _itds(array, faces[0], 10, 5e-6, rng) + 30e-6
    assert unexplained_voice(off, array, faces) is None
    # and one pair cannot tell a direction
    assert unexplained_voice(itds[:, :1], MicArray.from_pair(array.pair(0)), faces) is None


def test_a_voice_keeps_its_id_while_it_stays_and_is_remembered() -> None:
    """A voice is reported once heard in three results in a row, and keeps its id while heard within 20 degrees of
    where it was in the last 10 s."""
    tracks = VoiceTracks()
    from avcore.voices import VoiceDirection

    def at(deg: float) -> VoiceDirection:
        return VoiceDirection(np.radians(deg), None, 5)

    def heard(t: float, deg: float) -> int | None:
        """A result without a voice, then three with it, 1/30 s apart, from ``t``: the id the third one reports."""
        assert tracks.update(t - 1 / 30, None) is None
        for k in range(2):
            assert tracks.update(t + k / 30, at(deg)) is None  # not confirmed yet
        return tracks.update(t + 2 / 30, at(deg))

    assert heard(0.0, -53.0) == 0
    assert heard(5.0, -60.0) == 0  # 7 degrees off, 5 s later: the same voice
    assert heard(5.5, 90.0) == 1  # elsewhere: another
    assert heard(16.0, -55.0) == 2  # 11 s unheard: forgotten, a new id
    assert tracks.update(16.1, at(-55.0)) == 2  # still in a row: reported at once
    assert tracks.update(16.2, None) is None  # a result without it breaks the row: three in a row again
    assert tracks.update(16.3, at(-55.0)) is None and tracks.update(16.4, at(-56.0)) is None
    assert tracks.update(16.5, at(-55.0)) == 2


def test_voices_draw_their_ids_from_the_peoples_tracker() -> None:
    """Given the people's tracker's ``new_id``, a new voice takes the next number no person has, and a person seen
    after it another: people and voices never share an id."""
    from avcore.tracking import NearestTracker
    from avcore.voices import VoiceDirection

    people, tracks = NearestTracker(), VoiceTracks(confirm=1)
    assert people.update([[0.0, 0.0, 2.0], [1.0, 0.0, 2.0]], 0.0).tolist() == [0, 1]
    assert tracks.update(0.0, VoiceDirection(np.radians(-53.0), None, 5), people.new_id) == 2
    assert tracks.update(0.1, VoiceDirection(np.radians(-50.0), None, 5), people.new_id) == 2  # the same voice
    assert people.update([[0.0, 0.0, 2.0], [1.0, 0.0, 2.0], [-1.0, 0.0, 2.0]], 0.2).tolist() == [0, 1, 3]
