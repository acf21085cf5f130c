"""Request matching on scripted time: every echoed field, broadcast, one request per motor at a time,
retries, missing_ok; a request expires at exactly its timeout."""

from __future__ import annotations

from typing import Any

import pytest

from drempower.client.engine.effects import read_states, request
from drempower.client.engine.session import BusSession, Operation
from drempower.client.engine.state import MotorState
from drempower.client.errors import TimeoutError
from drempower.protocol import DataType, FastRead, ParamValue, ReadParam
from drempower.protocol.ids import Frame

from .rig import Rig

VBUS = 1  # vbus_voltage, f32
TRAJ_MODE = 35104  # axis0.trap_traj.config.traj_mode, u32
READ_VBUS_1 = Frame(0x03E, bytes.fromhex("0100000000000000"))
"""Motor 1, read 0x1E of address 1 as f32 (golden)."""
VBUS_1_IS_24 = Frame(0x03E, bytes.fromhex("010000000000c041"))
"""Motor 1's reply: address 1, f32, 24.0."""


def _read_vbus(s: BusSession, timeout: float | None = None) -> Operation[list[Any]]:
    opn = s.submit(request([ReadParam(1, VBUS, DataType.F32)], timeout))
    assert s.data_to_send() == [READ_VBUS_1]
    return opn


def test_the_reply_with_every_field_answers() -> None:
    s = BusSession()
    opn = _read_vbus(s)
    assert s.receive(VBUS_1_IS_24, 0.004) is None
    assert opn.done and opn.result() == [ParamValue(1, VBUS, DataType.F32, 24.0)]
    assert (s.anomalies, s.unmatched, len(s.matcher), s.next_deadline()) == (0, 0, 0, None)
    assert s.known.heard == {1}


@pytest.mark.parametrize(
    "reply",
    [
        ParamValue(2, VBUS, DataType.F32, 24.0),  # another motor
        ParamValue(1, 30001, DataType.U32, 5),  # another parameter
        Frame(0x027, bytes.fromhex("0000c04100000000")),  # a state of motor 1 (no answer to a parameter read)
    ],
)
def test_a_reply_of_another_motor_or_parameter_answers_nothing(reply: ParamValue | Frame) -> None:
    s = BusSession()
    opn = _read_vbus(s)
    frame = reply.encode() if isinstance(reply, ParamValue) else reply
    returned = s.receive(frame, 0.01)
    assert not opn.done and len(s.matcher) == 1 and s.anomalies == 0
    assert returned == frame if isinstance(reply, ParamValue) else isinstance(returned, MotorState)
    s.receive(VBUS_1_IS_24, 0.02)
    assert opn.result()[0].value == 24.0


@pytest.mark.parametrize(("dtype", "value"), [(DataType.S16, 7), (DataType.U32, 24), (DataType.S16, 0)])
def test_a_reply_of_another_data_type_is_an_anomaly_and_the_request_expires_at_its_timeout(
    dtype: DataType, value: int
) -> None:
    s = BusSession(timeout=0.1)
    opn = _read_vbus(s)
    wrong = ParamValue(1, VBUS, dtype, value).encode()
    assert s.receive(wrong, 0.003) == wrong
    assert (s.anomalies, s.unmatched, len(s.matcher)) == (1, 1, 1)
    assert s.next_deadline() == pytest.approx(0.1, abs=1e-12)
    s.advance(0.1 - 1e-6)
    assert not opn.done and len(s.matcher) == 1
    s.advance(0.1)
    assert opn.done and len(s.matcher) == 0 and s.next_deadline() is None
    with pytest.raises(TimeoutError) as info:
        opn.result()
    assert info.value.nodes == (1,) and info.value.timeout == 0.1
    assert "motor 1" in str(info.value) and "vbus_voltage (1)" in str(info.value)


def test_the_right_reply_after_a_wrong_type_one_still_answers() -> None:
    s = BusSession()
    opn = _read_vbus(s)
    s.receive(ParamValue(1, VBUS, DataType.S16, 0).encode(), 0.002)
    s.receive(VBUS_1_IS_24, 0.003)
    assert opn.result()[0].value == 24.0 and s.anomalies == 1


def test_a_request_with_its_own_timeout_expires_then() -> None:
    s = BusSession(timeout=0.1)
    opn = _read_vbus(s, timeout=0.25)
    assert s.next_deadline() == 0.25
    s.advance(0.2)
    assert not opn.done
    s.advance(0.25)
    assert isinstance(opn.error, TimeoutError) and opn.error.timeout == 0.25


def test_broadcast_reads_are_answered_by_any_motor() -> None:
    rig = Rig([7])
    rig.motors[7].params[31001] = 7
    opn = rig.run(request([ReadParam(0, 31001, DataType.U32)]))
    assert opn.result() == [ParamValue(7, 31001, DataType.U32, 7)]
    states = rig.run(read_states([0])).result()
    assert states[0] is not None and states[0].node == 7
    assert [c for _, c in rig.wire] == [ReadParam(0, 31001, DataType.U32), FastRead(0)]


def test_requests_to_one_motor_go_one_at_a_time_and_to_different_motors_together() -> None:
    rig = Rig([1, 2])
    rig.motors[1].params = {VBUS: 24.0, TRAJ_MODE: 2}
    rig.motors[2].params = {VBUS: 48.0}
    rig.motors[1].lag = 0.004
    msgs = [ReadParam(1, VBUS, DataType.F32), ReadParam(1, TRAJ_MODE, DataType.U32), ReadParam(2, VBUS, DataType.F32)]
    opn = rig.submit(request(msgs))
    assert rig.take() == [msgs[0], msgs[2]]
    rig.at(0.0039)
    assert rig.take() == []  # motor 1's first reply is not in yet
    rig.at(0.004)
    assert rig.take() == [msgs[1]]
    rig.settle(lambda: opn.done)
    assert [r.value for r in opn.result()] == [24.0, 2, 48.0]
    assert [t for t, _ in rig.wire] == [0.0, 0.0, 0.004]


def test_retries_send_again_only_the_silent_motor_at_each_timeout_then_name_it() -> None:
    rig = Rig([1, 2], timeout=0.1, retries=2)
    rig.motors[2].silent = True
    opn = rig.run(read_states([1, 2]))
    assert [(round(t, 9), c.node) for t, c in rig.sent(FastRead)] == [(0, 1), (0, 2), (0.1, 2), (0.2, 2)]
    assert rig.now == pytest.approx(0.3)
    with pytest.raises(TimeoutError, match="motor 2: no answer to a fast read") as info:
        opn.result()
    assert info.value.nodes == (2,)


def test_a_retry_that_is_answered_succeeds() -> None:
    rig = Rig([1], timeout=0.1, retries=1)
    rig.motors[1].silent = True
    opn = rig.submit(read_states([1]))
    rig.take()
    rig.at(0.1)
    rig.motors[1].silent = False
    rig.settle(lambda: opn.done)
    assert rig.now == pytest.approx(0.101) and opn.result()[0] is not None
    assert len(rig.sent(FastRead)) == 2


def test_missing_ok_returns_none_for_the_silent_motor_at_the_timeout() -> None:
    rig = Rig([1, 2, 3], timeout=0.1)
    rig.motors[2].silent = True
    opn = rig.run(read_states([1, 2, 3], missing_ok=True))
    states = opn.result()
    assert [None if st is None else st.node for st in states] == [1, None, 3]
    assert rig.now == pytest.approx(0.1) and len(rig.wire) == 3
