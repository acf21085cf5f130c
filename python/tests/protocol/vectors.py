"""Load spec/vectors/*.json and map vector entries to protocol messages."""

from __future__ import annotations

import json
from typing import Any

from drempower.protocol import DataType, StartKind, SysCmd, TorqueMode, VelocityMode
from drempower.protocol.describe import CLASSES_BY_NAME
from drempower.protocol.messages import Message

from ..conftest import REPO_ROOT

VECTOR_DIR = REPO_ROOT / "spec" / "vectors"

_ENUM_FIELDS: dict[tuple[str, str], Any] = {
    ("velocity", "mode"): VelocityMode,
    ("preset_v", "mode"): VelocityMode,
    ("torque", "mode"): TorqueMode,
    ("preset_c", "mode"): TorqueMode,
    ("system", "op"): SysCmd,
    ("start", "kind"): StartKind,
}


def load(name: str) -> list[dict[str, Any]]:
    vectors: list[dict[str, Any]] = json.loads((VECTOR_DIR / name).read_text(encoding="utf-8"))["vectors"]
    return vectors


def all_files() -> list[str]:
    return sorted(p.name for p in VECTOR_DIR.glob("*.json"))


def build(message: str, node: int, fields: dict[str, Any]) -> Message:
    """The message a vector describes."""
    kwargs: dict[str, Any] = {}
    for key, value in fields.items():
        enum = _ENUM_FIELDS.get((message, key))
        if key == "dtype":
            enum = DataType
        kwargs[key] = enum[value.upper()] if enum is not None else value
    cls: Any = CLASSES_BY_NAME[message]
    msg: Message = cls(node, **kwargs)
    return msg
