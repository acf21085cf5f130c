"""Another host's frames on the bus: never a motor's state, never an answer; counted as foreign.

State frames have bit 0 set; 0x01..0x17 are always a motor's. 0x19, 0x1B, 0x1D and 0x1F are also the
host commands T, P, C and write: once a motor's answers showed bits 3-4 sent as 0, such a frame is another
host's and carries no state (spec/PROTOCOL.md 1.6; tests/client/engine/test_status_bits.py for the other cases).
"""

from __future__ import annotations

import pytest

from drempower.client.engine import batch
from drempower.client.engine.effects import read_states
from drempower.client.engine.session import BusSession
from drempower.client.engine.state import MotorState
from drempower.protocol import PositionT, State
from drempower.protocol.ids import Frame
from drempower.protocol.messages import STATE_CMDS

FAST_READ_2 = Frame(0x05E, bytes(8))
"""Motor 2, fast read (golden)."""
OTHER_HOSTS_WRITE = Frame(0x05F, bytes.fromhex("EE79030001000000"))
"""Another host writes enable_reply_state (31214, u32) = 1 to motor 2 (golden): command 0x1F."""
STATE_2 = Frame(0x047, bytes.fromhex("0000B4420000E803"))
"""Motor 2's state: 90 deg, 0 r/min, 10 Nm, T and E set (command 0x07, golden)."""


def test_another_hosts_write_after_a_fast_read_is_no_state() -> None:
    s = BusSession(timeout=0.05)
    opn = s.submit(read_states([2]))
    assert s.data_to_send() == [FAST_READ_2]
    returned = s.receive(OTHER_HOSTS_WRITE, 0.001)
    assert returned == OTHER_HOSTS_WRITE  # handed on as a frame, not as a MotorState
    assert not opn.done and 2 not in s.known.states
    assert (s.foreign, s.unmatched, s.malformed, s.other_hosts) == (1, 1, 0, True)
    st = s.receive(STATE_2, 0.002)
    assert isinstance(st, MotorState) and (st.node, st.angle, st.torque, st.trajectory_done, st.error) == (
        2,
        90.0,
        10.0,
        True,
        True,
    )
    assert opn.result() == [st] and s.known.states[2] == st


@pytest.mark.parametrize("cmd", [0x19, 0x1B, 0x1D, 0x1F])
def test_host_commands_with_bit_0_set_update_nothing(cmd: int) -> None:
    s = BusSession(timeout=0.05)
    first = s.submit(read_states([2]))
    s.data_to_send()
    s.receive(STATE_2, 0.001)  # an answer with bits 3-4 zero: motor 2's firmware sends them as 0
    assert first.done and s.inbox.bits.of(2) == "zero"
    before = s.known.states[2]
    opn = s.submit(read_states([2]))
    s.data_to_send()
    frame = Frame((2 << 5) | cmd, bytes.fromhex("0000C8420A001400"))
    assert s.receive(frame, 0.002) == frame
    assert s.known.states[2] is before and not opn.done and s.foreign == 1
    s.advance(1.0)
    assert opn.done and opn.error is not None  # the request timed out: nothing answered it


@pytest.mark.parametrize("cmd", sorted(STATE_CMDS))
def test_state_frames_and_heartbeats_still_update_the_cache(cmd: int) -> None:
    s = BusSession()
    st = s.receive(Frame((3 << 5) | cmd, bytes.fromhex("0000B4420000E803")), 0.5)
    assert isinstance(st, MotorState) and s.known.states[3] == st and st.angle == 90.0
    assert (st.trajectory_done, st.error) == (bool(cmd & 2), bool(cmd & 4))
    assert (s.foreign, s.unmatched) == (0, 0)


def test_state_command_values() -> None:
    assert sorted(STATE_CMDS) == [0x01, 0x03, 0x05, 0x07, 0x09, 0x0B, 0x0D, 0x0F, 0x11, 0x13, 0x15, 0x17]
    for spare in (0, 1, 2):
        assert State(1, 0.0, 0.0, 0.0, True, True, spare).encode().arbitration_id & 0x1F in STATE_CMDS


def test_another_hosts_fast_read_is_foreign_not_malformed() -> None:
    s = BusSession()
    assert s.receive(FAST_READ_2, 0.001) == FAST_READ_2
    assert (s.foreign, s.malformed, s.other_hosts) == (1, 0, True)


def test_a_cycle_takes_no_other_hosts_position_command_as_a_reply_state() -> None:
    s = BusSession(timeout=0.05)
    s.inbox.bits.default = "zero"  # a profile says so (else: undecidable during the first wait, PROTOCOL.md 1.6)
    opn = s.submit(batch.cycle(s, [PositionT(2, 10.0, 50.0)], reply_state=True))
    s.data_to_send()
    other = PositionT(2, 45.0, 0.0, 20.0).encode()  # another host: T (0x19) to motor 2
    assert other.arbitration_id == 0x059
    assert s.receive(other, 0.001) == other and not opn.done and 2 not in s.known.states
    s.receive(STATE_2, 0.002)
    assert opn.result()[2].angle == 90.0
