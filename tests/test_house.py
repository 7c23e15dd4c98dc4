"""The house (docs/architecture.md): imports point one way, the command line is a leaf, the Source contract is light.

The import checks read every module's import statements (also those inside functions), so that a lazy import that
breaks the direction is caught as well as one at the top."""
from __future__ import annotations

import ast
import subprocess
import sys
from functools import lru_cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@lru_cache(maxsize=None)
def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"))


def _imports(package: str) -> dict[str, set[str]]:
    """{module file: the top-level names of everything it imports} for every module of ``package``."""
    out: dict[str, set[str]] = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        names: set[str] = set()
        for node in ast.walk(_tree(path)):
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


@lru_cache(maxsize=1)
def _module_graph() -> dict[str, set[str]]:
    """{module: the package's modules it imports} over app, avcore, sim, avhear and layouts: every import statement
    (in functions and under TYPE_CHECKING too), relative ones resolved, ``from a import b`` naming module ``a.b``
    where there is one and ``a`` otherwise."""
    paths = {_module_name(p): p for package in ("app", "avcore", "sim", "avhear", "layouts")
             for p in (ROOT / package).rglob("*.py")}

    def known(name: str) -> str | None:
        while name and name not in paths:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {}
    for module, path in paths.items():
        here = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
        found: set[str | None] = set()
        for node in ast.walk(_tree(path)):
            if isinstance(node, ast.Import):
                found |= {known(alias.name) for alias in node.names}
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(here[:len(here) - node.level + 1] + ([base] if base else []))
                found |= {known(f"{base}.{a.name}") if f"{base}.{a.name}" in paths else known(base)
                          for a in node.names}
        graph[module] = {m for m in found if m and m != module}
    return graph


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        top = stack.pop()
                        on_stack.discard(top)
                        component.append(top)
                        if top == node:
                            break
                    if len(component) > 1:
                        out.append(sorted(component))
            elif child not in index:
                index[child] = low[child] = len(index)
                stack.append(child)
                on_stack.add(child)
                work.append((child, iter(sorted(graph[child]))))
            elif child in on_stack:
                low[node] = min(low[node], index[child])
    return out


def test_no_import_circles() -> None:
    """No two modules import each other, directly or around a ring (a shared type goes down a floor): issue 58."""
    assert _circles(_module_graph()) == []


def test_the_circle_finder_finds_a_ring() -> None:
    assert _circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _circles({"a": {"b"}, "b": set()}) == []


def test_the_result_imports_no_sink() -> None:
    """The data types depend on nothing above them: a sink reads the result, never the other way round."""
    assert not {n for n in _module_graph()["app.result"] if n.startswith(("app.sinks", "app.bus", "app.console"))}


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


def test_the_command_lines_help_imports_none_of_the_method() -> None:
    """`avhear --help` (the parsers of every command) imports no SciPy, OpenCV, Rerun, Zenoh, YAML or ROS types:
    what it states comes from light modules (sim/presets.py, app/sources/limits.py, app/bus/drivers.py), choices
    a method knows are loaded when looked at (issue 56.5; the time itself is not a test's to say)."""
    script = ("import sys\nfrom app.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
              "print(' '.join(sorted({m.split('.')[0] for m in sys.modules})), file=sys.stderr)")
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and "usage: avhear" in done.stdout, done.stderr
    loaded = set(done.stderr.split())
    assert not loaded & {"scipy", "cv2", "rerun", "zenoh", "yaml", "rosbags", "sounddevice", "pyroomacoustics"}, \
        sorted(loaded & {"scipy", "cv2", "rerun", "zenoh", "yaml", "rosbags", "sounddevice", "pyroomacoustics"})
