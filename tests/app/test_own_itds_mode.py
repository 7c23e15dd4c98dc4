"""Each person's own ITD in the application: the face-guided mode learns it from its own results and hears each
person there; --no-own-itds and the paper's variant keep the mapping."""
from __future__ import annotations

import numpy as np
import pytest

from app.hearing import FaceGuided, Vision
from app.pipeline import PipelineConfig
from avcore.geometry import MicArray, MicPair
from avcore.inference import FaceGuidedHearing

_FACES = np.array([[2.0 * np.sin(np.radians(a)), 0.0, 2.0 * np.cos(np.radians(a))] for a in (-25.0, -13.0)])


def _run(config: PipelineConfig, results: int = 90, mics: MicPair | None = None) -> tuple[np.ndarray, list]:
    """A talker at -25 degrees alone, pulled to 0.8 of the mapping, a silent neighbour at -13: the neighbour's
    states over ``results`` results, and the mean offsets the mode handed the hearing each time. ``mics``: the
    hearing the mode builds for them (default: the nominal pair's, built here)."""
    mode = FaceGuided(config)
    hearing = FaceGuidedHearing(MicArray.from_pair(MicPair())) if mics is None else mode.hearing(mics)
    given: list = []
    real = hearing.step

    def step(*args: object, **options: object) -> object:
        given.append(options.get("mean_offsets_s"))
        return real(*args, **options)  # type: ignore[arg-type]

    hearing.step = step  # type: ignore[method-assign]
    mapped = hearing.array.itd(_FACES).reshape(2, 1)
    rng = np.random.default_rng(4)
    neighbour = []
    for r in range(results):
        itds = (0.8 * mapped[0, 0] + rng.laplace(0.0, 8e-6, 20))[:, None]
        vision = Vision(r / 30, None, np.zeros((2, 4)), _FACES)
        out = mode.step(hearing, vision, itds, np.full(20, r / 30), lambda: (None, None, None))
        neighbour.append(bool(out.speaking[1]))
    return np.array(neighbour), given


def test_the_mode_learns_each_persons_own_itd_and_stops_calling_the_neighbour() -> None:
    neighbour, given = _run(PipelineConfig())
    assert neighbour[:10].any() and not neighbour[-30:].any()
    assert given[0] is not None and not given[0].any()  # nothing known at first
    assert given[-1][0, 0] > 20e-6 and given[-1][1, 0] == 0.0  # the talker's pull learned; the neighbour's none


@pytest.mark.parametrize("config", [PipelineConfig(own_itds=False), PipelineConfig(face_variant="paper")],
                         ids=["--no-own-itds", "paper"])
def test_without_own_itds_and_in_the_papers_variant_each_person_stays_at_the_mapping(config: PipelineConfig
                                                                                     ) -> None:
    neighbour, given = _run(config, results=40)
    assert all(g is None for g in given)
    if config.face_variant == "avhear":
        assert neighbour[-20:].mean() > 0.5  # the pull keeps the neighbour called


def test_a_calibrated_mapping_is_not_learned_on_top_of() -> None:
    """Section 5.3's c1, c0 say where the voices are heard: on a calibrated pair the mode learns no offsets; on the
    nominal one, built the same way, it does."""
    _, given = _run(PipelineConfig(), results=40, mics=MicPair(c1=0.8))
    assert all(g is None for g in given)
    _, given = _run(PipelineConfig(), results=40, mics=MicPair())
    assert given[-1] is not None and given[-1][0, 0] > 5e-6


@pytest.mark.parametrize(("argv", "field", "expected"), [
    ([], "own_itds", True), (["--no-own-itds"], "own_itds", False),
    ([], "dereverb", False), (["--dereverb"], "dereverb", True)])
def test_the_option_reaches_the_config(argv: list[str], field: str, expected: bool) -> None:
    import argparse

    from app.commands.options import add_method_arguments, pipeline_config

    parser = argparse.ArgumentParser()
    add_method_arguments(parser)
    assert getattr(pipeline_config(parser.parse_args(argv), one_camera=False), field) is expected
