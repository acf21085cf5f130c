"""Every golden vector of spec/vectors: encode gives the bytes, decode gives the fields."""

from __future__ import annotations

from typing import Any

import pytest

from drempower.errors import FieldRangeError, ProtocolError
from drempower.protocol import decode_command, decode_reply, message_fields, message_name

from .vectors import all_files, build, load

VALID = [(f, v) for f in all_files() if f != "invalid.json" for v in load(f)]
INVALID = load("invalid.json")


def _ids(items: list[Any]) -> list[str]:
    return [f"{f}:{v['name']}" if isinstance(v, dict) else str(v) for f, v in items]


def test_every_vector_file_is_used() -> None:
    assert {"doc_examples.json", "motion.json", "presets.json", "system.json", "parameters.json", "state.json"} <= {
        f for f, _ in VALID
    }
    assert len(VALID) > 150


@pytest.mark.parametrize(("file", "vec"), VALID, ids=_ids(VALID))
def test_encode(file: str, vec: dict[str, Any]) -> None:
    frame = build(vec["message"], vec["node"], vec["fields"]).encode()
    assert frame.arbitration_id == vec["id"]
    assert frame.data.hex().upper() == vec["data"]


@pytest.mark.parametrize(("file", "vec"), VALID, ids=_ids(VALID))
def test_decode(file: str, vec: dict[str, Any]) -> None:
    decode = decode_command if vec["direction"] == "host" else decode_reply
    msg = decode(vec["id"], bytes.fromhex(vec["data"]))
    expected = vec.get("decodes_as", {"message": vec["message"], "fields": vec["fields"]})
    assert message_name(msg) == expected["message"]
    assert msg.node == vec["node"]
    got = message_fields(msg)
    assert set(got) == set(expected["fields"])
    for key, want in expected["fields"].items():
        if isinstance(want, float):
            assert got[key] == pytest.approx(want, abs=1e-9, rel=1e-9), key
        else:
            assert got[key] == want, key


ENCODE_ERRORS = [v for v in INVALID if v["error"] == "range"]
DECODE_ERRORS = [v for v in INVALID if v["error"] == "protocol"]


@pytest.mark.parametrize("vec", ENCODE_ERRORS, ids=[v["name"] for v in ENCODE_ERRORS])
def test_invalid_encode(vec: dict[str, Any]) -> None:
    with pytest.raises(FieldRangeError) as info:
        build(vec["message"], vec["node"], vec["fields"]).encode()
    assert info.value.field == vec["field"]
    assert vec["field"] in str(info.value)


@pytest.mark.parametrize("vec", DECODE_ERRORS, ids=[v["name"] for v in DECODE_ERRORS])
def test_invalid_decode(vec: dict[str, Any]) -> None:
    decode = decode_command if vec["direction"] == "host" else decode_reply
    with pytest.raises(ProtocolError):
        decode(vec["id"], bytes.fromhex(vec["data"]))
