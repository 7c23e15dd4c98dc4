"""`avhear.results`: the pipeline's results as an iterator in the caller's process."""
from __future__ import annotations

import threading

import avhear


def test_results_iterate_in_order_and_stop_when_the_loop_ends() -> None:
    stamps, speaking = [], []
    for result in avhear.results("sim:S2", duration_s=2):
        stamps.append(result.stamp_s)
        speaking += [p.speaking for p in result.people]
        # the people are those of the results file's line, in its order
        assert [p["id"] for p in result.as_dict()["people"]] == [p.id for p in result.people]
    assert len(stamps) == 60 and stamps == sorted(stamps)
    assert any(speaking) and not all(speaking)
    it = avhear.results("sim:S1", duration_s=5)
    first = next(it)
    it.close()  # leaving early stops the pipeline's threads
    assert first.index == 0
    assert not [t for t in threading.enumerate() if t.name.startswith("avhear-")]


def test_a_script_beside_the_clone_imports_the_package(tmp_path) -> None:  # noqa: ANN001
    """A clone in ~/avhear and a script run from ~: `import avhear` finds the clone's folder before the installed
    package; it must still be the package (it was an empty namespace package: "module 'avhear' has no attribute
    'results'")."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    (tmp_path / "avhear").symlink_to(root, target_is_directory=True)
    script = "import avhear; print(avhear.__file__); print(next(avhear.results('sim:S1', duration_s=1.0)).stamp_s)"
    done = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    where, stamp = done.stdout.split()
    assert where == str(tmp_path / "avhear" / "__init__.py")  # the clone's folder was the one found
    assert 0.0 <= float(stamp) < 1.0


def test_a_robot_with_an_array_hears_the_talker_out_of_view() -> None:
    """S4 with NAO's four microphones: the talker outside the view (53 degrees to the left, who counts first) is
    among the results as a voice to the left; with the default pair, results carry no voices. Four seconds: the
    talker's first two numbers."""
    import math

    voices = [v for r in avhear.results("sim:S4", duration_s=4, mics="nao") for v in r.voices]
    assert len(voices) >= 5 and all(-75 < math.degrees(v.azimuth_rad) < -35 for v in voices)
    assert next(avhear.results("sim:S4", duration_s=1)).voices is None
