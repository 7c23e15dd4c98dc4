"""sim.audio: where the simulated room's voices and noise come from."""
from __future__ import annotations


def test_a_clone_alone_speaks_with_the_real_voices_it_ships(tmp_path, monkeypatch) -> None:  # noqa: ANN001
    """With no data folder beside the clone (AVHEAR_DATA naming an empty one), the spoken digits, the read sentences
    and the kitchen noise come from the copies in sim/data (their licences in sim/data/SOURCES.md); a folder given
    by name is read alone (a test's empty folder still means synthetic sounds)."""
    from sim.audio import load_background, load_clip_bank, load_sentence_bank
    from sim.roomsim import EMBEDDED_DATA_DIR

    monkeypatch.setenv("AVHEAR_DATA", str(tmp_path / "nothing-here"))
    assert load_clip_bank(16000).source == "digits"
    assert load_sentence_bank(16000).source == "arctic"
    assert load_background((0.0, 0.0, 2.0), 20.0).source == "kitchen"
    assert load_clip_bank(16000, data_dir=tmp_path).source == "synthetic"
    assert load_background((0.0, 0.0, 2.0), 20.0, data_dir=tmp_path).source == "pink"
    sources = (EMBEDDED_DATA_DIR / "SOURCES.md").read_text(encoding="utf-8")
    shipped = sorted(p.relative_to(EMBEDDED_DATA_DIR).parts[:2] for p in EMBEDDED_DATA_DIR.rglob("*.wav"))
    assert {"/".join(parts) for parts in shipped} == {"speech/digits", "speech/arctic",
                                                      "noise/doing_the_dishes.wav"}
    for folder in ("speech/digits/", "speech/arctic/", "noise/doing_the_dishes.wav"):
        assert f"`{folder}`" in sources  # each shipped folder with its source and licence
    assert "CC BY-SA 4.0" in sources and "CC BY 4.0" in sources and "CMU ARCTIC" in sources
