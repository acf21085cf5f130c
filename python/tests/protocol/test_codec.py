"""Validation, ids, parameters and error words of the protocol core."""

from __future__ import annotations

import math

import pytest

from drempower.errors import FieldRangeError, ProtocolError, ValidationError
from drempower.protocol import (
    AxisError,
    DataType,
    FastRead,
    ParamValue,
    PositionQ,
    PositionT,
    Preset,
    PresetV,
    ReadParam,
    Start,
    StartKind,
    State,
    SysCmd,
    SystemCommand,
    Torque,
    Velocity,
    VelocityMode,
    WriteParam,
    arbitration_id,
    decode_command,
    decode_error_word,
    decode_reply,
    flag_info,
    parameter,
    parameters,
    split_arbitration_id,
)
from drempower.protocol.flags import ERROR_WORDS
from drempower.protocol.parameters import find_parameter


def test_arbitration_id_layout() -> None:
    assert arbitration_id(3, 0x08) == 0x068  # estop example of the protocol document
    assert arbitration_id(63, 0x1F) == 0x7FF
    assert split_arbitration_id(0x09E) == (4, 0x1E)
    with pytest.raises(FieldRangeError, match=r"node=64.*0..63"):
        arbitration_id(64, 0x08)
    with pytest.raises(FieldRangeError, match="command"):
        arbitration_id(1, 0x20)
    with pytest.raises(ProtocolError):
        split_arbitration_id(0x800)


@pytest.mark.parametrize("bad", [-1, 64, 1.0, True, "1", None])
def test_node_validation(bad: object) -> None:
    with pytest.raises(FieldRangeError) as info:
        FastRead(bad).encode()  # type: ignore[arg-type]
    assert info.value.field == "node"
    assert "0..63" in str(info.value)


def test_s16_error_names_field_value_and_range() -> None:
    with pytest.raises(FieldRangeError) as info:
        PositionQ(1, 0.0, speed=400.0, accel=5.0).encode()
    err = info.value
    assert (err.field, err.value, err.low, err.high) == ("speed", 400.0, -327.68, 327.67)
    assert str(err) == "speed=400.0 is out of range: allowed -327.68..327.67 (s16 field scaled by 0.01)"


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_nan_and_infinity_refused(bad: float) -> None:
    with pytest.raises(FieldRangeError, match="position"):
        PositionT(1, bad, 10.0).encode()
    with pytest.raises(FieldRangeError, match="bandwidth"):
        PositionT(1, 0.0, bad).encode()
    with pytest.raises(ValidationError, match="NaN"):
        WriteParam(1, 38012, DataType.F32, bad).encode()


def test_rounding_is_to_nearest_not_truncation() -> None:
    # the vendor library truncates: 0.29 -> 28, 1.15 -> 114, 0.57 -> 56
    data = PositionQ(1, 0.0, 0.29, 1.15).encode().data
    assert data[4:] == (29).to_bytes(2, "little") + (115).to_bytes(2, "little")
    assert Velocity(1, 0.0, 0.57).encode().data[4:6] == (57).to_bytes(2, "little")
    # the edge of the range rounds into it; beyond half a step it is refused
    assert PositionQ(1, 0.0, 327.674, -327.684).encode().data[4:] == bytes.fromhex("FF7F0080")
    with pytest.raises(FieldRangeError):
        PositionQ(1, 0.0, 327.676, 1.0).encode()


def test_mode_validation() -> None:
    with pytest.raises(FieldRangeError, match="mode"):
        Velocity(1, 1.0, 0.0, 3).encode()  # type: ignore[arg-type]
    with pytest.raises(FieldRangeError, match="mode"):
        Torque(1, 1.0, 0.0, 2).encode()  # type: ignore[arg-type]
    with pytest.raises(FieldRangeError, match="mode"):
        PresetV(1, 1.0, 0.0, 6).encode()  # type: ignore[arg-type]


def test_start_validation() -> None:
    with pytest.raises(ValidationError, match="relative"):
        Start(0, StartKind.V, relative=True).encode()
    with pytest.raises(ValidationError, match="StartImpedance"):
        Start(0, StartKind.D).encode()
    with pytest.raises(ValidationError, match=r"0x00\.\.0x07"):
        SystemCommand(0, SysCmd.START_T).encode()


def test_preset_interpretation() -> None:
    p = decode_command(*PresetV(2, -5.0, 12.5, VelocityMode.RAMP).encode()[:2])
    assert isinstance(p, Preset)
    assert p.p3 == 2.0  # mode code 200 travels x0.01
    assert p.as_kind(StartKind.V) == PresetV(2, -5.0, 12.5, VelocityMode.RAMP)
    assert p.as_kind(0x11).time == 12.5  # type: ignore[union-attr]
    with pytest.raises(ProtocolError, match="mode code"):
        p.as_kind(StartKind.C)
    with pytest.raises(ProtocolError, match="not a start"):
        p.as_kind(0x06)


def test_state_flags_from_id_bits() -> None:
    st = decode_reply(0x027, bytes(8))  # node 1, cmd 0b00111 = T and E
    assert isinstance(st, State)
    assert (st.node, st.trajectory_done, st.error, st.spare_bits) == (1, True, True, 0)
    st = decode_reply(0x039, bytes(8))  # bits 3-4 set: still a state frame, T=0 E=0
    assert isinstance(st, State) and not st.trajectory_done and not st.error and st.spare_bits == 3


def test_param_value_types() -> None:
    for dtype, value, raw in [
        (DataType.U16, 0xBEEF, "EFBE0000"),
        (DataType.S16, -2, "FEFF0000"),
        (DataType.U32, 0xDEADBEEF, "EFBEADDE"),
        (DataType.S32, -2, "FEFFFFFF"),
    ]:
        f = ParamValue(1, 100, dtype, value).encode()
        assert f.data[4:].hex().upper() == raw
        assert decode_reply(*f[:2]) == ParamValue(1, 100, dtype, value)
    with pytest.raises(ValidationError, match="whole number"):
        WriteParam(1, 100, DataType.U32, 1.5).encode()
    assert WriteParam(1, 100, DataType.U32, 2.0).encode().data[4:] == bytes([2, 0, 0, 0])


def test_parameter_registry() -> None:
    p = parameter("axis0.output_shaft.pos_estimate")
    assert (p.address, p.dtype, p.unit, p.writable) == (38007, DataType.F32, "deg", False)
    assert parameter(38007) is p
    assert parameter("38007") is p
    assert parameter("axis1.output_shaft.pos_estimate") is p  # vendor alias
    assert find_parameter("nope") is None
    with pytest.raises(ValidationError, match="did you mean"):
        parameter("axis0.output_shaft.pos_estimat")
    table = list(parameters())
    assert len(table) == 159
    assert [q.address for q in table] == sorted(q.address for q in table)
    assert parameter("can.config.heartbeat_ms").address == 21004  # Python-library address, not the PDF typo
    assert parameter("axis0.config.extra_setting.enable_reply_state").is_bool


def test_typed_read_and_write() -> None:
    assert ReadParam.of(4, "axis0.output_shaft.pos_estimate").encode().data.hex() == "7794000000000000"
    w = WriteParam.of(1, "axis0.config.can_node_id", 5)
    assert w.encode().data.hex() == "1979030005000000"
    with pytest.raises(ValidationError, match="read-only"):
        WriteParam.of(1, "vbus_voltage", 24.0)
    with pytest.raises(FieldRangeError, match="enable_reply_state"):
        WriteParam.of(1, "axis0.config.extra_setting.enable_reply_state", 2)
    with pytest.raises(FieldRangeError, match="can_node_id"):
        WriteParam.of(1, "axis0.config.can_node_id", -1)


def test_error_words() -> None:
    assert decode_error_word("axis0.error", 0x4000 | 0x2) == ["DC_BUS_UNDER_VOLTAGE", "ESTOP_REQUESTED"]
    assert decode_error_word(33001, 0x10000) == ["STALL_LIMIT_VIOLATION"]
    assert decode_error_word("encoder", 0x800) == ["EDR_BATTERY_LOW"]
    assert decode_error_word("can", 0x3) == ["DUPLICATE_CAN_IDS", "UNKNOWN_0x00000002"]
    assert decode_error_word("axis", 0) == []
    assert AxisError.ESTOP_REQUESTED == 0x4000
    assert [w.address for w in ERROR_WORDS] == [30001, 33001, 34001, 32001, 20001, 36001, 37001]
    for w in ERROR_WORDS:
        assert parameter(w.address).name == w.name
    assert "clear" in flag_info("axis", "ESTOP_REQUESTED").action.lower()
    assert flag_info("motor", "ADC_FAILED").meaning  # generic text for unrecorded flags
    with pytest.raises(KeyError):
        decode_error_word("vbus_voltage", 1)


def test_error_word_values_are_u32() -> None:
    from drempower.errors import FieldRangeError
    from drempower.protocol import decode_error_word

    for bad in (-1, 1 << 32, 1.5):
        with pytest.raises(FieldRangeError):
            decode_error_word("axis", bad)  # type: ignore[arg-type]
    assert decode_error_word("axis", 0x4000) == ["ESTOP_REQUESTED"]
