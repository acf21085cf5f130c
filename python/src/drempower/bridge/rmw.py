"""rmw_zenoh naming: key expressions, liveliness tokens, attachments (rmw_zenoh 0.2.5, ROS 2 Jazzy).

* topic/service key: ``<domain_id>/<fully qualified name without its leading />/<DDS type>/<RIHS01 hash>``
* liveliness token: ``@ros2_lv/<domain_id>/<session id>/<node id>/<entity id>/<kind>/<enclave>/<namespace>/<node>``
  and, for publishers, subscriptions, service servers and clients,
  ``/<qualified name>/<DDS type>/<hash>/<qos>``, names mangled (``/`` -> ``%``, empty -> ``%``)
* attachment: sequence number (int64 LE), source timestamp (ns since the epoch, int64 LE),
  GID length (one byte, 16), 16 GID bytes
"""

from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass
from typing import Literal

__all__ = [
    "ADMIN_SPACE",
    "DEFAULT_QOS",
    "GID_SIZE",
    "EntityKind",
    "Attachment",
    "mangle",
    "qualify",
    "topic_key",
    "node_token",
    "entity_token",
    "make_gid",
]

ADMIN_SPACE = "@ros2_lv"
"""Prefix of rmw_zenoh's liveliness tokens (a hermetic Zenoh namespace)."""
DEFAULT_QOS = "::,10:,:,:,,"
"""rmw_zenoh's compact QoS of a reliable, volatile, keep-last-10 entity (the ROS 2 default profile)."""
GID_SIZE = 16
EntityKind = Literal["NN", "MP", "MS", "SS", "SC"]
"""Node, message publisher, message subscription, service server, service client."""
_ATTACHMENT = struct.Struct("<qqB16s")


def mangle(name: str) -> str:
    """``name`` with each ``/`` replaced by ``%`` (``%`` for an empty name)."""
    return name.replace("/", "%") if name else "%"


def qualify(namespace: str, name: str) -> str:
    """Fully qualified name: ``qualify("/robot1", "joint_states")`` is ``/robot1/joint_states``."""
    if name.startswith("/"):
        return name
    ns = namespace.rstrip("/")
    return f"{ns}/{name}" if ns.startswith("/") or not ns else f"/{ns}/{name}"


def topic_key(domain_id: int, qualified_name: str, dds_type: str, type_hash: str) -> str:
    """The key expression of a topic or service."""
    return f"{domain_id}/{qualified_name.strip('/')}/{dds_type}/{type_hash}"


def node_token(domain_id: int, session_id: str, node_id: int, namespace: str, node: str, enclave: str = "") -> str:
    """Liveliness token of a node."""
    ns = mangle(namespace.rstrip("/") if namespace != "/" else "")
    return f"{ADMIN_SPACE}/{domain_id}/{session_id}/{node_id}/{node_id}/NN/{mangle(enclave)}/{ns}/{node}"


def entity_token(
    domain_id: int,
    session_id: str,
    node_id: int,
    entity_id: int,
    kind: EntityKind,
    namespace: str,
    node: str,
    qualified_name: str,
    dds_type: str,
    type_hash: str,
    qos: str = DEFAULT_QOS,
    enclave: str = "",
) -> str:
    """Liveliness token of a publisher (MP), subscription (MS), service server (SS) or client (SC)."""
    ns = mangle(namespace.rstrip("/") if namespace != "/" else "")
    return (
        f"{ADMIN_SPACE}/{domain_id}/{session_id}/{node_id}/{entity_id}/{kind}/{mangle(enclave)}/{ns}/{node}/"
        f"{mangle(qualified_name)}/{dds_type}/{type_hash}/{qos}"
    )


def make_gid(token: str) -> bytes:
    """A 16-byte GID for the entity whose liveliness token is ``token`` (unique per session and entity)."""
    return hashlib.sha256(token.encode()).digest()[:GID_SIZE]


@dataclass(frozen=True)
class Attachment:
    """What rmw_zenoh attaches to every sample, query and reply."""

    sequence_number: int
    source_timestamp: int
    """ns since the UNIX epoch."""
    gid: bytes

    def encode(self) -> bytes:
        """The 33 attachment bytes."""
        if len(self.gid) != GID_SIZE:
            raise ValueError(f"gid: {len(self.gid)} bytes, rmw_zenoh uses {GID_SIZE}")
        return _ATTACHMENT.pack(self.sequence_number, self.source_timestamp, GID_SIZE, self.gid)

    @classmethod
    def decode(cls, data: bytes) -> Attachment:
        """Parse an attachment; ValueError when it is not rmw_zenoh's 33-byte layout."""
        if len(data) != _ATTACHMENT.size:
            raise ValueError(f"attachment of {len(data)} bytes, rmw_zenoh's has {_ATTACHMENT.size}")
        seq, stamp, size, gid = _ATTACHMENT.unpack(data)
        if size != GID_SIZE:
            raise ValueError(f"attachment GID length {size}, rmw_zenoh's is {GID_SIZE}")
        return cls(seq, stamp, gid)
