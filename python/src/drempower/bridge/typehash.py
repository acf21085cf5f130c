"""RIHS01 type hashes (REP-2016) computed from message definitions.

The hash is the SHA-256 of a JSON type description: the type's fields (name,
type id, capacities, nested type name) and, sorted by name, the descriptions of
every type it refers to. Field definitions come from a ``rosbags`` type store.
"""

from __future__ import annotations

import hashlib
import json
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = ["type_hash", "FIELD_TYPE_IDS"]

FIELD_TYPE_IDS: dict[str, int] = {
    "nested": 1,
    "int8": 2,
    "uint8": 3,
    "int16": 4,
    "uint16": 5,
    "int32": 6,
    "uint32": 7,
    "int64": 8,
    "uint64": 9,
    "float32": 10,
    "float64": 11,
    "float128": 12,
    "char": 3,  # a .msg ``char`` is IDL ``uint8`` (rosidl maps it so before hashing)
    "wchar": 14,
    "bool": 15,
    "byte": 16,
    "octet": 16,
    "string": 17,
    "wstring": 18,
    "fixed_string": 19,
    "fixed_wstring": 20,
    "bounded_string": 21,
    "bounded_wstring": 22,
}
"""rosidl ``FieldType`` ids of the element types."""
_ARRAY, _BOUNDED_SEQUENCE, _SEQUENCE = 48, 96, 144
"""Offsets added to the element's id for ``T[N]``, ``T[<=N]`` and ``T[]``."""
_BASE, _NAME, _ARRAY_NODE, _SEQUENCE_NODE = 1, 2, 3, 4
"""rosbags' node kinds in its field definitions."""
_EMPTY = [("structure_needs_at_least_one_member", (_BASE, ("uint8", 0)))]


def _field(name: str, desc: Any, refer: Any) -> dict[str, Any]:
    kind, rest = desc
    offset = capacity = string_capacity = 0
    if kind == _ARRAY_NODE:
        (kind, rest), capacity = rest
        offset = _ARRAY
    elif kind == _SEQUENCE_NODE:
        (kind, rest), capacity = rest
        offset = _BOUNDED_SEQUENCE if capacity else _SEQUENCE
    nested = ""
    if kind == _NAME:
        nested = rest
        refer(nested)
        tid = FIELD_TYPE_IDS["nested"]
    else:
        base, bound = rest
        if base in ("string", "wstring") and bound:
            string_capacity = bound
            base = "bounded_" + base
        tid = FIELD_TYPE_IDS[base]
    return {
        "name": name,
        "type": {
            "type_id": offset + tid,
            "capacity": capacity,
            "string_capacity": string_capacity,
            "nested_type_name": nested,
        },
    }


def type_hash(store: Typestore, typename: str) -> str:
    """``RIHS01_<sha256 hex>`` of ``typename`` (e.g. ``"sensor_msgs/msg/JointState"``) in ``store``.

    A service's hash is that of a type with the fields ``request_message``,
    ``response_message`` and ``event_message``, as rosidl describes services;
    register that type in the store (see :mod:`drempower.bridge.rosmsg`).
    """
    described: dict[str, dict[str, Any]] = {}

    def describe(name: str) -> None:
        if name in described:
            return
        described[name] = {}  # breaks cycles
        fields = store.fielddefs[name][1] or _EMPTY
        described[name] = {"type_name": name, "fields": [_field(n, d, describe) for n, d in fields]}

    describe(typename)
    top = described.pop(typename)
    doc = {"type_description": top, "referenced_type_descriptions": [described[k] for k in sorted(described)]}
    return "RIHS01_" + hashlib.sha256(json.dumps(doc).encode()).hexdigest()
