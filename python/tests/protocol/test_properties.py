"""Property-based tests: round trips for every message, and random bytes into every decoder."""

from __future__ import annotations

import struct
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from drempower.errors import ProtocolError
from drempower.protocol import (
    AADecoder,
    DataType,
    FastRead,
    ParamValue,
    PositionP,
    PositionQ,
    PositionT,
    Preset,
    PresetC,
    PresetD,
    PresetP,
    PresetQ,
    PresetT,
    PresetV,
    ReadParam,
    Start,
    StartImpedance,
    StartKind,
    State,
    SysCmd,
    SystemCommand,
    Torque,
    TorqueMode,
    Uart11Decoder,
    Velocity,
    VelocityMode,
    WriteParam,
    decode_command,
    decode_reply,
    encode_aa,
    encode_uart11,
)
from drempower.protocol.ids import Frame
from drempower.protocol.messages import Message

nodes = st.integers(0, 63)
f32s = st.floats(width=32, allow_nan=False, allow_infinity=False)
s16s = st.integers(-32768, 32767).map(lambda r: r / 100)


def _value(dtype: DataType) -> st.SearchStrategy[Any]:
    return {
        DataType.F32: f32s,
        DataType.U16: st.integers(0, 0xFFFF),
        DataType.S16: st.integers(-0x8000, 0x7FFF),
        DataType.U32: st.integers(0, 0xFFFFFFFF),
        DataType.S32: st.integers(-0x80000000, 0x7FFFFFFF),
    }[dtype]


def _rw(cls: type[WriteParam] | type[ParamValue]) -> st.SearchStrategy[Message]:
    return st.sampled_from(list(DataType)).flatmap(
        lambda dt: st.builds(cls, nodes, st.integers(1, 0xFFFF), st.just(dt), _value(dt))
    )


commands: st.SearchStrategy[Message] = st.one_of(
    st.builds(PositionT, nodes, f32s, s16s, s16s),
    st.builds(PositionQ, nodes, f32s, s16s, s16s),
    st.builds(PositionP, nodes, f32s, s16s, s16s),
    st.builds(Velocity, nodes, f32s, s16s, st.sampled_from(list(VelocityMode))),
    st.builds(Torque, nodes, f32s, s16s, st.sampled_from(list(TorqueMode))),
    st.builds(Preset, nodes, f32s, s16s, s16s),
    st.builds(SystemCommand, nodes, st.sampled_from([op for op in SysCmd if op < 0x08])),
    st.builds(Start, nodes, st.sampled_from([StartKind.T, StartKind.Q, StartKind.P]), st.booleans()),
    st.builds(Start, nodes, st.sampled_from([StartKind.V, StartKind.C]), st.just(False)),
    st.builds(StartImpedance, nodes, s16s, s16s),
    st.builds(ReadParam, nodes, st.integers(1, 0xFFFF), st.sampled_from(list(DataType))),
    st.builds(FastRead, nodes),
    _rw(WriteParam),
)
typed_presets: st.SearchStrategy[Message] = st.one_of(
    st.builds(PresetT, nodes, f32s, s16s, s16s),
    st.builds(PresetQ, nodes, f32s, s16s, s16s),
    st.builds(PresetP, nodes, f32s, s16s, s16s),
    st.builds(PresetV, nodes, f32s, s16s, st.sampled_from(list(VelocityMode))),
    st.builds(PresetC, nodes, f32s, s16s, st.sampled_from(list(TorqueMode))),
    st.builds(PresetD, nodes, f32s, s16s, s16s),
)
replies: st.SearchStrategy[Message] = st.one_of(
    st.builds(State, nodes, f32s, s16s, s16s, st.booleans(), st.booleans(), st.integers(0, 3)),
    _rw(ParamValue),
)


@given(commands)
def test_command_round_trip(msg: Message) -> None:
    frame = msg.encode()
    assert len(frame.data) == 8
    assert decode_command(frame.arbitration_id, frame.data) == msg


@given(typed_presets)
def test_typed_preset_round_trip(msg: Any) -> None:
    frame = msg.encode()
    generic = decode_command(frame.arbitration_id, frame.data)
    assert isinstance(generic, Preset)
    assert generic.as_kind(msg.kind) == msg
    assert msg.to_preset() == generic


@given(replies)
def test_reply_round_trip(msg: Message) -> None:
    frame = msg.encode()
    assert decode_reply(frame.arbitration_id, frame.data) == msg


@given(st.integers(0, 0x7FF), st.binary(min_size=0, max_size=12))
def test_random_bytes_raise_only_protocol_error(arb: int, data: bytes) -> None:
    for decode in (decode_command, decode_reply):
        try:
            msg = decode(arb, data)
        except ProtocolError:
            continue
        # whatever decodes must encode back to the same frame
        again = msg.encode()
        assert again.arbitration_id == arb
        assert decode(again.arbitration_id, again.data) == msg


@given(st.integers(-(2**40), 2**40), st.binary(max_size=8))
def test_any_id_raises_only_protocol_error(arb: int, data: bytes) -> None:
    for decode in (decode_command, decode_reply):
        try:
            decode(arb, data)
        except ProtocolError:
            pass


frames = st.builds(lambda a, d: Frame(a, d), st.integers(0, 0x7FF), st.binary(min_size=8, max_size=8))


@settings(max_examples=200)
@given(st.lists(frames, max_size=8), st.binary(max_size=40), st.data())
def test_uart11_stream_resynchronises(fs: list[Frame], garbage: bytes, data: st.DataObject) -> None:
    """Frames after garbage are recovered, whatever the chunking; garbage never raises."""
    # garbage free of 0x08 cannot fake a header
    garbage = bytes(b for b in garbage if b != 0x08)
    stream = garbage + b"".join(encode_uart11(f.arbitration_id, f.data) for f in fs)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=6)))
    dec = Uart11Decoder()
    out: list[Frame] = []
    prev = 0
    for c in [*cuts, len(stream)]:
        out += dec.feed(stream[prev:c])
        prev = c
    assert out == fs
    assert dec.dropped == len(garbage)
    assert dec.pending == 0


@settings(max_examples=200)
@given(st.lists(frames, max_size=8), st.binary(max_size=40), st.data())
def test_aa_stream_resynchronises(fs: list[Frame], garbage: bytes, data: st.DataObject) -> None:
    garbage = bytes(b for b in garbage if b != 0xAA)
    stream = garbage + b"".join(encode_aa(f) for f in fs)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=6)))
    dec = AADecoder()
    out: list[Frame] = []
    prev = 0
    for c in [*cuts, len(stream)]:
        out += dec.feed(stream[prev:c])
        prev = c
    assert out == fs
    assert dec.dropped == len(garbage)


@given(st.binary(max_size=200))
def test_stream_decoders_never_raise(blob: bytes) -> None:
    """Every byte is accounted for: in a frame, dropped, or pending."""
    u = Uart11Decoder()
    got = u.feed(blob)
    assert 11 * len(got) + u.dropped + u.pending == len(blob)
    a = AADecoder()
    got = a.feed(blob)
    assert sum(8 + len(f.data) for f in got) + a.dropped + a.pending == len(blob)
    assert all(0 <= f.arbitration_id <= 0x1FFFFFFF for f in got)


def test_s16_struct_matches_reference() -> None:
    # the packing of the core agrees with a plain struct reference for a sweep of values
    for raw in range(-32768, 32768, 97):
        msg = PositionQ(1, 0.0, raw / 100, -raw / 100 if raw != -32768 else 0.0)
        _, s, _a = struct.unpack("<fhh", msg.encode().data)
        assert s == raw
