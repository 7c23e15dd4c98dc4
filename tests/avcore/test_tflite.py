"""avcore.tflite: the face models give the same answers by OpenCV's DNN module and by LiteRT."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import cv2
import numpy as np
import pytest

from avcore.blazeface import SHORT_RANGE, BlazeFaceDetector, BlazeFaceNet
from avcore.facemesh import FaceMesh
from avcore.tflite import TfliteNet, litert_available


@pytest.fixture(scope="module")
def models() -> Path:
    from app.errors import UserError
    from app.models import blazeface_model

    if not litert_available():
        pytest.skip("LiteRT is not installed (pip install ai-edge-litert)")
    try:
        return blazeface_model().parent
    except UserError as exc:
        pytest.skip(str(exc))


def test_an_unknown_runtime_and_an_unreadable_model_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="runtime must be one of opencv, litert"):
        TfliteNet(tmp_path / "m.tflite", "m.tflite", runtime="onnx")
    bad = tmp_path / "bad.tflite"
    bad.write_bytes(b"not a model")
    for runtime in ("opencv", "litert") if litert_available() else ("opencv",):
        with pytest.raises(ValueError, match="cannot read it as a TFLite model .*; give m.tflite"):
            TfliteNet(bad, "m.tflite", runtime=runtime)


@pytest.mark.shared_data
def test_both_runtimes_find_the_same_faces_and_landmarks(models: Path, shared_data: Path) -> None:
    """The labelled photographs: the full range (whole image and tiles, a batch of five), the short range on
    squares around the faces (a batch), and the face mesh: boxes, keypoints and landmarks within 0.05 px, scores
    within 1e-4, by OpenCV's DNN and by LiteRT."""
    full = {rt: BlazeFaceDetector(models / "face_detection_full_range.tflite", runtime=rt)
            for rt in ("opencv", "litert")}
    short = {rt: BlazeFaceNet(models / SHORT_RANGE.file, SHORT_RANGE, rt) for rt in ("opencv", "litert")}
    mesh = {rt: FaceMesh(models / "face_landmark.tflite", runtime=rt) for rt in ("opencv", "litert")}
    faces = 0
    for image in ET.parse(shared_data / "faces" / "testing.xml").getroot().iter("image"):
        img = cv2.imread(str(shared_data / "faces" / image.get("file")))
        a, b = (full[rt].detect_faces(img) for rt in ("opencv", "litert"))
        assert len(a) == len(b)
        np.testing.assert_allclose(b.boxes, a.boxes, atol=0.05)
        np.testing.assert_allclose(b.keypoints, a.keypoints, atol=0.05)
        np.testing.assert_allclose(b.scores, a.scores, atol=1e-4)
        squares = [(int(x - w), int(y - h), int(3 * w)) for x, y, w, h in a.boxes]
        sa, sb = (short[rt].run(img, squares) for rt in ("opencv", "litert"))
        np.testing.assert_allclose(sb.boxes, sa.boxes, atol=0.05)
        ma, mb = (mesh[rt].run(img, a.boxes, a.keypoints[:, :2]) for rt in ("opencv", "litert"))
        np.testing.assert_allclose(mb.landmarks, ma.landmarks, atol=0.05)
        faces += len(a)
    assert faces >= 15
