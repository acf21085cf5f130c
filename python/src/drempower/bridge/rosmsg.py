"""ROS 2 message types of the bridge and their CDR encoding, through ``rosbags``' type store.

No ROS installation is needed: the Jazzy type store of ``rosbags`` holds
``sensor_msgs/msg/JointState`` and ``std_msgs/msg/Float64MultiArray``; services
(``std_srvs/srv/Trigger``) are registered here from their definition text, with
the request, response and event types rosidl generates for every service;
``rcl_interfaces/msg/Log`` is there for ``/rosout``.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Any

from .typehash import type_hash

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = [
    "JOINT_STATE",
    "FLOAT64_MULTI_ARRAY",
    "TRIGGER",
    "LOG",
    "SERVICES",
    "typestore",
    "register_service",
    "dds_type_name",
    "ros_type_hash",
    "encode",
    "decode",
]

JOINT_STATE = "sensor_msgs/msg/JointState"
FLOAT64_MULTI_ARRAY = "std_msgs/msg/Float64MultiArray"
TRIGGER = "std_srvs/srv/Trigger"
LOG = "rcl_interfaces/msg/Log"
"""What a node says on ``/rosout`` (the bridge: its refusals)."""
SERVICES: dict[str, str] = {
    TRIGGER: "---\nbool success   # indicate successful run of triggered service\nstring message # informational\n",
}
"""Definitions (``.srv`` text) of the services the bridge serves."""
_PLACEHOLDER = "uint8 structure_needs_at_least_one_member\n"
"""The one field rosidl gives a type with none (an empty request or response)."""


def register_service(store: Typestore, name: str, definition: str) -> None:
    """Add service ``name`` (``pkg/srv/Name``) given by its ``.srv`` text to ``store``.

    Registers ``Name_Request``, ``Name_Response``, ``Name_Event`` (``info``,
    ``request[<=1]``, ``response[<=1]``) and ``Name`` itself (``request_message``,
    ``response_message``, ``event_message``), as rosidl does for Jazzy.
    """
    from rosbags.typesys import get_types_from_msg

    lines = definition.splitlines()
    if "---" not in [line.strip() for line in lines]:
        raise ValueError(f"service {name}: its definition has no '---' line between request and response")
    cut = [line.strip() for line in lines].index("---")
    request, response = "\n".join(lines[:cut]) + "\n", "\n".join(lines[cut + 1 :]) + "\n"
    pkg, _, short = name.split("/")
    texts = service_texts(short, request, response)
    # rosbags files every parsed type under msg/: parse there, then move the four types to srv/.
    moved = {f"{pkg}/msg/{n}": f"{pkg}/srv/{n}" for n in texts}
    types: dict[str, Any] = {}
    for typename, text in texts.items():
        for key, (consts, fields) in get_types_from_msg(text, f"{pkg}/msg/{typename}").items():
            types[moved.get(key, key)] = (consts, [(n, _rename(d, moved)) for n, d in fields])
    store.register(types)


def service_texts(short: str, request: str, response: str) -> dict[str, str]:
    """The ``.msg`` texts of service ``short``'s request, response, event and service types, as rosidl makes them."""
    return {
        f"{short}_Request": request if request.strip() else _PLACEHOLDER,
        f"{short}_Response": response if response.strip() else _PLACEHOLDER,
        f"{short}_Event": (
            f"service_msgs/ServiceEventInfo info\n{short}_Request[<=1] request\n{short}_Response[<=1] response\n"
        ),
        short: f"{short}_Request request_message\n{short}_Response response_message\n{short}_Event event_message\n",
    }


def _rename(desc: Any, names: dict[str, str]) -> Any:
    """``desc`` (a rosbags field description) with nested type names replaced per ``names``."""
    if isinstance(desc, str):
        return names.get(desc, desc)
    if isinstance(desc, tuple):
        return tuple(_rename(d, names) for d in desc)
    return desc


@functools.lru_cache(maxsize=1)
def typestore() -> Typestore:
    """The Jazzy type store with the bridge's services registered (built once)."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    for name, definition in SERVICES.items():
        register_service(store, name, definition)
    return store


def dds_type_name(name: str) -> str:
    """The DDS name rmw_zenoh puts in key expressions: ``sensor_msgs::msg::dds_::JointState_``."""
    pkg, kind, short = name.split("/")
    return f"{pkg}::{kind}::dds_::{short}_"


@functools.cache
def ros_type_hash(name: str) -> str:
    """RIHS01 hash of message or service ``name``, computed from its definition."""
    return type_hash(typestore(), name)


def encode(message: Any, typename: str) -> bytes:
    """CDR (little-endian, with the 4-byte encapsulation header) of ``message``."""
    return bytes(typestore().serialize_cdr(message, typename))


def decode(data: bytes, typename: str) -> Any:
    """The message of type ``typename`` in CDR ``data``."""
    return typestore().deserialize_cdr(data, typename)
