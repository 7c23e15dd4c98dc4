"""Where the Rerun data goes: the native viewer, a running viewer, the web viewer, an .rrd file, or nowhere.

The web viewer (``--serve``) is hosted by the ``rerun`` command-line server that ships with rerun-sdk, started with
``--bind``: the Python SDK's own ``serve_grpc``/``serve_web_viewer`` listen on every interface (0.0.0.0) with no
way to narrow it, and avhear's servers bind to 127.0.0.1 unless the user asks otherwise.
"""
from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from app.errors import UserError

if TYPE_CHECKING:
    import rerun as rr

__all__ = ["ViewerSession", "ViewerTarget", "WebViewer", "check_viewer", "display_available", "rerun_executable",
           "viewer_abandoned"]


def rerun_executable() -> str | None:
    """The ``rerun`` command of rerun-sdk: on PATH, or beside this Python (a virtual environment not activated)."""
    found = shutil.which("rerun")
    if found:
        return found
    beside = Path(sys.executable).with_name("rerun")
    return str(beside) if beside.exists() else None


def display_available() -> bool:
    """Whether a native viewer window can open here (a display and the viewer binary)."""
    has_display = bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) or os.name == "nt"
    return has_display and rerun_executable() is not None


@dataclass(frozen=True)
class ViewerTarget:
    """save : an .rrd path; connect : a viewer URL ("" for the default local viewer); spawn : open the native
    viewer; serve : host the web viewer on ``bind`` (``grpc_port`` for the data, ``web_port`` for the page);
    none of them: log nothing (headless).

    part_s : with ``save``, a long run goes into parts of this many seconds of wall time: ``NAME.rrd``, then
    ``NAME.part2.rrd``, ... (the viewer opens them together: ``rerun NAME*.rrd``). Rerun's file writer keeps memory
    for everything it wrote until its file is closed, about 15-30 MB a minute of the console
    (``benchmarks/pipeline.py``); a new part releases it. None: one file, however long the run."""

    save: Path | None = None
    connect: str | None = None
    spawn: bool = False
    serve: bool = False
    bind: str = "127.0.0.1"
    grpc_port: int = 9876
    web_port: int = 9090
    part_s: float | None = 60.0

    @property
    def logs(self) -> bool:
        return self.save is not None or self.connect is not None or self.spawn or self.serve


def stop_process_group(proc: subprocess.Popen, timeout_s: float = 3.0) -> None:
    """Stop a process started with ``start_new_session=True`` and all it started: Ctrl-C to its whole process group
    first, as a user would, then harder. The ``rerun`` command is a Python launcher that runs the viewer binary as a
    child; a signal to the launcher alone (``terminate()``) leaves the binary serving, at full CPU."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:  # the whole group is gone
            break
        if _group_gone(proc, timeout_s):
            break
    proc.wait(timeout=timeout_s)


def _group_gone(proc: subprocess.Popen, timeout_s: float) -> bool:
    """Wait until no process of ``proc``'s group is left (the launcher reaped here, its children by their new
    parent), at most ``timeout_s``. Waiting for the launcher alone returns while the viewer binary still exits."""
    deadline = time.monotonic() + timeout_s
    while True:
        proc.poll()  # reap the launcher, our child, so that it leaves the group
        try:
            os.killpg(proc.pid, 0)
        except ProcessLookupError:
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.02)


def _wait_for_port(host: str, port: int, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    target = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
    while time.monotonic() < deadline:
        with socket.socket(socket.AF_INET6 if ":" in target else socket.AF_INET) as s:
            s.settimeout(0.2)
            if s.connect_ex((target, port)) == 0:
                return True
        time.sleep(0.1)
    return False


DEFAULT_VIEWER_URL = "rerun+http://127.0.0.1:9876/proxy"
_ABANDONED: list[rr.RecordingStream] = []  # streams whose viewer stopped answering, never dropped
FLUSH_TIMEOUT_S = 5.0  # at most this long to hand the last data to a viewer or file at the end of a run


def check_viewer(url: str) -> None:
    """Raise :class:`UserError` unless something accepts connections at the viewer ``url`` (``rerun+http://host:port
    /proxy``; "" for the default local viewer). Rerun's own connect never fails: with nobody listening it buffers
    until the end of the run and then waits for ever to flush."""
    from urllib.parse import urlsplit

    url = url or DEFAULT_VIEWER_URL
    parts = urlsplit(url)
    if not parts.scheme.startswith("rerun") or not parts.hostname:
        raise UserError(f"--connect {url!r} is not a Rerun viewer URL: use rerun+http://HOST:PORT/proxy "
                        f"(default {DEFAULT_VIEWER_URL})")
    try:
        port = parts.port or 9876
    except ValueError as exc:
        raise UserError(f"--connect {url!r}: {exc}") from exc
    if not _wait_for_port(parts.hostname, port, 1.0):
        raise UserError(f"no Rerun viewer at {url}: start one with `rerun`, or use --save FILE.rrd")
    if not _speaks_grpc(parts.hostname, port):
        raise UserError(f"no Rerun viewer at {url}: something listens there but does not answer as a viewer "
                        "(gRPC); start one with `rerun`, or use --save FILE.rrd")


_H2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + bytes(3) + b"\x04" + bytes(5)  # + an empty SETTINGS frame


def _speaks_grpc(host: str, port: int, timeout_s: float = 2.0) -> bool:
    """Whether the server at ``host:port`` answers an HTTP/2 connection preface with its SETTINGS frame, as every
    gRPC server (Rerun's viewer among them) must; a port held by something else never does."""
    try:
        with socket.create_connection((host, port), timeout=timeout_s) as conn:
            conn.sendall(_H2_PREFACE)
            head = b""
            deadline = time.monotonic() + timeout_s
            while len(head) < 9 and time.monotonic() < deadline:
                conn.settimeout(max(deadline - time.monotonic(), 0.01))
                chunk = conn.recv(9 - len(head))
                if not chunk:
                    break
                head += chunk
    except OSError:
        return False
    return len(head) == 9 and head[3] == 0x04  # frame type 4: SETTINGS


def viewer_abandoned() -> bool:
    """Whether a viewer stopped answering during this process: Rerun then blocks any later call, and its exit hook,
    for ever, so the command line ends the process at once (:func:`app.cli.main`)."""
    return bool(_ABANDONED)


def _bounded(fn: Callable[[], object], timeout_s: float) -> bool:
    """Run ``fn`` in a daemon thread; whether it returned without an error within ``timeout_s``."""
    ok: list[bool] = []

    def call() -> None:
        try:
            fn()
            ok.append(True)
        except Exception:  # noqa: BLE001 - rerun raises its own error type on a flush timeout
            pass

    worker = threading.Thread(target=call, name="avhear-viewer-flush", daemon=True)
    worker.start()
    worker.join(timeout_s)
    return bool(ok)


def web_url(target: ViewerTarget) -> str:
    """The web viewer's page for ``target`` (``serve``), opening its data."""
    return (f"http://{target.bind}:{target.web_port}/?url=rerun%2Bhttp%3A%2F%2F{target.bind}%3A{target.grpc_port}"
            "%2Fproxy")


class WebViewer:
    """The web viewer of ``--serve``: the ``rerun`` command's server bound to ``target.bind`` (the module's
    docstring says why not the SDK's), its data at :attr:`grpc_url`; its page is printed once it listens. Raises
    :class:`UserError` when it does not start."""

    def __init__(self, target: ViewerTarget) -> None:
        exe = rerun_executable()
        if exe is None:
            raise UserError("the 'rerun' command of rerun-sdk is not on PATH: reinstall with pip install rerun-sdk")
        self.target = target
        self._log = tempfile.TemporaryFile(mode="w+")
        self.server: subprocess.Popen | None = subprocess.Popen(
            [exe, "--serve-web", "--bind", target.bind, "--port", str(target.grpc_port), "--web-viewer-port",
             str(target.web_port)], stdout=subprocess.DEVNULL, stderr=self._log, start_new_session=True)
        if not (_wait_for_port(target.bind, target.grpc_port, 10.0)
                and _wait_for_port(target.bind, target.web_port, 10.0)):
            err = self.stop()
            raise UserError(f"the web viewer did not start on {target.bind} ports {target.grpc_port}/"
                            f"{target.web_port} (in use? choose others with --grpc-port/--web-port): {err[-300:]}")
        self.grpc_url = f"rerun+http://{target.bind}:{target.grpc_port}/proxy"
        print(f"avhear: the web viewer is at {web_url(target)}", file=sys.stderr, flush=True)

    def keep_serving(self) -> None:
        """Serve what was logged until Ctrl-C (or the server's end)."""
        print(f"avhear: the run has ended; the web viewer stays at {web_url(self.target)} ... Ctrl-C stops it",
              file=sys.stderr, flush=True)
        try:
            while self.server is not None and self.server.poll() is None:
                time.sleep(0.5)
        except KeyboardInterrupt:
            pass

    def stop(self) -> str:
        """Stop the server (:func:`stop_process_group`); returns what it printed."""
        if self.server is None:
            return ""
        stop_process_group(self.server)
        self.server = None
        self._log.seek(0)
        text = self._log.read()
        self._log.close()
        return text


class ViewerSession:
    """Opens the recording stream for a :class:`ViewerTarget` (with the default blueprint; ``several_pairs`` opens
    its "ITDs per pair" tab) and, for ``serve``, the web-viewer server; :meth:`close` flushes the data and, for
    ``serve``, keeps serving until Ctrl-C."""

    def __init__(self, target: ViewerTarget, *, several_pairs: bool = False) -> None:
        self.target = target
        self.web: WebViewer | None = None  # ``serve``
        self.recording: rr.RecordingStream | None = None
        self.parts: list[Path] = []  # the .rrd files written, in order
        self.abandoned = False  # close() gave up on a viewer that stopped answering
        self._part_started = time.monotonic()
        if target.part_s is not None and not target.part_s > 0:
            raise ValueError(f"part_s must be > 0 seconds or None, got {target.part_s!r}")
        if not target.logs:
            return  # headless: Rerun is not even imported
        import rerun as rr

        from layouts.blueprint import APPLICATION_ID, default_blueprint

        rec = rr.RecordingStream(APPLICATION_ID)
        blueprint = default_blueprint(several_pairs)
        self._blueprint = blueprint
        if target.save is not None:
            target.save.parent.mkdir(parents=True, exist_ok=True)
            rec.save(str(target.save), default_blueprint=blueprint)
            self.parts.append(target.save)
        elif target.connect is not None:
            check_viewer(target.connect)
            if not _bounded(lambda: rec.connect_grpc(target.connect or None, default_blueprint=blueprint),
                            FLUSH_TIMEOUT_S):
                _ABANDONED.append(rec)  # its sink waits for ever: never dropped, and the CLI ends the process
                raise UserError(f"the Rerun viewer at {target.connect or DEFAULT_VIEWER_URL} did not take the "
                                f"connection within {FLUSH_TIMEOUT_S:.0f} s; restart it, or use --save FILE.rrd")
        elif target.serve:
            self.web = WebViewer(target)
            rec.connect_grpc(self.web.grpc_url, default_blueprint=blueprint)
        else:
            rec.spawn(default_blueprint=blueprint)
        self.recording = rec

    def part_due(self) -> bool:
        """Whether the current .rrd part has run for ``part_s`` (always False when not saving in parts)."""
        t = self.target
        return (self.recording is not None and t.save is not None and t.part_s is not None
                and time.monotonic() - self._part_started >= t.part_s)

    def next_part(self) -> Path:
        """Close the current .rrd part and continue in the next, ``NAME.partK.rrd``; returns its path. The caller
        logs the static data again (:meth:`app.console.Console.new_part`), so that each part opens on its own."""
        assert self.recording is not None and self.target.save is not None, "next_part needs a save target"
        save = self.target.save
        path = save.with_name(f"{save.stem}.part{len(self.parts) + 1}{save.suffix}")
        self.recording.save(str(path), default_blueprint=self._blueprint)
        self.parts.append(path)
        self._part_started = time.monotonic()
        return path

    @property
    def server(self) -> subprocess.Popen | None:
        """The web viewer's server process (``serve``), while it runs."""
        return self.web.server if self.web is not None else None

    @property
    def web_url(self) -> str:
        return web_url(self.target)

    def close(self, *, keep_serving: bool = True) -> None:
        """Flush and disconnect; with a web viewer, serve until Ctrl-C (unless ``keep_serving`` is False)."""
        if self.recording is not None:
            flushed = _bounded(lambda: self.recording.flush(timeout_sec=FLUSH_TIMEOUT_S), FLUSH_TIMEOUT_S + 1)
            if self.web is not None and keep_serving:
                self.web.keep_serving()
            if not (flushed and _bounded(self.recording.disconnect, FLUSH_TIMEOUT_S)):
                # Rerun's gRPC client waits for ever for a viewer that stopped answering, in disconnect and again
                # in its exit hook: give up on the last data rather than hang the user's terminal
                print(f"avhear: warning: the viewer did not take the last data within {FLUSH_TIMEOUT_S:.0f} s; "
                      "some of it may be missing", file=sys.stderr, flush=True)
                import rerun as rr

                rr.unregister_shutdown()
                _ABANDONED.append(self.recording)  # dropping the stream would wait for the viewer too
                self.abandoned = True
            self.recording = None
        if self.web is not None:
            self.web.stop()
