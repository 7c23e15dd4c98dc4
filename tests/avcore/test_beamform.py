"""The steered voices' building blocks on free-field sound: what each one promises, checked on plane facts."""
from __future__ import annotations

import numpy as np

from avcore import beamform as bf
from avcore.geometry import MicArray

ARRAY = np.asarray(MicArray.preset("respeaker4").positions)
FREQS = np.linspace(0.0, 8000.0, 257)


def _free_field(source_xyz: np.ndarray, spectrum: np.ndarray) -> np.ndarray:
    """(Q, F, T): what the microphones hear of ``spectrum`` (F, T) at the first microphone, in free field."""
    return bf.steering(ARRAY, source_xyz, FREQS)[:, :, None].transpose(1, 0, 2) * spectrum[None]


def test_steering_is_the_direct_paths_delay_against_the_first_microphone() -> None:
    s = np.array([1.0, 0.0, 1.5])
    a = bf.steering(ARRAY, s, FREQS)
    assert a.shape == (257, 4) and np.allclose(a[:, 0], 1.0) and np.allclose(np.abs(a), 1.0)
    d = np.linalg.norm(ARRAY - s, axis=1)
    np.testing.assert_allclose(np.angle(a[10]), np.angle(np.exp(-2j * np.pi * FREQS[10] * (d - d[0]) / 343.0)))


def test_delay_and_sum_passes_the_steered_voice_and_mvdr_cancels_another() -> None:
    """A talker ahead and another 60 degrees to the side, each a random spectrum: delay-and-sum at the talker gives
    its spectrum back exactly; MVDR, its covariance learned while the talker is silent, gives it back too and
    leaves of the other far less than delay-and-sum does."""
    rng = np.random.default_rng(0)
    talker, other = np.array([0.0, 0.0, 2.0]), np.array([1.7, 0.0, 1.0])
    t_spec = rng.standard_normal((257, 200)) + 1j * rng.standard_normal((257, 200))
    o_spec = rng.standard_normal((257, 400)) + 1j * rng.standard_normal((257, 400))
    x = _free_field(other, o_spec)
    x[:, :, :200] += _free_field(talker, t_spec)  # the talker in the first 200 frames only
    steer = bf.steering(ARRAY, talker, FREQS)
    np.testing.assert_allclose(bf.delay_and_sum(_free_field(talker, t_spec), steer), t_spec, atol=1e-9)
    silent = np.arange(400) >= 200
    w = bf.mvdr_weights(bf.covariance(x, silent), steer, loading=1e-3)
    band = slice(64, 257)  # 2-8 kHz, where a 6.5 cm array can tell directions apart
    np.testing.assert_allclose(bf.apply(w, _free_field(talker, t_spec))[band], t_spec[band], atol=1e-6)
    left_mvdr = np.abs(bf.apply(w, _free_field(other, o_spec))[band]) ** 2
    left_ds = np.abs(bf.delay_and_sum(_free_field(other, o_spec), steer)[band]) ** 2
    assert left_mvdr.mean() < 0.01 * left_ds.mean()


def test_the_direction_mask_gives_each_bin_to_the_person_it_points_at() -> None:
    rng = np.random.default_rng(1)
    a, b = np.array([-1.0, 0.0, 1.5]), np.array([1.0, 0.0, 1.5])
    spec = rng.standard_normal((257, 10)) + 1j * rng.standard_normal((257, 10))
    x = _free_field(a, spec)
    steers = np.stack([bf.steering(ARRAY, p, FREQS) for p in (a, b)])
    mask = bf.direction_mask(x, steers, target=0, floor=0.1)
    assert (mask[64:] == 1.0).all()  # every bin above 2 kHz is a's
    assert (bf.direction_mask(x, steers, target=1, floor=0.1)[64:] == 0.1).all()
    assert (bf.direction_mask(x, steers[:1], target=0) == 1.0).all()  # one person: nothing to take


def test_covariance_of_no_frame_is_zero_and_mvdr_falls_back_to_delay_and_sum() -> None:
    x = np.ones((4, 257, 3), dtype=complex)
    cov = bf.covariance(x, np.zeros(3, dtype=bool))
    assert cov.shape == (257, 4, 4) and not cov.any()
    steer = bf.steering(ARRAY, np.array([0.0, 0.0, 1.0]), FREQS)
    np.testing.assert_allclose(bf.mvdr_weights(cov, steer), steer / 4)


def test_diffuse_coherence_is_that_of_sound_from_every_direction() -> None:
    """Many independent plane waves from directions spread over the sphere: their measured coherence between the
    microphones is the model's sinc, and each microphone's with itself is 1."""
    rng = np.random.default_rng(1)
    directions = rng.standard_normal((4000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    freqs = np.array([500.0, 2000.0, 5000.0])
    # each wave's delay at each microphone, and a random phase of its own
    delays = ARRAY @ directions.T / 343.0  # (Q, K)
    x = np.exp(-2j * np.pi * freqs[:, None, None] * delays[None] + 2j * np.pi * rng.random(4000)[None, None])
    measured = np.einsum("fqk,fpk->fqp", x, x.conj()).real / 4000  # (F, Q, Q)
    model = bf.diffuse_coherence(ARRAY, freqs)
    assert model.shape == (3, 4, 4)
    np.testing.assert_allclose(np.diagonal(model, axis1=1, axis2=2), 1.0)
    np.testing.assert_allclose(measured, model, atol=0.06)
    assert model[2, 0, 2] < 0.5 < model[0, 0, 2]  # far apart in wavelengths: little in common
