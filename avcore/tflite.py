"""TFLite models (MediaPipe's face detectors and face mesh) run by OpenCV's DNN module or by LiteRT.

OpenCV's DNN module (``cv2.dnn.readNetFromTFLite``; on OpenCV 5 its classic engine) is the default: avhear needs
OpenCV anyway. LiteRT (the ``ai-edge-litert`` package, Google's TFLite runtime with its XNNPACK kernels, no
TensorFlow) is optional and runs these models faster (``python benchmarks/vision_speed.py`` times
both). Both take the same crops and give the same outputs to within float rounding.

:class:`TfliteNet` takes square BGR uint8 crops of the model's input size and gives the model's outputs for the
batch; each model's own module decodes them.
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

import cv2
import numpy as np

__all__ = ["RUNTIMES", "LITERT_HINT", "TfliteNet", "litert_available"]

RUNTIMES = ("opencv", "litert")
LITERT_HINT = "pip install ai-edge-litert"


def litert_available() -> bool:
    """Whether LiteRT is installed (found without importing it)."""
    try:
        return importlib.util.find_spec("ai_edge_litert") is not None
    except (ImportError, ValueError):
        return False


def _read_opencv(model: str | Path, expected: str) -> cv2.dnn.Net:
    reader = cv2.dnn.readNetFromTFLite
    try:
        try:
            return reader(str(model), engine=cv2.dnn.ENGINE_CLASSIC)  # type: ignore[attr-defined]
        except (AttributeError, TypeError):
            return reader(str(model))
    except cv2.error as exc:
        raise ValueError(f"{model}: OpenCV cannot read it as a TFLite model ({str(exc).strip()[-80:]}); "
                         f"give {expected}") from None


class TfliteNet:
    """One TFLite model, ``runtime`` "opencv" or "litert" (one thread: the pipeline's other threads share the cores).

    ``forward(crops)`` -> the model's outputs, each an array whose leading dimension holds the batch as the runtime
    gives it: OpenCV runs the whole batch at once and may fold it into a later axis where the model reshapes with a
    batch of 1 (see :func:`avcore.blazeface.per_image`); LiteRT runs the crops one by one and stacks each output,
    (batch, ...) with the model's own leading 1 dropped. A file the runtime cannot read is a ValueError naming
    ``expected``; LiteRT asked for and absent is an ImportError that says how to install it.
    """

    def __init__(self, model: str | Path, expected: str, runtime: str = "opencv") -> None:
        if runtime not in RUNTIMES:
            raise ValueError(f"runtime must be one of {', '.join(RUNTIMES)}, got {runtime!r}")
        self.runtime = runtime
        if runtime == "opencv":
            self._net = _read_opencv(model, expected)
            self._names = self._net.getUnconnectedOutLayersNames()
            return
        try:
            from ai_edge_litert.interpreter import Interpreter
        except ImportError:
            raise ImportError(f"the LiteRT runtime is not installed: {LITERT_HINT}") from None
        try:
            self._interpreter = Interpreter(model_path=str(model), num_threads=1)
            self._interpreter.allocate_tensors()
        except (ValueError, RuntimeError) as exc:
            raise ValueError(f"{model}: LiteRT cannot read it as a TFLite model ({str(exc).strip()[-80:]}); "
                             f"give {expected}") from None
        self._input = self._interpreter.get_input_details()[0]["index"]
        self._outputs = [d["index"] for d in self._interpreter.get_output_details()]

    def forward(self, crops: list[np.ndarray]) -> list[np.ndarray]:
        """crops : square BGR uint8 images of the model's input size -> outputs (RGB in [-1, 1] as MediaPipe feeds
        them)."""
        if self.runtime == "opencv":
            side = crops[0].shape[0]
            blob = cv2.dnn.blobFromImages(crops, 1.0 / 127.5, (side, side), (127.5, 127.5, 127.5), swapRB=True)
            self._net.setInput(blob)
            return list(self._net.forward(self._names))
        per_crop: list[list[np.ndarray]] = []
        for crop in crops:
            rgb = cv2.cvtColor(crop, cv2.COLOR_BGR2RGB).astype(np.float32) / 127.5 - 1.0
            self._interpreter.set_tensor(self._input, rgb[None])
            self._interpreter.invoke()
            per_crop.append([self._interpreter.get_tensor(i)[0].copy() for i in self._outputs])
        return [np.stack(outs) for outs in zip(*per_crop)]
