from __future__ import annotations

import os
import socket
from pathlib import Path

import pytest

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"

# The suite starts about fifty `python -m app` processes: with PYTHONDONTWRITEBYTECODE set (as on some CI images)
# each compiled the whole package again; they share the first one's bytecode instead (docs/experiments.md).
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
# The README's workers (`-n 3`) already more than fill two cores: each process's BLAS and OpenMP keep to one thread
# instead of a pool that spins beside the other workers (docs/experiments.md). A developer's own setting stays.
for _threads in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_threads, "1")


@pytest.fixture
def shared_data() -> Path:
    """The real third-party data in ../shared/data; the test skips when it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"../shared/data not found at {SHARED_DATA}")
    return SHARED_DATA


@pytest.fixture(scope="session")
def load_benchmark():  # noqa: ANN201
    """A script of ``benchmarks/`` loaded as a module by its name (the folder is no package)."""
    import importlib.util

    def load(name: str):  # noqa: ANN202
        path = Path(__file__).resolve().parents[1] / "benchmarks" / f"{name}.py"
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module

    return load


@pytest.fixture(scope="session", autouse=True)
def _own_bus_rendezvous() -> None:
    """The suite's avhear processes meet on a free loopback port of their own (AVHEAR_BUS_PORT), not on 7448, where
    a developer's own `avhear sensors` may be running."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    os.environ.setdefault("AVHEAR_BUS_PORT", str(port))
    # and the rmw_zenoh router they join is the suite's own (tests/app/conftest.py's rmw_router), not 7447, where a
    # developer's ROS 2 system may run: processes of one test then never meet those another test left behind
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        router = s.getsockname()[1]
    os.environ.setdefault("AVHEAR_ROS_ROUTER", f"tcp/127.0.0.1:{router}")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Tests marked ``haar`` are about OpenCV 4's Haar cascade: skipped, with the reason, on an OpenCV without it."""
    import cv2

    if hasattr(cv2, "CascadeClassifier"):
        return
    skip = pytest.mark.skip(reason=f"OpenCV {cv2.__version__} has no Haar cascades (OpenCV 5)")
    for item in items:
        if "haar" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def face_finder():  # noqa: ANN201
    """A face detector for tests about something other than detection: BlazeFace (the full range on the whole image
    and 2 x 2 tiles, as the default's scan) when its model is installed, else Haar's cascade; skipped without
    either."""
    import cv2

    from app.errors import UserError
    from app.models import blazeface_model
    from avcore.blazeface import BlazeFaceDetector

    try:
        return BlazeFaceDetector(blazeface_model(), tiles=2)
    except UserError as exc:
        if not hasattr(cv2, "CascadeClassifier"):
            pytest.skip(str(exc))
    from avcore.faces import HaarFaceDetector

    return HaarFaceDetector()
