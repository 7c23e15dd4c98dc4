"""Tests of app.config: the rig YAML file round trip and its error messages."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from app.config import RigConfig, load_rig, save_rig
from app.errors import UserError
from avcore.geometry import MicPair
from avcore.stereo import StereoRig


def _rig() -> RigConfig:
    k_l = np.array([[530.123456789, 0.0, 330.5], [0.0, 531.0, 240.25], [0.0, 0.0, 1.0]])
    k_r = np.array([[536.0, 0.0, 320.0], [0.0, 535.0, 245.0], [0.0, 0.0, 1.0]])
    stereo = StereoRig((640, 480), k_l, [-0.2, 0.05, 0.001, -0.0005, 0.1], k_r, [-0.18, 0.03, 0.0, 0.0, 0.0],
                       np.eye(3), [-0.12, 0.001, 0.0])
    mics = MicPair(left=(-0.07, 0.01, 0.0), right=(0.07, 0.01, 0.0), speed_of_sound=340.0, c1=1.1, c0=2e-5)
    return RigConfig(stereo=stereo, microphones=mics)


def test_round_trip_is_exact(tmp_path):
    path = tmp_path / "rig.yaml"
    rig = _rig()
    save_rig(path, rig, header="test rig")
    back = load_rig(path)
    assert back.microphones == rig.microphones
    assert back.stereo.to_dict() == rig.stereo.to_dict()
    assert path.read_text().startswith("# test rig\n")


def test_sections_are_optional_but_not_both(tmp_path):
    path = tmp_path / "rig.yaml"
    save_rig(path, RigConfig(microphones=MicPair()))
    assert load_rig(path).stereo is None
    path.write_text("{}\n")
    with pytest.raises(UserError, match="empty"):
        load_rig(path)
    path.write_text("")
    with pytest.raises(UserError, match="empty"):
        load_rig(path)


def _write(tmp_path, data) -> str:
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


@pytest.mark.parametrize(
    ("edit", "key"),
    [
        (lambda d: d.update(extra=1), "'extra'"),
        (lambda d: d["stereo"].update(baseline=0.1), "'stereo.baseline'"),
        (lambda d: d["microphones"].update(c2=1.0), "'microphones.c2'"),
        (lambda d: d["microphones"].update(c1="one"), "'microphones.c1'"),
        (lambda d: d["microphones"].update(c1=True), "'microphones.c1'"),
        (lambda d: d["microphones"].pop("left_m"), "'microphones.left_m'"),
        (lambda d: d["stereo"].update(image_size=[640.5, 480]), r"'stereo.image_size\[0\]'"),
        (lambda d: d["stereo"]["left"].update(camera_matrix=[[1, 2], [3, 4]]), "'stereo.left.camera_matrix'"),
        (lambda d: d["stereo"].update(translation_m=[0, 0, "x"]), r"'stereo.translation_m\[2\]'"),
        (lambda d: d.update(stereo=[1, 2]), "'stereo'"),
    ],
)
def test_unknown_keys_and_wrong_types_name_the_key_and_the_file(tmp_path, edit, key):
    from app.config import rig_to_dict

    data = rig_to_dict(_rig())
    edit(data)
    path = _write(tmp_path, data)
    with pytest.raises(UserError, match=key) as info:
        load_rig(path)
    assert path in str(info.value)


def test_invalid_values_are_reported_with_the_file(tmp_path):
    from app.config import rig_to_dict

    data = rig_to_dict(_rig())
    data["stereo"]["translation_m"] = [0.12, 0.0, 0.0]
    path = _write(tmp_path, data)
    with pytest.raises(UserError, match="swap the two cameras") as info:
        load_rig(path)
    assert path in str(info.value)


def test_missing_file_and_bad_yaml(tmp_path):
    with pytest.raises(UserError, match="not found"):
        load_rig(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("stereo: [1, 2\n")
    with pytest.raises(UserError, match="not valid YAML"):
        load_rig(bad)
    bad.write_text("microphones:\n  left_m: [0, 0\n  right_m: [1, 2]\n")
    with pytest.raises(UserError) as info:
        load_rig(bad)
    assert str(info.value) == f"{bad}: not valid YAML at line 3, column 10: expected ',' or ']', but got ':'"


def test_an_array_section_places_a_preset_on_the_rig_and_round_trips(tmp_path):
    from avcore.geometry import MicArray

    path = tmp_path / "rig.yaml"
    path.write_text("array:\n  preset: nao\n  translation_m: [0.0, -0.05, 0.01]\n  channels: [3, 2, 1, 0]\n")
    rig = load_rig(path)
    placed = MicArray.preset("nao", translation_m=[0.0, -0.05, 0.01])
    np.testing.assert_allclose(rig.array.positions, placed.positions)
    assert rig.array.channels == (3, 2, 1, 0) and rig.array.n_pairs == 6
    save_rig(tmp_path / "again.yaml", rig)
    back = load_rig(tmp_path / "again.yaml")
    assert back.array.positions == rig.array.positions and back.array.channels == rig.array.channels


def test_a_turned_array_keeps_its_pairs_and_their_corrections_through_a_file(tmp_path):
    """A placed array's pairs keep the preset's order (its c1, c0 go with them): a file written from it names its
    pairs, so that read back (where another microphone may now be the more to the left) each correction stays with
    its pair."""
    from avcore.geometry import MicArray

    given = MicArray.preset("respeaker4").turned(np.radians(40.0))
    turned = MicArray(given.positions, given.pairs, given.speed_of_sound, (0.9, 0.91, 0.92, 0.93, 0.94, 0.95),
                      (1e-6, 2e-6, 3e-6, 4e-6, 5e-6, 6e-6), given.channels)
    assert MicArray(turned.positions).pairs != turned.pairs  # the default order would be another one
    save_rig(tmp_path / "rig.yaml", RigConfig(array=turned))
    back = load_rig(tmp_path / "rig.yaml").array
    assert back.pairs == turned.pairs and back.c1 == turned.c1 and back.c0 == turned.c0


@pytest.mark.parametrize(("section", "message"), [
    ("array:\n  preset: nao5\n", "unknown array 'nao5'"),
    ("array:\n  preset: nao\n  positions_m: [[0, 0, 0], [0.1, 0, 0]]\n", "either 'preset'"),
    ("array:\n  positions_m: [[0, 0, 0]]\n", "at least two"),
    ("array:\n  preset: pair\n  channels: [0, 0]\n", "different channel numbers"),
    ("array:\n  preset: nao\n  rotation: [[2, 0, 0], [0, 1, 0], [0, 0, 1]]\n", "rotation matrix"),
    ("array:\n  preset: nao\n  pairs: [[0, 1, 2]]\n", "list of \\[i, j\\]"),
    ("array:\n  preset: nao\n  pairs: [[0, 7]]\n", "below 4"),
])
def test_a_bad_array_section_names_the_file_and_what_to_fix(tmp_path, section, message):
    path = tmp_path / "rig.yaml"
    path.write_text(section)
    with pytest.raises(UserError, match=message) as info:
        load_rig(path)
    assert str(path) in str(info.value)
