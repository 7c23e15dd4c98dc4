"""sim.body_truth: where a rendered person is for a motion-guided method, the centre of the visible moving body."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from avcore.stereo import StereoRig
from sim.body_truth import interval_times, visible_moving_centres
from sim.face_textures import drawn_face_texture
from sim.render import Person

RIG = StereoRig.ideal(554.0, (640, 480), 0.12)
TIMES = interval_times(1.0, 0.4)


def _centre(*people: Person) -> np.ndarray:
    return visible_moving_centres(RIG, [list(people)] * len(TIMES), TIMES)


def test_the_instants_span_the_interval_around_its_stamp():
    np.testing.assert_allclose(interval_times(1.0, 0.4), [0.84, 0.92, 1.0, 1.08, 1.16])


def test_a_flat_person_nodding_is_at_the_head_and_a_still_one_at_the_face():
    nodding = Person(drawn_face_texture(), (0.2, -0.1, 2.0), nod_rad=0.2, nod_hz=2.0)
    np.testing.assert_allclose(_centre(nodding)[0], nodding.position, atol=0.03)
    still = replace(nodding, nod_rad=0.0)
    np.testing.assert_allclose(_centre(still)[0], still.position, atol=1e-12)


def test_a_talker_with_a_body_is_at_the_chest_above_the_table():
    """The moving body of a talker behind a table: head, shoulders, arms and hands, nothing below the table."""
    talker = Person(drawn_face_texture(), (0.2, -0.15, 2.0), nod_rad=0.12, nod_hz=2.0, arms=True, gesture_m=0.15,
                    table=True)
    c = _centre(talker)[0]
    table_top_y = talker.props(0.0)[0][0][0, 1]
    assert abs(c[0] - 0.2) < 0.05 and talker.position[1] + 0.1 < c[1] < table_top_y
    # without the table the lower torso and the legs are seen, but the torso rocks at the shoulders, not at the hips,
    # and the legs stay: the centre comes down a little, not to the hips (0.74 m below the face)
    free = _centre(replace(talker, table=False))[0]
    assert c[1] < free[1] < talker.position[1] + 0.4


def test_only_the_visible_parts_count():
    """A person half out of the image is at the centre of their visible half; one hidden behind another is at the
    visible rest."""
    talker = Person(drawn_face_texture(), (0.0, -0.15, 2.0), nod_rad=0.12, nod_hz=2.0, arms=True, gesture_m=0.15)
    alone = _centre(talker)[0]
    edge_x = 2.0 * 320 / 554.0  # the left image's right edge at 2 m
    at_edge = replace(talker, position=(edge_x, -0.15, 2.0))
    assert _centre(at_edge)[0][0] < edge_x - 0.05  # the part beyond the edge is not counted
    # a nearer person in front of the left half of the body
    screen = Person(drawn_face_texture(), (-0.25, -0.15, 1.2), nod_rad=0.12, nod_hz=2.0, arms=True, gesture_m=0.15)
    behind = _centre(talker, screen)[0]
    assert behind[0] > alone[0] + 0.03


def test_the_people_must_be_given_at_every_instant():
    with pytest.raises(ValueError, match="at each instant"):
        visible_moving_centres(RIG, [[]], TIMES)


class _Plate:
    """A person of one square part 0.4 m wide facing the camera, its centre at ``centre`` (what
    :func:`labelled_point_means` reads of a person: its parts)."""

    def __init__(self, centre: tuple[float, float, float]) -> None:
        x, y, z = centre
        self.corners = np.array([[x - 0.2, y - 0.2, z], [x + 0.2, y - 0.2, z], [x + 0.2, y + 0.2, z],
                                 [x - 0.2, y + 0.2, z]])

    def parts(self, t: float) -> list:
        return [("shirt", self.corners, None)]


def test_the_papers_truth_is_the_mean_of_each_persons_own_points():
    """Points on or near a person (a stereo error of 10 cm in depth) are theirs; one 40 cm off everybody is an
    outlier of the room; a person without points has no truth (NaN). The mean is of the points as found."""
    from sim.body_truth import LABEL_M, labelled_point_means

    people = [_Plate((-0.5, 0.0, 2.0)), _Plate((0.6, 0.0, 3.0)), _Plate((0.0, 0.0, 6.0))]
    points = np.array([[-0.6, 0.1, 2.0], [-0.4, -0.1, 2.1],  # the first person, one 10 cm behind the plate
                       [0.5, 0.0, 2.95], [0.7, 0.1, 3.0], [0.6, 0.2, 3.05],  # the second
                       [0.0, 0.0, 2.4]])  # 40 cm in front of the first's plate: nobody's
    assert LABEL_M < 0.4
    truth = labelled_point_means(points, [people] * len(TIMES), TIMES)
    np.testing.assert_allclose(truth[0], [-0.5, 0.0, 2.05])
    np.testing.assert_allclose(truth[1], [0.6, 0.1, 3.0])
    assert np.isnan(truth[2]).all()
    assert np.isnan(labelled_point_means(np.empty((0, 3)), [people], [1.0])).all()
    with pytest.raises(ValueError, match="the people at each instant"):
        labelled_point_means(points, [people], TIMES)
