"""sim.mouths and the rendered mouths: a talker's mouth opens with their own speech a little before the sound, a
listener's now and then without sound, and the face mesh reads the difference in the rendered images."""
from __future__ import annotations

import numpy as np
import pytest

from sim.mouths import HOP_S, MouthTracks
from sim.render import MOUTH_MAX_GAP, drawn_face_texture
from sim.scenario import Actor, Path3D, Scenario, SoundEvent, synthetic_clip_bank


def _scenario(events: list[SoundEvent], duration_s: float = 6.0) -> Scenario:
    actors = tuple(Actor(f"p{i}", Path3D.still((x, 0.0, 2.0)), voice=i, face=i)
                   for i, x in enumerate((-0.5, 0.5)))
    return Scenario("test", "", duration_s, 3, actors, tuple(events))


def test_a_talkers_mouth_follows_their_speech_and_leads_it() -> None:
    bank = synthetic_clip_bank(seed=1)
    clip_s = bank.durations_s[0][0]
    tracks = MouthTracks(_scenario([SoundEvent(0, "speech", 1.0, 1.0 + clip_s, clip=0)]), bank, bouts_per_min=0.0)
    t = np.arange(0.0, 6.0, HOP_S)
    speech = np.array([tracks.speech_opening(x) for x in t])
    inside = (t > 0.9) & (t < 1.0 + clip_s)
    # fully open at the loud part (the envelope over its 90th percentile), shut well before and after the clip
    assert speech[inside, 0].max() == 1.0 and speech[(t < 0.85) | (t > 1.0 + clip_s + 0.1), 0].max() == 0.0
    assert speech[:, 1].max() == 0.0  # the other person says nothing, and nobody mouths (no bouts)
    # the mouth leads: its opening at t is the sound's envelope at t + lead_s
    first_open = t[np.argmax(speech[:, 0] > 0.05)]
    assert 1.0 - tracks.lead_s - 0.02 <= first_open <= 1.0 - tracks.lead_s + 0.05


def test_listeners_mouth_now_and_then_but_never_over_their_own_speech() -> None:
    bank = synthetic_clip_bank(seed=1)
    events = [SoundEvent(1, "speech", s, s + bank.durations_s[1][0], clip=0) for s in np.arange(0.5, 58, 2.0)]
    scenario = _scenario(events, duration_s=60.0)
    tracks = MouthTracks(scenario, bank, bouts_per_min=6.0)
    t = np.arange(0.0, 60.0, HOP_S)
    silent = np.array([tracks.silent_opening(x) for x in t])
    assert 0.02 < np.mean(silent[:, 0] > 0.05) < 0.5  # person 0 mouths now and then, not all the time
    talking = scenario.speaking_at(t, hold_s=0.3)[:, 1]
    assert silent[talking, 1].max() == 0.0 and silent[~talking, 1].max() > 0.2
    again = MouthTracks(scenario, bank, bouts_per_min=6.0)  # the scenario's seed fixes them
    assert all(np.array_equal(tracks.opening(x), again.opening(x)) for x in t[::50])
    with pytest.raises(ValueError, match="lead_s"):
        MouthTracks(scenario, bank, lead_s=0.5)


def test_an_open_mouth_drops_the_jaw_and_shows_the_cavity() -> None:
    face = drawn_face_texture()
    assert face.with_mouth(0.0) is face.image
    opened = face.with_mouth(1.0)
    bx, by, bw, bh = face.face_box
    fx, fy, fw = face.mouth_in_box
    cx, cy, width = int(bx + fx * bw), int(by + fy * bh), fw * bw
    changed = np.abs(opened.astype(int) - face.image.astype(int)).sum(axis=2) > 30
    rows = np.flatnonzero(changed.any(axis=1))
    assert rows.min() >= cy - 2 and rows.max() <= by + 1.2 * bh  # below the mouth's line, above the neck
    cols = np.flatnonzero(changed.any(axis=0))
    assert abs(0.5 * (cols.min() + cols.max()) - cx) < 0.1 * bw  # around the mouth
    dark = opened[int(cy + 0.5 * MOUTH_MAX_GAP * width), cx].astype(int).sum()
    assert dark < face.image[int(cy + 0.5 * MOUTH_MAX_GAP * width), cx].astype(int).sum() - 100


@pytest.mark.shared_data
def test_the_face_mesh_reads_who_moves_their_lips_in_the_rendered_room() -> None:
    """S2 with moving mouths: the variation of each visible face's measured mouth opening over 0.4 s (the face
    mesh on the rendered left images) is larger while the person speaks than while they do not, listeners'
    silent mouthing included (area under the ROC curve over 0.8)."""
    from app.errors import UserError
    from app.models import facemesh_model
    from app.sources.sim import SimSource
    from avcore.facemesh import FaceMesh, mouth_opening

    try:
        mesh = FaceMesh(facemesh_model())
    except UserError as exc:
        pytest.skip(str(exc))
    source = SimSource.from_preset("S2", duration_s=8.0, seed=1, lips=True)
    if source.meta["faces"] != "faces":
        pytest.skip("the photographed faces of ../shared/data are not here")
    openings, speaking, visible = [], [], []
    for k in range(len(source.frame_stamps_s)):
        left, _ = source._images(k)
        truth = source.truth(k)
        openings.append(mouth_opening(mesh.run(left, np.nan_to_num(truth.boxes_left)).landmarks))
        speaking.append(truth.speaking)
        visible.append(truth.visible)
    o, s, v = np.array(openings), np.array(speaking), np.array(visible)
    spread = np.array([np.nanstd(o[k - 12:k + 1], axis=0) for k in range(12, len(o))])
    s, v = s[12:], v[12:] & np.isfinite(spread)
    pos, neg = spread[s & v], spread[~s & v]
    auc = (pos[:, None] > neg[None, :]).mean() + 0.5 * (pos[:, None] == neg[None, :]).mean()
    assert auc > 0.8, auc
