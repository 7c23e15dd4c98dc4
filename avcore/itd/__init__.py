"""Interaural time differences (paper section 5.1): ``extract_itds`` (batch) and ``PairsItdStream`` (streaming, on
every pair of a microphone array; one pair is an array of one pair, ``MicArray.from_pair``).

Methods, one module each, registered by name in ``METHODS``:

- ``"correlogram"``: summary cross-correlogram over a gammatone filterbank (Christensen et al., 2007), the paper's.
- ``"gcc-phat"``: generalised cross-correlation with the phase transform.
- ``"correlogram-robust"``, ``"gcc-phat-robust"``: the same two, computed over short frames weighted by
  signal-to-noise ratio, onsets (precedence), coherence and coherent-to-diffuse ratio (and, for
  ``gcc-phat-robust``, whole frames by their signal-to-noise ratio and spectral flatness, after a linear-prediction
  dereverberation of the frames' spectra); stateful (a noise floor, the dereverberation's filters), so they run
  frame by frame (``avcore.itd.robust``). Much better in reverberant, noisy rooms: see
  ``benchmarks/itd_accuracy.py``.

Sign (docs/architecture.md): ITD = t_left - t_right, positive for a source on the right, as ``MicPair.itd``.
"""
from __future__ import annotations

from ._base import ItdMethod
from ._extract import METHODS, ItdTrack, extract_itds, geometry_options, gives_frame_itds, make_method
from .correlogram import Correlogram
from .gcc_phat import GccPhat
from .pairs import FrameBins, PairsItdStream, join_pairs
from .robust import RobustCorrelogram, RobustGccPhat

__all__ = [
           "METHODS",
           "Correlogram",
           "FrameBins",
           "GccPhat",
           "ItdMethod",
           "ItdTrack",
           "PairsItdStream",
           "RobustCorrelogram",
           "RobustGccPhat",
           "extract_itds",
           "geometry_options",
           "gives_frame_itds",
           "join_pairs",
           "make_method",
]
