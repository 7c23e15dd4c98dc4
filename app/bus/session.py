"""One Zenoh session per process, configured in one place from the command line.

Defaults keep avhear off the network and let every avhear process on one machine find the others, in any order,
beside a Zenoh router on tcp/localhost:7447 (rmw_zenoh's) or not: avhear never listens on 7447. The first avhear
process listens on the rendezvous ``tcp/127.0.0.1:7448`` (``AVHEAR_BUS_PORT`` changes the port); the others find it
in use, connect to it (retrying, so a rendezvous that goes away and comes back is joined again) and listen on a port
of their own on 127.0.0.1, which Zenoh's gossip passes on so that the processes reach each other directly. Multicast
scouting, which would announce a session on the LAN, is off. Reaching another machine is explicit:
``--bus-listen``/``--bus-connect`` with Zenoh endpoints (``tcp/192.168.1.20:7448``), or ``--bus-config FILE`` (a
Zenoh JSON5 configuration file, for TLS, access control and everything else; then avhear changes nothing in it but
the endpoints the flags give).

Under rmw_zenoh's key convention (the default, :mod:`app.bus.ros2`) the session also connects to rmw_zenoh's router
on ``tcp/127.0.0.1:7447`` (``AVHEAR_ROS_ROUTER`` names another, or none when empty) when the user gave no endpoint,
retrying, as every rmw_zenoh node does: that is how ROS 2 processes on this machine see avhear's node and topics.
Connecting is not listening: the router keeps its port.
"""
from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from app.bus.ros2 import DEFAULT_CONVENTION, Convention, router
from app.errors import UserError

__all__ = ["ENDPOINT", "RENDEZVOUS_PORT", "BusOptions", "open_session", "rendezvous", "ros_router"]

RENDEZVOUS_PORT = 7448  # one above Zenoh's (and rmw_zenoh's router's) 7447, which avhear leaves to them
_ANY_PORT = "tcp/127.0.0.1:0"
ENDPOINT = re.compile(r"^(tcp|udp|tls|quic|ws|unixsock-stream)/(\[[0-9a-fA-F:]+\]|[^/:\s\[\]]+):(\d{1,5})(#.*)?$")


@dataclass(frozen=True)
class BusOptions:
    """listen, connect : Zenoh endpoints; config : a Zenoh configuration file; namespace : the ROS namespace of every
    topic; keys : the key convention (``rmw_zenoh`` or ``bridge``); domain : the ROS domain id (rmw_zenoh's keys)."""

    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    config: Path | None = None
    namespace: str = ""
    keys: str = DEFAULT_CONVENTION
    domain: int = 0

    @property
    def convention(self) -> Convention:
        return Convention(self.keys, self.domain, self.namespace)


def ros_router(options: BusOptions) -> str | None:
    """The rmw_zenoh router the session joins by itself (:func:`open_session`), or None when it joins none (the
    bridge's keys, endpoints or a configuration file given, or ``AVHEAR_ROS_ROUTER`` empty)."""
    if not options.convention.native or options.config is not None or options.listen or options.connect:
        return None
    return router()


def _one_line(exc: BaseException) -> str:
    """Zenoh's message on one line, without the Rust source locations it appends."""
    return re.sub(r"\s*at /\S+\.rs:\d+\.?", "", " ".join(str(exc).split())).strip()


def rendezvous() -> str:
    """The loopback endpoint where avhear processes on one machine meet (port ``AVHEAR_BUS_PORT`` or 7448)."""
    text = os.environ.get("AVHEAR_BUS_PORT", "")
    if text and not (text.isdigit() and 0 < int(text) < 65536):
        raise UserError(f"AVHEAR_BUS_PORT={text!r} is not a port number (1-65535)")
    return f"tcp/127.0.0.1:{int(text) if text else RENDEZVOUS_PORT}"


def _config(options: BusOptions, *, listen: list[str] | None = None, connect: list[str] | None = None) -> Any:
    """A Zenoh configuration: the file's, or peer mode with multicast off; ``listen``/``connect`` are the endpoints
    avhear chose when the user gave none."""
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
    listen = list(options.listen) or listen
    connect = list(options.connect) or connect
    if listen:
        config.insert_json5("listen/endpoints", json.dumps(listen))
    if connect:
        config.insert_json5("connect/endpoints", json.dumps(connect))
        if options.config is None:  # a robot (or the rendezvous) that comes back is reached again within a second
            config.insert_json5("connect/retry", json.dumps({"period_init_ms": 250, "period_max_ms": 1000,
                                                             "period_increase_factor": 2}))
    return config


def open_session(options: BusOptions) -> Any:
    """The process's Zenoh session, or a :class:`UserError` that says what to change.

    Without endpoints or a configuration file: the rendezvous if it is free, else a free loopback port joined to
    the rendezvous (module docstring). With ``--bus-connect`` alone: a free loopback port, joined to those."""
    import zenoh

    if options.config is None and not options.listen and not options.connect:
        meet = rendezvous()
        ros = router() if options.convention.native else None
        if ros is not None and not ENDPOINT.match(ros):
            raise UserError(f"AVHEAR_ROS_ROUTER={ros!r} is not a Zenoh endpoint (e.g. tcp/127.0.0.1:7447; empty for "
                            "none)")
        router_endpoints = [ros] if ros else []
        try:
            return zenoh.open(_config(options, listen=[meet], connect=router_endpoints or None))
        except Exception:  # noqa: BLE001 - ZError: the rendezvous is taken (by another avhear): join it instead
            return _open(zenoh, _config(options, listen=[_ANY_PORT], connect=[meet, *router_endpoints]), options)
    listen = [_ANY_PORT] if options.config is None and not options.listen else None
    return _open(zenoh, _config(options, listen=listen), options)


def _open(zenoh: Any, config: Any, options: BusOptions) -> Any:
    try:
        return zenoh.open(config)
    except Exception as exc:  # noqa: BLE001 - ZError: a port in use, an address this machine does not have ...
        reason = _one_line(exc)
        if "Address already in use" in reason:
            hint = (f"{', '.join(options.listen)} is in use (another avhear, or a Zenoh router); choose another "
                    "port with --bus-listen, or join it with --bus-connect")
        elif "Cannot assign requested address" in reason:
            hint = (f"{', '.join(options.listen)} is not an address of this machine; --bus-listen takes one of its "
                    "own addresses (see `ip address`), --bus-connect the other machine's")
        else:
            hint = "check the endpoints and the configuration file"
        raise UserError(f"cannot open the Zenoh session ({reason}); {hint}") from None
