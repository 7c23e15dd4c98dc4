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
