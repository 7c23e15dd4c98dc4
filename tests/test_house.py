"""The house (docs/architecture.md): imports point one way, the command line is a leaf, the Source contract is light.

The import checks read every module's import statements (also those inside functions), so that a lazy import that
breaks the direction is caught as well as one at the top."""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _imports(package: str) -> dict[str, set[str]]:
    """{module file: the top-level names of everything it imports} for every module of ``package``."""
    out: dict[str, set[str]] = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        names: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names |= {alias.name for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module)
        out[str(path.relative_to(ROOT))] = names
    return out


@pytest.mark.parametrize(("package", "forbidden"), [
    ("avcore", ("app", "sim", "avhear", "layouts", "rerun", "yaml", "zenoh", "sounddevice", "rosbags")),
    ("sim", ("app", "avhear", "rerun", "zenoh", "sounddevice")),
])
def test_the_method_and_the_simulator_import_nothing_above_them(package: str, forbidden: tuple[str, ...]) -> None:
    wrong = {module: sorted(n for n in names if n.split(".")[0] in forbidden)
             for module, names in _imports(package).items()}
    assert not {m: n for m, n in wrong.items() if n}, f"{package} imports what lies above it"


def test_nothing_imports_the_command_modules() -> None:
    """The commands are leaves: only the command line (app/cli.py) names them, and only by module name."""
    users = {module for package in ("app", "avhear", "sim", "avcore", "layouts")
             for module, names in _imports(package).items()
             if any(n.startswith("app.commands") for n in names)}
    assert users <= {str(Path("app") / "commands" / p.name) for p in (ROOT / "app" / "commands").glob("*.py")}


def test_the_source_contract_imports_nothing_heavy() -> None:
    """A source of one's own implements app.sources.contract without pulling in the simulator, OpenCV, YAML or the
    devices: importing the contract loads none of them (checked in a fresh interpreter)."""
    script = ("import sys, app.sources.contract; "
              "print(' '.join(sorted({m.split('.')[0] for m in sys.modules} | "
              "{m for m in sys.modules if m.startswith('app.')})))")
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    loaded = set(done.stdout.split())
    heavy = {"cv2", "yaml", "scipy", "numpy", "sim", "zenoh", "rerun", "sounddevice", "rosbags", "avcore",
             "app.sources.sim", "app.sources.live", "app.sources.recording", "app.sources.open"}
    assert not loaded & heavy, sorted(loaded & heavy)


def test_argparse_stays_in_the_command_line() -> None:
    """Flags and Namespaces end at the command line (app/cli.py, app/commands/): sources, the bus and the pipeline
    take plain values. (layouts/blueprint.py is a script of its own, `python -m layouts.blueprint`.)"""
    users = {module for package in ("app", "avhear", "sim", "avcore")
             for module, names in _imports(package).items() if "argparse" in names}
    assert users and all(m == "app/cli.py" or m.startswith("app/commands/") for m in users), sorted(users)
