"""The frame encoding of the drempower face and which motors frames set moving."""

from __future__ import annotations

import pytest

from drempower.bridge.hub import driven_nodes
from drempower.errors import ProtocolError
from drempower.protocol.ids import Frame, SysCmd
from drempower.protocol.messages import FastRead, SystemCommand
from drempower.transports.zenoh_wire import decode_frames, encode_frames, is_estop, keys


def test_frames_golden_bytes() -> None:
    frames = [Frame(0x03E, bytes(8)), Frame(0x1234567, b"\x01", is_extended=True), Frame(0x20, b"", is_remote=True)]
    data = encode_frames(frames)
    assert data == (
        bytes.fromhex("3e00000008") + bytes(8) + bytes.fromhex("674523810101") + bytes.fromhex("2000004000")
    )
    assert decode_frames(data) == frames


def test_cut_frames_are_refused() -> None:
    data = encode_frames([Frame(0x3E, bytes(8))])
    with pytest.raises(ProtocolError, match="8 data bytes with 7 left"):
        decode_frames(data[:-1])
    with pytest.raises(ProtocolError, match="2 trailing bytes"):
        decode_frames(data + b"\x00\x00")


def test_estop_recognised() -> None:
    assert is_estop(SystemCommand(1, SysCmd.ESTOP).encode())
    assert is_estop(SystemCommand(0, SysCmd.ESTOP).encode())
    assert not is_estop(SystemCommand(1, SysCmd.CLEAR_ERRORS).encode())
    assert not is_estop(FastRead(1).encode())


def test_driven_nodes() -> None:
    from drempower.client.engine.commands import make_angle, make_speed

    assert driven_nodes([make_speed(3, 10.0).encode(), FastRead(4).encode()]) == {3}
    assert driven_nodes([FastRead(4).encode(), SystemCommand(2, SysCmd.CLEAR_ERRORS).encode()]) == set()
    assert driven_nodes([make_angle(5, 10.0, 1.0, 1.0, 1).encode()]) == {5}


def test_prefix_checked() -> None:
    assert keys("/arm/")["tx"] == "arm/tx"
    with pytest.raises(ValueError, match="without wildcards"):
        keys("arm/*")
    with pytest.raises(ValueError, match="non-empty"):
        keys("")
