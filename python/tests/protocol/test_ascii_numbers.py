"""Numbers read from text take ASCII digits only (``int("\u0661")`` is 1 in Python)."""

from __future__ import annotations

import pytest

from drempower.errors import ProtocolError, ValidationError
from drempower.protocol.candump import parse_candump_line
from drempower.protocol.ids import parse_float, parse_int
from drempower.protocol.parameters import find_parameter
from drempower.records.dbc import parse_nodes
from drempower.sim.bus import parse_host_queue
from drempower.sim.slcan import parse_frame
from drempower.sim.socketcand import parse_send

ARABIC_ONE = "\u0661"  # ARABIC-INDIC DIGIT ONE
FULLWIDTH_ONE = "\uff11"
SUPERSCRIPT_TWO = "\u00b2"
NOT_ASCII = [ARABIC_ONE, FULLWIDTH_ONE, ARABIC_ONE + "0", "1" + ARABIC_ONE, "\u0967", "1_0", SUPERSCRIPT_TWO]


@pytest.mark.parametrize("text", NOT_ASCII)
def test_parse_int_refuses_digits_of_other_scripts(text: str) -> None:
    with pytest.raises(ValidationError, match="motor id") as info:
        parse_int(text, "motor id")
    assert repr(text) in str(info.value)


@pytest.mark.parametrize("text", [*NOT_ASCII, ARABIC_ONE + ".5", "1e" + ARABIC_ONE, "", "1.2.3", "0x10"])
def test_parse_float_refuses_what_is_not_an_ascii_number(text: str) -> None:
    with pytest.raises(ValueError, match="target"):
        parse_float(text, "target")


@pytest.mark.parametrize(
    ("text", "base", "value"),
    [
        ("1", 10, 1),
        (" 63 ", 10, 63),
        ("-5", 10, -5),
        ("+7", 10, 7),
        ("7FF", 16, 0x7FF),
        ("0x1f", 16, 0x1F),
        ("0x10", 0, 16),
        ("010", 10, 10),
        ("0b11", 0, 3),
        ("12", 0, 12),
    ],
)
def test_parse_int_reads_ascii(text: str, base: int, value: int) -> None:
    assert parse_int(text, base=base) == value


def test_parse_int_base_zero_keeps_pythons_refusal_of_leading_zeros() -> None:
    with pytest.raises(ValidationError):
        parse_int("010", base=0)


@pytest.mark.parametrize(
    ("text", "value"), [("10", 10.0), ("-1.5e3", -1500.0), (".5", 0.5), ("5.", 5.0), ("1E-2", 0.01)]
)
def test_parse_float_reads_ascii(text: str, value: float) -> None:
    assert parse_float(text) == value


def test_parse_float_reads_infinity_for_the_caller_to_refuse() -> None:
    assert parse_float("-inf") == float("-inf")
    assert parse_float("NaN") != parse_float("NaN")


def test_candump_time_stamp_and_length_in_ascii_only() -> None:
    assert parse_candump_line("(1700.5) can0 039#00").timestamp == 1700.5
    with pytest.raises(ProtocolError):
        parse_candump_line(f"({ARABIC_ONE}700.5) can0 039#00")
    with pytest.raises(ProtocolError):
        parse_candump_line(f"  can0  039   [{ARABIC_ONE}]  00")


def test_parameter_by_address_in_ascii_only() -> None:
    assert find_parameter("1") is not None
    assert find_parameter(ARABIC_ONE) is None


def test_dbc_nodes_in_ascii_only() -> None:
    assert parse_nodes("1-3") == [1, 2, 3]
    with pytest.raises(ValueError, match="nodes"):
        parse_nodes(ARABIC_ONE)


def test_simulator_text_links_take_ascii_only() -> None:
    assert parse_frame("t0391AA").arbitration_id == 0x039
    with pytest.raises(ProtocolError):
        parse_frame(f"t039{ARABIC_ONE}AA")
    with pytest.raises(ProtocolError):
        parse_frame(f"t{ARABIC_ONE}391AA")
    assert parse_send("send 039 1 AA").data == b"\xaa"
    with pytest.raises(ProtocolError):
        parse_send(f"send 039 {ARABIC_ONE} AA")
    assert parse_host_queue("priority:3") == 3
    with pytest.raises(ValueError, match="host_queue"):
        parse_host_queue(f"priority:{ARABIC_ONE}")
    with pytest.raises(ValueError, match="host_queue"):
        parse_host_queue(f"priority:{SUPERSCRIPT_TWO}")


def test_socketcand_port_in_ascii_only() -> None:
    from drempower.errors import TransportError
    from drempower.transports.pythoncan import _probe_socketcand

    with pytest.raises(TransportError, match="ASCII"):
        _probe_socketcand("127.0.0.1", "\u0662\u0669\u0665\u0663\u0666", 1.0)  # 29536 in Arabic-Indic digits
