"""One Zenoh session per process, configured in one place from the command line.

Defaults keep avhear off the network: the session listens on 127.0.0.1 only (port 7447, Zenoh's own, so that a
local subscriber or ``zenoh-bridge-ros2dds`` finds it as it would find a router) and multicast scouting, which
would announce it on the LAN, is off. Reaching another machine is explicit: ``--bus-listen``/``--bus-connect``
with Zenoh endpoints (``tcp/192.168.1.20:7447``), or ``--bus-config FILE`` (a Zenoh JSON5 configuration file, for
TLS, access control and everything else; then avhear changes nothing in it but the endpoints the flags give).
"""
from __future__ import annotations

import argparse
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from app.errors import UserError

__all__ = ["BusOptions", "DEFAULT_LISTEN", "add_bus_arguments", "bus_source", "open_session"]

DEFAULT_LISTEN = "tcp/127.0.0.1:7447"
_ENDPOINT = re.compile(r"^(tcp|udp|tls|quic|ws|unixsock-stream)/(\[[0-9a-fA-F:]+\]|[^/:\s\[\]]+):(\d{1,5})(#.*)?$")


@dataclass(frozen=True)
class BusOptions:
    """listen, connect : Zenoh endpoints; config : a Zenoh configuration file; namespace : key prefix."""

    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    config: Path | None = None
    namespace: str = ""

    @classmethod
    def from_args(cls, args: argparse.Namespace) -> BusOptions:
        return cls(tuple(args.bus_listen or ()), tuple(args.bus_connect or ()), args.bus_config,
                   args.bus_namespace or "")


def _endpoint(text: str) -> str:
    m = _ENDPOINT.match(text)
    if not m or not 0 <= int(m.group(3)) <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r} is not a Zenoh endpoint: use PROTOCOL/HOST:PORT, e.g. "
                                         f"{DEFAULT_LISTEN} or tcp/192.168.1.20:7447")
    return text


def add_bus_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("bus (Zenoh)")
    g.add_argument("--bus-listen", type=_endpoint, action="append", metavar="ENDPOINT",
                   help=f"listen on this Zenoh endpoint (repeatable; default {DEFAULT_LISTEN}, loopback only)")
    g.add_argument("--bus-connect", type=_endpoint, action="append", metavar="ENDPOINT",
                   help="connect to this Zenoh endpoint: a robot, a router (repeatable)")
    g.add_argument("--bus-config", type=Path, metavar="FILE",
                   help="a Zenoh configuration file (JSON5) for everything else: TLS, access control, ...")
    g.add_argument("--bus-namespace", default="", metavar="NS", help="prefix of every key (a ROS namespace)")


def _one_line(exc: BaseException) -> str:
    """Zenoh's message on one line, without the Rust source locations it appends."""
    return re.sub(r"\s*at /\S+\.rs:\d+\.?", "", " ".join(str(exc).split())).strip()


def _config(options: BusOptions) -> Any:
    import zenoh

    if options.config is not None:
        if not options.config.is_file():
            raise UserError(f"--bus-config {options.config}: no such file")
        try:
            config = zenoh.Config.from_file(str(options.config))
        except Exception as exc:  # noqa: BLE001 - zenoh raises ZError with the parser's message
            raise UserError(f"--bus-config {options.config} does not parse as a Zenoh configuration: "
                            f"{_one_line(exc)}") from None
    else:
        config = zenoh.Config()
        config.insert_json5("mode", json.dumps("peer"))
        config.insert_json5("scouting/multicast/enabled", "false")
        if not options.listen:
            config.insert_json5("listen/endpoints", json.dumps([DEFAULT_LISTEN]))
    if options.listen:
        config.insert_json5("listen/endpoints", json.dumps(list(options.listen)))
    if options.connect:
        config.insert_json5("connect/endpoints", json.dumps(list(options.connect)))
        if options.config is None:  # a robot that comes back is reached again within a second
            config.insert_json5("connect/retry", json.dumps({"period_init_ms": 250, "period_max_ms": 1000,
                                                             "period_increase_factor": 2}))
    return config


def open_session(options: BusOptions) -> Any:
    """The process's Zenoh session, or a :class:`UserError` that says what to change."""
    import zenoh

    config = _config(options)
    try:
        return zenoh.open(config)
    except Exception as exc:  # noqa: BLE001 - ZError: a port in use, an endpoint that cannot be reached ...
        where = ", ".join(options.listen or (() if options.config else (DEFAULT_LISTEN,)))
        hint = (f"is {where} in use (another avhear, or a Zenoh router: then join it with --bus-connect)? "
                "Choose another with --bus-listen" if where else "check the endpoints and the configuration file")
        raise UserError(f"cannot open the Zenoh session ({_one_line(exc)}); {hint}") from None


def bus_source(session: Any, options: BusOptions, args: argparse.Namespace) -> Any:
    """The robot's sensors as a pipeline source (``--source bus``), with ``--rig``, ``--left-key`` ... if given."""
    from app.bus.source import BusSource
    from app.config import require_live_rig

    rig = require_live_rig(args.rig) if getattr(args, "rig", None) else None
    return BusSource(session, namespace=options.namespace, rig=rig, left_key=getattr(args, "left_key", None),
                     right_key=getattr(args, "right_key", None), audio_key=getattr(args, "audio_key", None))
