"""The zero-reply grace on scripted time: with another host about, a parameter reply of value 0 (the bytes
of a read request) is held back for the grace; a non-zero reply inside it is the answer."""

from __future__ import annotations

import pytest

from drempower.client.engine.effects import request
from drempower.client.engine.session import BusSession, Operation
from drempower.protocol import DataType, ParamValue, PresetT, ReadParam
from drempower.protocol.ids import Frame

VBUS = 1
ZERO = Frame(0x03E, bytes.fromhex("0100000000000000"))
"""Motor 1: address 1, f32, value 0 (also the bytes of a read of vbus_voltage by another host)."""
VBUS_24 = ParamValue(1, VBUS, DataType.F32, 24.0).encode()
GRACE = 0.01


def _read(s: BusSession, timeout: float = 0.1) -> Operation[list[ParamValue]]:
    opn: Operation[list[ParamValue]] = s.submit(request([ReadParam(1, VBUS, DataType.F32)], timeout))
    assert s.data_to_send() == [ZERO]
    return opn


def test_a_zero_reply_answers_at_once_while_no_other_host_was_seen() -> None:
    s = BusSession(zero_reply_grace=GRACE)
    opn = _read(s)
    assert s.receive(ZERO, 0.002) is None
    assert opn.done and opn.result()[0].value == 0.0 and s.now == 0.002


def test_a_host_only_command_on_the_bus_means_another_host() -> None:
    s = BusSession()
    assert s.receive(PresetT(3, 10.0, 20.0).encode(), 0.001) is not None
    assert s.other_hosts and s.malformed == 0


def test_an_unclaimed_zero_reply_means_another_host() -> None:
    s = BusSession()
    assert s.receive(ZERO, 0.001) == ZERO
    assert s.other_hosts


def test_with_another_host_a_zero_reply_is_held_and_a_non_zero_one_inside_the_grace_wins() -> None:
    s = BusSession(zero_reply_grace=GRACE)
    s.other_hosts = True
    opn = _read(s)
    assert s.receive(ZERO, 0.002) is None
    assert not opn.done and s.next_deadline() == pytest.approx(0.002 + GRACE)
    assert s.receive(VBUS_24, 0.011) is None
    assert opn.result()[0].value == 24.0
    s.advance(0.05)
    assert (s.anomalies, s.unmatched, s.next_deadline(), len(s.matcher)) == (0, 0, None, 0)


def test_a_held_zero_reply_is_the_answer_at_the_end_of_the_grace() -> None:
    s = BusSession(zero_reply_grace=GRACE)
    s.other_hosts = True
    opn = _read(s)
    s.receive(ZERO, 0.002)
    s.receive(ZERO, 0.008)  # a second zero frame does not extend the grace
    assert s.next_deadline() == pytest.approx(0.002 + GRACE)
    s.advance(0.002 + GRACE - 1e-6)
    assert not opn.done
    s.advance(0.002 + GRACE)
    assert opn.result()[0].value == 0.0 and s.next_deadline() is None


def test_a_held_zero_reply_is_the_answer_when_the_request_expires_before_the_grace_ends() -> None:
    s = BusSession(zero_reply_grace=GRACE)
    s.other_hosts = True
    opn = _read(s, timeout=0.1)
    s.receive(ZERO, 0.095)
    assert s.next_deadline() == pytest.approx(0.1)
    s.advance(0.1 - 1e-6)
    assert not opn.done
    s.advance(0.1)
    assert opn.done and opn.error is None and opn.result()[0].value == 0.0
    assert s.next_deadline() is None and len(s.matcher) == 0
