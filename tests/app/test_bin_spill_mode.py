"""The bins' claims in the application: with --bin-spill the face-guided mode learns each talker's spill on the
neighbours' bins from its own results with several microphone pairs and hands it to the hearing (one pair, the
default (off) and the paper's variant hand nothing); an array with NAO's geometry is heard with NAO's claim."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from app.hearing import FaceGuided, Vision
from app.pipeline import PipelineConfig
from avcore.geometry import MicArray, MicPair
from avcore.inference import FaceGuidedParams

_FACES = np.array([[2.0 * np.sin(np.radians(a)), 0.0, 2.0 * np.cos(np.radians(a))] for a in (-25.0, -10.0)])


class _Hearing:
    """Hears person 0 alone in every result, the windows' own call; the bins give person 1 a quarter of person
    0's share, more than the fixed claim. Records the spill each step is given."""

    def __init__(self, array: MicArray) -> None:
        self.array = array
        self.given: list = []

    def step(self, xyz: np.ndarray, itds: np.ndarray, *rest: object, mean_offsets_s: object = None,
             bin_spill: object = None) -> SimpleNamespace:
        self.given.append(bin_spill)
        return SimpleNamespace(speaking=np.array([True, False]), probability=np.array([0.9, 0.2]),
                               rescued=np.array([False, False]), bin_share=np.array([0.6, 0.15]))


def _run(config: PipelineConfig, array: MicArray, results: int = 25) -> list:
    mode = FaceGuided(config)
    hearing = _Hearing(array)
    itds = np.tile(array.itd(_FACES[:1]).reshape(1, -1), (20, 1))  # the talker's own ITDs: nothing unexplained
    for r in range(results):
        vision = Vision(r / 30, None, np.zeros((2, 4)), _FACES)
        mode.step(hearing, vision, itds, np.full(20, r / 30), lambda: (None, None, None))
    return hearing.given


def test_the_mode_learns_the_talkers_spill_with_several_pairs() -> None:
    given = _run(PipelineConfig(bin_spill=True), MicArray.preset("respeaker4"))
    assert np.isnan(given[0]).all()  # nothing known at first
    learned = given[-1]
    assert learned.shape == (2, 2) and learned[0, 1] == pytest.approx(0.25)
    assert np.isnan(learned[1, 0])  # person 1 was never heard alone


@pytest.mark.parametrize("config, array", [(PipelineConfig(bin_spill=True), MicArray.from_pair(MicPair())),
                                           (PipelineConfig(), MicArray.preset("respeaker4")),
                                           (PipelineConfig(bin_spill=True, face_variant="paper"),
                                            MicArray.preset("respeaker4"))],
                         ids=["one pair", "the default", "paper"])
def test_one_pair_the_default_and_the_papers_variant_hand_no_spill(config: PipelineConfig, array: MicArray
                                                                     ) -> None:
    assert all(g is None for g in _run(config, array))


@pytest.mark.parametrize(("argv", "expected"), [([], False), (["--no-bin-spill"], False), (["--bin-spill"], True)])
def test_the_option_reaches_the_config(argv: list[str], expected: bool) -> None:
    import argparse

    from app.commands.options import add_method_arguments, pipeline_config

    parser = argparse.ArgumentParser()
    add_method_arguments(parser)
    assert pipeline_config(parser.parse_args(argv), one_camera=False).bin_spill is expected


def test_the_face_guided_mode_hears_naos_head_with_its_own_claim_and_the_papers_variant_as_written() -> None:
    from avcore.speaking import ARRAY_THRESHOLDS
    nao = MicArray.preset("nao")
    ours = FaceGuided(PipelineConfig()).hearing(nao)
    assert ours.params.speaking.bin_claim_share == ARRAY_THRESHOLDS["nao"]["bin_claim_share"]
    assert FaceGuided(PipelineConfig()).hearing(MicArray.preset("respeaker4")).params.speaking.bin_claim_share == 0.1
    pair = MicPair((-0.06, 0.0, 0.0), (0.06, 0.0, 0.0))  # the pair that S1-S5 are heard with
    assert FaceGuided(PipelineConfig()).hearing(pair).params.speaking == FaceGuidedParams().speaking
    paper = FaceGuided(PipelineConfig(face_variant="paper")).hearing(nao)
    assert paper.params.speaking == FaceGuidedParams.paper().speaking
