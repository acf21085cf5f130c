"""Presets and starts on scripted time: a start is released only once its presets are on the wire
(timed from the bit rate, confirmed by the transport, or in order), where it goes, the moves it records,
and what goes before it."""

from __future__ import annotations

from collections.abc import Sequence

import pytest

from drempower.client.engine.effects import Batch, Op
from drempower.client.engine.session import Operation, StartPolicy
from drempower.client.errors import TimeoutError
from drempower.errors import BusStoppedError
from drempower.protocol import (
    FastRead,
    PositionT,
    Preset,
    PresetQ,
    PresetT,
    ReadParam,
    Start,
    StartKind,
    State,
    SysCmd,
    SystemCommand,
    WriteParam,
)
from drempower.protocol.messages import Command

from .rig import Rig

IDS = (1, 2, 3)
TARGETS = (10.0, 20.0, 30.0)
FRAME_BITS = 135


def _batch(nodes: Sequence[int] = IDS, move_time: float | None = None) -> Op[list[int]]:
    presets = [PresetT(n, 10.0 * n, 20.0) for n in nodes]
    where: list[int] = yield Batch(presets, Start(0, StartKind.T), [10.0 * n for n in nodes], move_time)
    return where


def _starts(cmds: Sequence[Command]) -> list[int]:
    return [c.node for c in cmds if isinstance(c, Start)]


def _kinds(cmds: Sequence[Command]) -> list[str]:
    return [f"{type(c).__name__}{c.node}" for c in cmds]


@pytest.mark.parametrize(("bitrate", "latency"), [(125_000, 0.005), (1_000_000, 0.0), (10_000, 0.002)])
def test_timed_the_start_goes_out_at_the_bus_time_of_its_presets_plus_the_latency(bitrate: int, latency: float) -> None:
    rig = Rig(tx="timed", bitrate=bitrate, tx_latency=latency)
    rig.at(0.5)
    opn = rig.submit(_batch())
    assert _kinds(rig.take()) == ["Preset1", "Preset2", "Preset3"]
    due = 0.5 + 3 * FRAME_BITS / bitrate + latency
    assert rig.session.next_deadline() == pytest.approx(due, abs=1e-12)
    rig.at(due - 1e-6)
    assert rig.take() == [] and not opn.done
    rig.at(due)
    assert _kinds(rig.take()) == ["Start0"] and opn.result() == [0]


def test_timed_frames_handed_over_earlier_count_in_the_bus_time() -> None:
    rig = Rig(tx="timed", bitrate=10_000, tx_latency=0.0)
    rig.session.send([FastRead(1), FastRead(2)])
    rig.take()  # two frames on the wire from t = 0: busy until 27 ms
    rig.at(0.001)
    rig.submit(_batch([1]))
    rig.take()
    assert rig.session.next_deadline() == pytest.approx(3 * FRAME_BITS / 10_000)


def test_timed_a_start_is_never_released_before_its_presets_are_handed_over() -> None:
    rig = Rig(tx="timed", bitrate=1_000_000, tx_latency=0.0)
    opn = rig.submit(_batch())
    rig.at(5.0)  # nobody took the presets
    assert not opn.done and _kinds(rig.take()) == ["Preset1", "Preset2", "Preset3"]
    rig.at(5.0 + 3 * FRAME_BITS / 1_000_000)
    assert _kinds(rig.take()) == ["Start0"]


def test_in_order_the_start_follows_its_presets_at_once() -> None:
    rig = Rig(tx="in_order")
    opn = rig.submit(_batch())
    assert _kinds(rig.take()) == ["Preset1", "Preset2", "Preset3", "Start0"]
    assert opn.result() == [0] and rig.session.next_deadline() is None


def test_confirmed_the_start_is_released_by_the_confirmation() -> None:
    rig = Rig(tx="confirmed", timeout=0.05)
    opn = rig.submit(_batch())
    s = rig.session
    assert not s.awaiting_confirmation  # the presets are not handed over yet
    rig.take()
    assert s.awaiting_confirmation and s.next_deadline() == pytest.approx(0.1)
    s.transmitted(0.004, False)  # not yet: it keeps waiting
    assert rig.take() == [] and not opn.done
    s.transmitted(0.006, True)
    assert _kinds(rig.take()) == ["Start0"] and opn.result() == [0]
    assert s.known.moves[1].sent == 0.006 and not s.awaiting_confirmation


@pytest.mark.parametrize(("timeout", "wait"), [(0.05, 0.1), (0.3, 0.3)])
def test_confirmed_without_confirmation_the_batch_fails_at_the_longer_of_timeout_and_100_ms(
    timeout: float, wait: float
) -> None:
    rig = Rig(tx="confirmed", timeout=timeout)
    opn = rig.submit(_batch())
    rig.take()
    rig.at(wait - 1e-6)
    assert not opn.done
    rig.at(wait)
    assert rig.take() == []
    with pytest.raises(TimeoutError, match="the transmission of the presets") as info:
        opn.result()
    assert info.value.nodes == IDS and info.value.timeout == wait
    assert rig.session.next_deadline() is None and not rig.session.known.moves


def test_confirmed_falls_back_to_the_bus_time_when_the_transport_cannot_tell() -> None:
    rig = Rig(tx="confirmed", bitrate=125_000, tx_latency=0.005)
    opn = rig.submit(_batch())
    rig.take()
    rig.session.transmitted(0.001, None)
    due = 3 * FRAME_BITS / 125_000 + 0.005
    assert not rig.session.awaiting_confirmation
    assert rig.session.next_deadline() == pytest.approx(due)
    rig.at(due - 1e-6)
    assert rig.take() == []
    rig.at(due)
    assert _kinds(rig.take()) == ["Start0"] and opn.result() == [0]


@pytest.mark.parametrize(
    ("policy", "nodes", "motor_ids", "where"),
    [
        ("auto", [2], (), [2]),
        ("auto", [1, 2, 3], (), [1, 2, 3]),  # another command's presets may wait elsewhere: never broadcast
        ("auto", [1, 2, 3], (1, 2, 3), [0]),  # every motor of the bus is in the move
        ("auto", [1, 2], (1, 2, 3), [1, 2]),
        ("broadcast", [2], (), [0]),
        ("node", [1, 2, 3], (1, 2, 3), [1, 2, 3]),
    ],
)
def test_start_policy(policy: StartPolicy, nodes: list[int], motor_ids: tuple[int, ...], where: list[int]) -> None:
    rig = Rig(tx="in_order", start=policy, motor_ids=motor_ids)
    opn = rig.submit(_batch(nodes))
    cmds = rig.take()
    assert _starts(cmds) == where and opn.result() == where
    assert [c.node for c in cmds if isinstance(c, Preset)] == nodes
    assert rig.session.sequencer.pending_presets == set()


def test_a_failed_batch_leaves_its_motors_marked_so_later_starts_go_per_motor() -> None:
    rig = Rig(tx="confirmed")
    failed = rig.submit(_batch([1, 2, 3]))
    rig.take()
    rig.at(0.1)
    assert isinstance(failed.error, TimeoutError)
    assert rig.session.sequencer.pending_presets == {1, 2, 3}  # they hold presets no start consumed
    s = rig.session
    opn = rig.submit(_batch([1, 2]))
    rig.take()
    s.transmitted(0.2, True)
    assert _starts(rig.take()) == [1, 2] and opn.result() == [1, 2]  # a broadcast would fire motor 3
    assert s.sequencer.pending_presets == {3}
    again = rig.submit(_batch([1, 2, 3]))
    rig.take()
    s.transmitted(0.3, True)
    assert _starts(rig.take()) == [0] and again.result() == [0] and s.sequencer.pending_presets == set()


def test_a_node_start_through_send_consumes_only_its_preset() -> None:
    rig = Rig(tx="in_order")
    s = rig.session
    s.send([PresetT(1, 15.0, 20.0), PresetT(2, 25.0, 20.0), Start(1, StartKind.T)])
    assert _kinds(rig.take()) == ["Preset1", "Preset2", "Start1"]
    assert s.sequencer.pending_presets == {2} and list(s.known.moves) == [1] and s.known.moves[1].target == 15.0
    rig.submit(_batch([1, 3]))
    assert _starts(rig.take()) == [1, 3]


def test_moves_are_recorded_with_target_sent_time_and_move_time() -> None:
    rig = Rig(tx="timed", bitrate=1_000_000, tx_latency=0.001)
    rig.at(2.0)
    rig.submit(_batch(move_time=0.75))
    rig.take()
    released = 2.0 + 3 * FRAME_BITS / 1_000_000 + 0.001
    rig.at(released)
    rig.take()
    moves = rig.session.known.moves
    assert [(n, mv.target, mv.move_time, mv.took) for n, mv in moves.items()] == [
        (n, 10.0 * n, 0.75, None) for n in IDS
    ]
    assert [mv.sent for mv in moves.values()] == [pytest.approx(released)] * 3
    assert moves[2].resend == (PresetT(2, 20.0, 20.0), Start(2, StartKind.T))


def test_presets_and_a_q_start_through_send_record_the_preset_targets_and_time() -> None:
    rig = Rig(tx="in_order")
    s = rig.session
    rig.at(1.0)
    s.send([PresetQ(1, 30.0, 1.5, 200.0), PresetQ(2, -30.0, 1.5, 200.0), Start(0, StartKind.Q)])
    assert _kinds(rig.take()) == ["Preset1", "Preset2", "Start0"]
    assert [(n, mv.target, mv.move_time, mv.sent) for n, mv in s.known.moves.items()] == [
        (1, 30.0, 1.5, 1.0),
        (2, -30.0, 1.5, 1.0),
    ]
    s.send([PositionT(2, 45.0, 20.0)])
    assert s.known.moves[2].target == 45.0 and s.known.moves[2].move_time is None and s.known.commanded == {1, 2}


def test_a_second_batch_goes_out_after_the_held_start_in_order() -> None:
    rig = Rig(tx="timed", bitrate=125_000, tx_latency=0.0, motor_ids=(1, 2))  # the first batch moves every motor
    first: Operation[list[int]] = rig.submit(_batch([1, 2]))
    assert _kinds(rig.take()) == ["Preset1", "Preset2"]
    second = rig.submit(_batch([3]))
    assert rig.take() == []  # its preset waits behind the held start
    frame = FRAME_BITS / 125_000
    rig.at(2 * frame)
    assert _kinds(rig.take()) == ["Start0", "Preset3"] and first.result() == [0]
    assert not second.done and rig.session.next_deadline() == pytest.approx(4 * frame)
    rig.at(4 * frame)
    assert _kinds(rig.take()) == ["Start3"] and second.result() == [3]


def test_an_estop_drops_a_start_held_for_its_presets() -> None:
    rig = Rig(tx="timed", bitrate=125_000)
    s = rig.session
    opn = rig.submit(_batch([1, 2]))
    assert _kinds(rig.take()) == ["Preset1", "Preset2"]
    s.estop([2])
    assert rig.take() == [SystemCommand(2, SysCmd.ESTOP)]
    assert opn.done and isinstance(opn.error, BusStoppedError)
    assert "motor 2" in str(opn.error)
    rig.settle(until=1.0)  # the hold's time passes: nothing more goes out
    assert rig.take() == [] and not [c for _, c in rig.sent() if isinstance(c, Start)]
    assert s.sequencer.pending_presets == {1, 2}  # marked: no later broadcast start fires them
    assert s.next_deadline() is None


def test_an_estop_drops_the_batches_queued_behind_a_held_start() -> None:
    rig = Rig(tx="confirmed")
    s = rig.session
    first = rig.submit(_batch([1, 2]))
    second = rig.submit(_batch([3]))  # waits behind the first's held start
    assert _kinds(rig.take()) == ["Preset1", "Preset2"]
    s.stopped([0])  # an estop the driver wrote without the session lock
    for opn in (first, second):
        assert opn.done and isinstance(opn.error, BusStoppedError) and "every motor" in str(opn.error)
    s.transmitted(rig.now, True)
    rig.settle(until=1.0)
    assert rig.take() == [] and [type(c).__name__ for _, c in rig.sent()] == ["Preset", "Preset"]


def test_an_estop_goes_before_everything_queued() -> None:
    rig = Rig(tx="timed", bitrate=125_000)
    s = rig.session
    s.send([WriteParam.of(1, "axis0.output_shaft.vel_limit", 100.0), FastRead(2)])
    rig.submit(_batch([1, 2]))
    s.estop([0])
    cmds = rig.take()
    assert cmds[0] == SystemCommand(0, SysCmd.ESTOP)
    assert _kinds(cmds[1:]) == ["WriteParam1", "FastRead2", "Preset1", "Preset2"]
    s.estop([1, 2])  # while a start is held, too
    assert rig.take() == [SystemCommand(1, SysCmd.ESTOP), SystemCommand(2, SysCmd.ESTOP)]


def test_answered_the_start_waits_for_fast_reads_sent_after_the_presets() -> None:
    """Over a link of unbounded delay (socketcand): a read has a higher id than its motor's preset, so its
    reply proves the preset was on the wire (a heartbeat cannot pass for it: the reply echoes the address)."""
    rig = Rig(tx="answered")
    for m in rig.motors.values():
        m.params[31001] = m.node  # can_node_id
    opn = rig.submit(_batch([1, 2, 3]))
    assert _kinds(rig.take()) == ["Preset1", "Preset2", "Preset3", "ReadParam1", "ReadParam2", "ReadParam3"]
    assert rig.session.receive(State(1, 0.0, 0.0, 0.0, True, False).encode(), 0.0002) is not None  # a heartbeat
    assert not opn.done
    assert not rig.session.awaiting_confirmation  # nothing to ask the transport
    rig.at(0.0005)
    assert rig.take() == [] and not opn.done  # the answers are 1 ms away
    rig.at(0.001)
    assert _kinds(rig.take()) == ["Start0"] and opn.result() == [0]
    assert len(rig.session.matcher) == 0


@pytest.mark.parametrize("retries", [0, 2])
def test_answered_a_silent_motor_fails_the_batch_and_sends_no_start(retries: int) -> None:
    rig = Rig(tx="answered", timeout=0.2, retries=retries)
    for m in rig.motors.values():
        m.params[31001] = m.node
    rig.motors[2].silent = True
    opn = rig.submit(_batch([1, 2, 3]))
    rig.settle(lambda: opn.done, until=5.0)
    assert isinstance(opn.error, TimeoutError) and opn.error.nodes == (2,)
    assert rig.now == pytest.approx(0.2 * (1 + retries))
    assert [c.node for _, c in rig.sent(ReadParam)] == [1, 2, 3] + [2] * retries  # only the silent one again
    assert rig.sent(Start) == [] and rig.session.sequencer.pending_presets == {1, 2, 3}
    assert len(rig.session.matcher) == 0


def test_answered_an_estop_drops_the_held_start_and_its_fast_reads() -> None:
    rig = Rig(tx="answered")
    s = rig.session
    opn = rig.submit(_batch([1, 2]))
    rig.take()
    s.estop([1])
    assert opn.done and isinstance(opn.error, BusStoppedError)
    assert len(s.matcher) == 0
    rig.settle(until=1.0)
    assert rig.sent(Start) == []
