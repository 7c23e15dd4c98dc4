"""ROS 2 over Zenoh: the two key conventions, and a ROS 2 node as rmw_zenoh's graph sees one.

``bridge`` (zenoh-bridge-ros2dds): the topic ``/NS/humans/voices/tracked`` is the key ``NS/humans/voices/tracked``;
payloads are bare CDR; the bridge announces DDS readers and writers itself, so avhear declares nothing more.

``rmw_zenoh`` (the default; native ROS 2 on Zenoh, Jazzy and later), from ros2/rmw_zenoh ``docs/design.md`` and
``liveliness_utils.cpp`` (2024-10), checked against two newer readers, ZettaScaleLabs/ros-z
(``crates/ros-z-protocol/src/format/rmw_zenoh.rs``, 2026-05) and copper-rs ``cu_ros2_bridge`` (``liveliness.rs``,
``qos.rs``, ``attachment.rs``):

- data key ``<domain>/<topic without its leading slash>/<DDS type name>/<type hash>``, the DDS type name of
  ``pkg/msg/Name`` being ``pkg::msg::dds_::Name_`` and the hash REP-2011's ``RIHS01_<64 hex>`` (rosbags'
  ``Typestore.hash_rihs01``);
- a liveliness token per entity, ``@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<kind>/<enclave>/<namespace>/
  <node name>`` with, for a publisher (``MP``) or a subscription (``MS``), ``/<topic>/<type>/<hash>/<qos>``
  appended; a node's token (``NN``) has its own id twice. ``/`` inside a name is written ``%``, and an empty
  namespace or enclave is ``%``;
- QoS ``reliability:durability:history,depth:deadline_s,deadline_ns:lifespan_s,lifespan_ns:liveliness,lease_s,
  lease_ns``, each value left empty when it equals rmw_zenoh's default (reliable, volatile, keep last 42, the rest
  infinite or automatic): keep-last 10 is ``::,10:,:,:,,``;
- every sample's attachment: the sequence number (int64), the source time in ns since the epoch (int64) and the
  publisher's 16-byte GID, in Zenoh's serialization format (little-endian numbers; the GID as a sequence, its LEB128
  length 0x10 then the bytes): 33 bytes. The GID is rmw_zenoh's: XXH3-128 of the entity's token key, its low 64 bits
  then its high 64 bits, each little-endian (``liveliness_utils.cpp``, ``Entity::Entity``);
- one counter of entity ids per session (rmw_zenoh's context), from 0: a node takes the next id (its token carries it
  twice), and each of its publishers and subscriptions the next; a node is declared once per session whatever number
  of avhear's parts use it.

Subscriptions of rmw_zenoh data use ``*`` for the hash, so that a Humble driver behind a bridge
(``TypeHashNotSupported``) or a message revised upstream is still read; decoding is what checks the type.
"""
from __future__ import annotations

import itertools
import os
import struct
import threading
import time
from dataclasses import dataclass
from typing import Any, Callable

from app.errors import UserError

__all__ = ["CONVENTIONS", "DEFAULT_CONVENTION", "ROUTER", "router", "Convention", "Endpoint", "RosNode", "dds_type_name",
           "domain_from_env", "entity_gid", "published_topics", "qos_text", "ros_type_name"]

CONVENTIONS = ("rmw_zenoh", "bridge")
DEFAULT_CONVENTION = "rmw_zenoh"
ROUTER = "tcp/127.0.0.1:7447"  # where rmw_zenoh's router (rmw_zenohd) listens; avhear connects, never listens
ADMIN_SPACE = "@ros2_lv"
_RMW_DEFAULT_DEPTH = 42
_GID_BYTES = 16


def entity_gid(token_key: str) -> bytes:
    """rmw_zenoh's 16-byte GID of the entity whose liveliness token is ``token_key`` (module docstring)."""
    import xxhash

    return xxhash.xxh3_128_intdigest(token_key.encode()).to_bytes(_GID_BYTES, "little")


class _SessionGraph:
    """What rmw_zenoh's context keeps for one session: the counter of entity ids and the nodes declared, each with
    its id, its token and the number of avhear's parts that use it."""

    def __init__(self) -> None:
        self.ids = itertools.count(0)
        self.lock = threading.Lock()
        self.nodes: dict[str, list[Any]] = {}  # node token key without its ids -> [node id, token, users]


_GRAPHS: dict[str, _SessionGraph] = {}
_GRAPHS_LOCK = threading.Lock()


def _graph_of(session: Any) -> _SessionGraph:
    zid = str(session.info.zid())
    with _GRAPHS_LOCK:
        return _GRAPHS.setdefault(zid, _SessionGraph())


def ros_type_name(dds_name: str) -> str:
    """``hri_msgs::msg::dds_::IdsList_`` -> ``hri_msgs/msg/IdsList`` (the inverse of :func:`dds_type_name`)."""
    parts = dds_name.split("::")
    if len(parts) != 4 or parts[2] != "dds_" or not parts[3].endswith("_"):
        return dds_name
    return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"


def published_topics(session: Any, domain: int, timeout_s: float = 2.0) -> dict[str, set[str]]:
    """{topic: its ROS types} of every publisher rmw_zenoh's graph announces in ``domain``: the publishers' liveliness
    tokens, as ``ros2 topic list -t`` reads them (module docstring)."""
    out: dict[str, set[str]] = {}
    for reply in session.liveliness().get(f"{ADMIN_SPACE}/{domain}/**", timeout=timeout_s):
        if reply.ok is None:
            continue
        parts = str(reply.ok.key_expr).split("/")
        if len(parts) >= 11 and parts[5] == "MP":
            out.setdefault(parts[9].replace("%", "/"), set()).add(ros_type_name(parts[10]))
    return out


def dds_type_name(typename: str) -> str:
    """``hri_msgs/msg/IdsList`` -> ``hri_msgs::msg::dds_::IdsList_`` (the name rmw_zenoh puts in keys)."""
    package, kind, name = typename.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def qos_text(depth: int = 10) -> str:
    """A reliable, volatile, keep-last ``depth`` profile in rmw_zenoh's token form (module docstring)."""
    return f"::,{'' if depth == _RMW_DEFAULT_DEPTH else depth}:,:,:,,"


def router() -> str | None:
    """The rmw_zenoh router avhear joins under rmw_zenoh's keys: ``AVHEAR_ROS_ROUTER`` (a Zenoh endpoint; empty for
    none) or :data:`ROUTER`."""
    text = os.environ.get("AVHEAR_ROS_ROUTER")
    if text is None:
        return ROUTER
    return text.strip() or None


def _mangle(name: str) -> str:
    return name.replace("/", "%") or "%"


def domain_from_env() -> int:
    """``ROS_DOMAIN_ID`` as ROS 2 reads it (0 when unset); a value that is not a domain id is a user's mistake."""
    text = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return 0
    if not text.isdigit() or int(text) > 232:
        raise UserError(f"ROS_DOMAIN_ID={text!r} is not a ROS 2 domain id (0-232); unset it or give --ros-domain")
    return int(text)


@dataclass(frozen=True)
class Convention:
    """How ROS topic names become Zenoh keys: ``name`` is ``rmw_zenoh`` or ``bridge``; ``namespace`` is the ROS
    namespace of every topic (``robot1`` puts ``/humans/...`` at ``/robot1/humans/...``)."""

    name: str = DEFAULT_CONVENTION
    domain: int = 0
    namespace: str = ""

    def __post_init__(self) -> None:
        if self.name not in CONVENTIONS:
            raise ValueError(f"unknown key convention {self.name!r}; one of {', '.join(CONVENTIONS)}")

    @property
    def native(self) -> bool:
        return self.name == "rmw_zenoh"

    def topic(self, relative: str) -> str:
        """The absolute ROS topic name of ``relative`` (``humans/voices/tracked``) in the namespace; a name that
        starts with ``/`` is absolute already, as in ROS."""
        if relative.startswith("/"):
            return "/" + relative.strip("/")
        parts = [p for p in (self.namespace.strip("/"), relative.strip("/")) if p]
        return "/" + "/".join(parts)

    def key(self, relative: str, typename: str) -> str:
        """The key samples of ``relative`` (of ROS type ``typename``) are put on."""
        topic = self.topic(relative).lstrip("/")
        if not self.native:
            return topic
        from app.bus.messages import typestore

        return f"{self.domain}/{topic}/{dds_type_name(typename)}/{typestore().hash_rihs01(typename)}"

    def subscription(self, relative: str, typename: str) -> str:
        """The key expression a subscriber of ``relative`` declares (any type hash under rmw_zenoh)."""
        topic = self.topic(relative).lstrip("/")
        return f"{self.domain}/{topic}/{dds_type_name(typename)}/*" if self.native else topic

    def plain(self, key: str) -> str:
        """A key outside ROS (avhear's JSON and rig): under the namespace, as in both conventions."""
        return self.topic(key).lstrip("/")


class Endpoint:
    """One topic's Zenoh publisher or subscriber; under rmw_zenoh it holds its liveliness token, and a publisher
    attaches to each sample what rmw_zenoh attaches."""

    def __init__(self, publisher: Any, token: Any = None, gid: bytes | None = None) -> None:
        self._publisher, self._token, self._gid = publisher, token, gid
        self._sequence = itertools.count(1)

    def put(self, payload: bytes) -> None:
        if self._gid is None:
            self._publisher.put(payload)
            return
        attachment = struct.pack("<qqB", next(self._sequence), time.time_ns(), _GID_BYTES) + self._gid
        self._publisher.put(payload, attachment=attachment)

    def undeclare(self) -> None:
        for entity in (self._token, self._publisher):
            if entity is not None:
                try:
                    entity.undeclare()
                except Exception:  # noqa: BLE001 - the session may be closing already
                    pass


class RosNode:
    """The node ``name`` on ``session``: under rmw_zenoh its token and each endpoint's make it appear in ``ros2 node
    list`` and ``ros2 topic list``; under the bridge convention it only maps names to keys."""

    def __init__(self, session: Any, convention: Convention, name: str = "avhear") -> None:
        self.session, self.convention, self.name = session, convention, name
        self.node_token_key: str | None = None
        self.node_id = 0
        self._graph: _SessionGraph | None = None
        self._node: str | None = None
        if convention.native:
            self._graph = graph = _graph_of(session)
            self._node = self._token_key(-1, -1, "NN")  # the node's key without its ids: one node per name
            with graph.lock:
                entry = graph.nodes.get(self._node)
                if entry is None:
                    node_id = next(graph.ids)
                    key = self._token_key(node_id, node_id, "NN")
                    entry = graph.nodes[self._node] = [node_id, session.liveliness().declare_token(key), 0, key]
                entry[2] += 1
            self.node_id, self.node_token_key = entry[0], entry[3]

    def _next_id(self) -> int:
        assert self._graph is not None
        with self._graph.lock:
            return next(self._graph.ids)

    def _token_key(self, node_id: int, entity_id: int, kind: str, relative: str | None = None,
                   typename: str | None = None, depth: int = 10) -> str:
        c = self.convention
        zid = str(self.session.info.zid())
        key = (f"{ADMIN_SPACE}/{c.domain}/{zid}/{node_id}/{entity_id}/{kind}/%/{_mangle(c.topic(''))}/"
               f"{_mangle(self.name)}")
        if relative is None or typename is None:
            return key
        from app.bus.messages import typestore

        return (f"{key}/{_mangle(c.topic(relative))}/{dds_type_name(typename)}/{typestore().hash_rihs01(typename)}/"
                f"{qos_text(depth)}")

    def publisher(self, relative: str, typename: str) -> Endpoint:
        """A publisher of ``relative`` (a ROS topic in the namespace) carrying ``typename``."""
        zenoh_publisher = self.session.declare_publisher(self.convention.key(relative, typename))
        if not self.convention.native:
            return Endpoint(zenoh_publisher)
        token_key = self._token_key(self.node_id, self._next_id(), "MP", relative, typename)
        token = self.session.liveliness().declare_token(token_key)
        return Endpoint(zenoh_publisher, token, entity_gid(token_key))

    def subscriber(self, relative: str, typename: str, callback: Callable[[Any], None]) -> Endpoint:
        """A subscriber of ``relative``; ``callback`` gets Zenoh samples (in Zenoh's threads)."""
        subscriber = self.session.declare_subscriber(self.convention.subscription(relative, typename), callback)
        token = None
        if self.convention.native:
            token = self.session.liveliness().declare_token(
                self._token_key(self.node_id, self._next_id(), "MS", relative, typename))
        return Endpoint(subscriber, token)

    def close(self) -> None:
        """Leave the node: its token goes with the last of avhear's parts that use it."""
        graph, node, self._graph = self._graph, self._node, None
        if graph is None:
            return
        with graph.lock:
            entry = graph.nodes.get(node)  # type: ignore[arg-type]
            if entry is None:
                return
            entry[2] -= 1
            if entry[2] > 0:
                return
            del graph.nodes[node]  # type: ignore[arg-type]
        try:
            entry[1].undeclare()
        except Exception:  # noqa: BLE001 - the session may be closing already
            pass
