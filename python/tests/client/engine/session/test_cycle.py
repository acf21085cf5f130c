"""The control cycle on scripted time: what goes out, what answers it, what it records, how it ends."""

from __future__ import annotations

import pytest

from drempower.client.engine import batch
from drempower.client.engine.effects import Cycle
from drempower.client.engine.session import BusSession, idle_frames
from drempower.client.errors import TimeoutError
from drempower.errors import ValidationError
from drempower.protocol import (
    DataType,
    FastRead,
    ParamValue,
    PositionT,
    PresetT,
    ReadParam,
    Start,
    StartKind,
    State,
    Velocity,
    decode_command,
)
from drempower.protocol.ids import Frame

from .rig import Rig

_REPLY_STATE = 31214


def _state(node: int, angle: float = 0.0, done: bool = False) -> Frame:
    return State(node, angle, 0.0, 0.0, done, False).encode()


def _sent(s: BusSession) -> list[object]:
    return [decode_command(f.arbitration_id, f.data) for f in s.data_to_send()]


def test_a_cycle_with_reply_state_sends_the_commands_only_and_returns_each_state() -> None:
    s = BusSession(timeout=0.05, now=1.0)
    cmds = [PositionT(1, 10.0, 50.0), PositionT(2, -5.0, 50.0)]
    run = batch.cycle(s, cmds, reply_state=True)
    assert isinstance(run, Cycle)
    opn = s.submit(run)
    assert _sent(s) == cmds
    s.receive(_state(2, -4.0), 1.001)
    assert not opn.done
    s.receive(_state(1, 9.0), 1.002)
    got = opn.result()
    assert list(got) == [1, 2]
    assert (got[1].angle, got[2].angle, got[1].timestamp) == (9.0, -4.0, 1.002)
    assert s.known.heard >= {1, 2} and s.next_deadline() is None and len(s.matcher) == 0


def test_a_cycle_records_what_its_commands_change_so_that_closing_stops_the_motors() -> None:
    s = BusSession(now=2.0)
    s.submit(batch.cycle(s, [PositionT(1, 10.0, 50.0), Velocity(2, 3.0)], reply_state=True))
    s.data_to_send()
    assert s.known.commanded == {1, 2}
    assert (
        s.known.moves[1].target == 10.0
        and s.known.moves[1].sent == 2.0
        and s.known.moves[1].resend == (PositionT(1, 10.0, 50.0),)
    )
    assert 2 not in s.known.moves  # a speed command ends any position move
    assert s.stop_frames() == idle_frames([1, 2])


def test_a_start_after_a_cycle_of_presets_goes_out_at_once() -> None:
    s = BusSession(tx="timed", bitrate=1_000_000, tx_latency=0.005)
    opn = s.submit(batch.cycle(s, [PresetT(n, 30.0, 20.0) for n in (1, 2)], reply_state=True))
    s.data_to_send()
    s.receive(_state(1), 0.0003)
    s.receive(_state(2), 0.0005)
    assert set(opn.result()) == {1, 2} and s.known.commanded == {1, 2}
    assert s.send([Start(0, StartKind.T)]) is None  # not held for the answered presets
    assert _sent(s) == [Start(0, StartKind.T)]


def test_a_preset_cycled_to_one_motor_keeps_a_later_batch_of_others_from_broadcasting_its_start() -> None:
    from drempower.client.engine.effects import Batch

    s = BusSession(tx="in_order")
    opn = s.submit(batch.cycle(s, [PresetT(3, 30.0, 20.0)], reply_state=True))
    s.data_to_send()
    s.receive(_state(3), 0.001)
    assert opn.done and s.sequencer.pending_presets == {3}

    def move() -> object:
        yield Batch([PresetT(1, 10.0, 20.0), PresetT(2, 20.0, 20.0)], Start(0, StartKind.T))

    s.submit(move())
    # a broadcast start would also fire motor 3's preset: each motor of the batch gets its own
    expected = [PresetT(1, 10.0, 20.0), PresetT(2, 20.0, 20.0), Start(1, StartKind.T), Start(2, StartKind.T)]
    assert s.data_to_send() == [m.encode() for m in expected]
    assert s.sequencer.pending_presets == {3}


def test_a_cycle_whose_frames_do_not_match_its_messages_is_refused_and_leaves_nothing_waiting() -> None:
    s = BusSession()
    opn = s.submit(Cycle([Velocity(1, 1.0)], [], [1]))
    assert opn.done
    with pytest.raises(ValidationError, match="1 messages came with 0 frames"):
        opn.result()
    assert s.data_to_send() == []
    assert s.receive(_state(1), 0.0) is not None  # a state as any other, no stale waiter behind it
    read = s.submit(batch.read_states([1]))
    s.data_to_send()
    s.receive(_state(1, 5.0), 0.001)
    assert read.result()[0].angle == pytest.approx(5.0)


def test_motors_without_reply_state_get_a_fast_read_after_the_commands() -> None:
    s = BusSession()
    cmds = [PositionT(1, 1.0, 50.0), PositionT(2, 2.0, 50.0)]
    s.submit(batch.cycle(s, cmds, reply_state=False))
    assert _sent(s) == [*cmds, FastRead(1), FastRead(2)]


def test_an_unknown_reply_state_is_read_once_then_the_cycle_follows() -> None:
    rig = Rig((1, 2))
    rig.motors[1].params[_REPLY_STATE] = 1
    s = rig.session
    cmds = [PositionT(1, 1.0, 50.0), PositionT(2, 2.0, 50.0)]
    run = batch.cycle(s, cmds)
    assert not isinstance(run, Cycle)
    opn = s.submit(run)
    assert rig.take() == [ReadParam(1, _REPLY_STATE, DataType.U32), ReadParam(2, _REPLY_STATE, DataType.U32)]
    rig.at(0.002)
    assert s.known.reply_state == {1: True, 2: False}
    assert rig.take() == [*cmds, FastRead(2)]  # motor 1 answers its command itself
    s.receive(_state(1, 1.5), 0.003)
    rig.at(0.004)  # motor 2's fast read answered
    assert set(opn.result()) == {1, 2} and opn.result()[1].angle == 1.5
    # known now: the next cycle reads nothing first
    assert isinstance(batch.cycle(s, cmds), Cycle)


def test_a_cycle_times_out_at_its_timeout_naming_the_silent_motors() -> None:
    s = BusSession(timeout=0.02, now=5.0)
    opn = s.submit(batch.cycle(s, [Velocity(n, 1.0) for n in (1, 2, 3)], reply_state=True))
    s.data_to_send()
    s.receive(_state(2), 5.001)
    assert s.next_deadline() == pytest.approx(5.02)
    s.advance(5.02 - 1e-6)
    assert not opn.done
    s.advance(5.02)
    with pytest.raises(TimeoutError, match="motors 1, 3: no answer to a control cycle") as info:
        opn.result()
    assert info.value.nodes == (1, 3) and len(s.matcher) == 0
    assert s.receive(_state(1), 5.03).node == 1  # a late state answers nothing: it is only a state


def test_a_parameter_reply_answers_no_cycle() -> None:
    s = BusSession(timeout=0.02)
    opn = s.submit(batch.cycle(s, [Velocity(1, 1.0)], reply_state=True))
    reply = ParamValue(1, _REPLY_STATE, DataType.U32, 1).encode()
    assert s.receive(reply, 0.001) == reply and not opn.done


def test_a_cancelled_cycle_stops_waiting() -> None:
    s = BusSession()
    opn = s.submit(batch.cycle(s, [Velocity(1, 1.0)], reply_state=True))
    s.cancel(opn)
    assert opn.done and len(s.matcher) == 0 and s.next_deadline() is None


def test_a_refused_cycle_sends_nothing() -> None:
    s = BusSession()

    def refuse(msgs: object) -> None:
        raise ValidationError("refused")

    s.check_request = refuse
    opn = s.submit(batch.cycle(s, [Velocity(1, 1.0)], reply_state=True))
    with pytest.raises(ValidationError, match="refused"):
        opn.result()
    assert s.data_to_send() == [] and len(s.matcher) == 0
