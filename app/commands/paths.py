"""Output paths checked before the work starts: a file a command will write is probed (parent folders created, as
every command does) so that an unwritable path is one line at once, not a traceback after a long run."""
from __future__ import annotations

from pathlib import Path

from app.errors import UserError

__all__ = ["distinct_outputs", "output_dir", "output_file"]


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


def output_file(path: Path | str, option: str) -> Path:
    """``path`` as a file this command may write: its parent folders are created, a probe opens it for writing
    (and removes it again if it did not exist). Raises :class:`UserError` naming ``option`` otherwise."""
    path = Path(path)
    if path.is_dir():
        raise UserError(f"{option} {path} is a folder: give a file name")
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise UserError(f"cannot write {option} {path}: {parent} is a file, not a folder; choose another path")
            break
    existed = path.exists()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("a"):
            pass
    except OSError as exc:
        raise UserError(f"cannot write {option} {path}: {_reason(exc)}; choose another path") from None
    if not existed:
        path.unlink(missing_ok=True)
    return path


def output_dir(path: Path | str, option: str) -> Path:
    """``path`` as a folder this command may write into (created with its parents). Raises :class:`UserError`."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UserError(f"{option} {path} is a file, not a folder: choose a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".avhear-write-test"
        probe.touch()
        probe.unlink()
    except OSError as exc:
        raise UserError(f"cannot write into {option} {path}: {_reason(exc)}; choose another folder") from None
    return path


def distinct_outputs(*outputs: tuple[str, Path | str | None]) -> None:
    """Two outputs of one run never share a path: ``outputs`` are (option, path or None) pairs; the first two that
    name one file (after resolving links and ``..``) are a :class:`UserError` naming both options."""
    seen: dict[Path, str] = {}
    for option, path in outputs:
        if path is None:
            continue
        key = Path(path).expanduser().resolve()
        if key in seen:
            raise UserError(f"{seen[key]} and {option} both name {path}: each output of a run needs its own path")
        seen[key] = option
