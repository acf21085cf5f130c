"""The session's parts on their own, on scripted time: the timers, what is known about each motor, the
outbox's bus time, the zero-reply grace and the held start's state machine."""

from __future__ import annotations

import functools

import pytest

from drempower.client.engine.grace import ZeroReplyGrace
from drempower.client.engine.hold import TRANSITIONS, HoldEvent, HoldState
from drempower.client.engine.known import Known
from drempower.client.engine.outbox import ASSUMED_BITRATE, Outbox
from drempower.client.engine.requests import Matcher, Waiter
from drempower.client.engine.session import BusSession
from drempower.client.engine.stats import BusStats
from drempower.client.engine.timers import Timers
from drempower.client.errors import TimeoutError
from drempower.protocol import (
    DataType,
    FastRead,
    ParamValue,
    PositionT,
    PresetT,
    ReadParam,
    SysCmd,
    SystemCommand,
    Velocity,
    WriteParam,
)
from drempower.protocol.addresses import (
    AXIS0_CONFIG_CAN_NODE_ID,
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE,
    AXIS0_REQUESTED_STATE,
    AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE,
)

TRAJ = AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE
REPLY = AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE


# ---------------------------------------------------------------------- timers


def test_timers_fire_in_due_order_and_not_before_their_time() -> None:
    timers = Timers()
    fired: list[str] = []
    for due, name in ((0.3, "c"), (0.1, "a"), (0.2, "b"), (0.2, "b2")):
        timers.add(due, functools.partial(fired.append, name))
    assert timers.next_due() == 0.1
    timers.fire_due(0.05)
    assert fired == []
    timers.fire_due(0.2)
    assert fired == ["a", "b", "b2"]  # equal due times fire in the order they were set
    assert timers.next_due() == 0.3 and len(timers) == 1
    timers.fire_due(1.0)
    assert fired == ["a", "b", "b2", "c"] and timers.next_due() is None


def test_a_dropped_timer_never_fires_and_no_longer_sets_the_deadline() -> None:
    timers = Timers()
    fired: list[float] = []
    first = timers.add(0.1, lambda: fired.append(0.1))
    timers.add(0.5, lambda: fired.append(0.5))
    timers.drop(first)
    timers.drop(first)  # twice: nothing happens
    assert timers.next_due() == 0.5
    timers.fire_due(0.4)
    assert fired == []
    timers.fire_due(0.5)
    assert fired == [0.5]


def test_a_timer_set_while_timers_fire_waits_for_the_next_call_even_when_already_due() -> None:
    timers = Timers()
    fired: list[str] = []

    def first() -> None:
        fired.append("first")
        timers.add(0.0, lambda: fired.append("set while firing"))  # due at once, but not in this round

    timers.add(0.1, first)
    changes = timers.changes
    timers.fire_due(0.1)
    assert fired == ["first"] and timers.changes == changes + 1
    timers.fire_due(0.1)
    assert fired == ["first", "set while firing"]


def test_a_timer_that_raises_leaves_the_timers_set_while_firing_due() -> None:
    timers = Timers()
    fired: list[str] = []

    def first() -> None:
        timers.add(0.0, lambda: fired.append("set while firing"))

    def failing() -> None:
        raise RuntimeError("boom")

    timers.add(0.1, first)
    timers.add(0.2, failing)
    with pytest.raises(RuntimeError, match="boom"):
        timers.fire_due(0.2)
    assert timers.next_due() == 0.0
    timers.fire_due(0.2)
    assert fired == ["set while firing"] and timers.next_due() is None


def test_dropped_timers_are_cleared_out_so_a_run_of_answered_requests_keeps_the_heap_small() -> None:
    timers = Timers()
    fired: list[str] = []
    timers.add(50.0, functools.partial(fired.append, "late"))
    timers.add(2.0, functools.partial(fired.append, "soon"))
    for i in range(5000):  # each request's timer, dropped once it is answered
        timers.drop(timers.add(1.0 + i / 1000, functools.partial(fired.append, "dropped")))
        assert len(timers.heap) <= 4 * 64 + 1
    assert len(timers) == 2 and timers.next_due() == 2.0

    def refill() -> None:  # adds and drops while timers fire: the clear-out may happen mid-round
        fired.append("refill")
        for _ in range(300):
            timers.drop(timers.add(3.0, functools.partial(fired.append, "dropped")))
        timers.add(3.0, functools.partial(fired.append, "set while firing"))

    timers.add(2.5, refill)
    timers.fire_due(2.5)
    assert fired == ["soon", "refill"]
    timers.fire_due(3.0)
    assert fired == ["soon", "refill", "set while firing"]
    timers.fire_due(100.0)
    assert fired == ["soon", "refill", "set while firing", "late"] and timers.next_due() is None


def test_touch_counts_a_change_without_a_timer() -> None:
    timers = Timers()
    before = timers.changes
    timers.touch()
    assert timers.changes == before + 1 and timers.next_due() is None


# ---------------------------------------------------------------------- what is known about each motor


def _known() -> Known:
    known = Known()
    for node in (1, 2):
        known.learn(node, TRAJ, 2)
        known.learn(node, REPLY, 1)
    return known


def test_known_forgets_one_node_and_only_that_node() -> None:
    known = _known()
    known.forget(1)
    assert known.traj_mode == {2: 2} and known.reply_state == {2: True}


def test_known_forgets_every_node_for_a_broadcast() -> None:
    known = _known()
    known.forget(0)
    assert known.traj_mode == {} and known.reply_state == {}


def test_known_learns_only_usable_trajectory_modes_and_a_broadcast_write_makes_all_unknown() -> None:
    known = _known()
    known.learn(1, TRAJ, 7)  # no mode a move can be timed with: unknown until read again
    assert known.traj_mode == {2: 2}
    known.learn(0, REPLY, 0)
    assert known.reply_state == {}


def test_known_notes_moves_commanded_motors_and_resets() -> None:
    known = _known()
    move = PositionT(1, 90.0, 10.0)
    known.note(move, move.encode(), 2.5)
    assert known.commanded == {1}
    record = known.moves[1]
    assert (record.target, record.sent, record.resend) == (90.0, 2.5, (move,))
    preset = PresetT(2, 45.0, 10.0)
    known.note(preset, preset.encode(), 3.0)  # a preset commands the motor but moves nothing yet
    assert known.commanded == {1, 2} and 2 not in known.moves
    spin = Velocity(1, 10.0)
    known.note(spin, spin.encode(), 3.0)  # another motion command ends the position move's record
    assert 1 not in known.moves
    idle = WriteParam(3, AXIS0_REQUESTED_STATE, DataType.U32, 1)
    known.note(idle, idle.encode(), 3.0)
    assert known.commanded == {1, 2, 3} and known.traj_mode == {1: 2, 2: 2}
    reboot = SystemCommand(2, SysCmd.REBOOT)
    known.note(reboot, reboot.encode(), 4.0)
    assert known.traj_mode == {1: 2} and known.reply_state == {1: True}


# ---------------------------------------------------------------------- outbox


def test_the_outbox_counts_the_bus_time_of_what_it_hands_over() -> None:
    outbox = Outbox(1_000_000, now=0.0)
    frames = [FastRead(n).encode() for n in (1, 2)]
    outbox.frames.extend(frames)
    assert outbox.take(1.0) == frames and outbox.frames == [] and outbox.handed == 2
    assert outbox.wire_free == pytest.approx(1.0 + 2 * 135e-6)
    outbox.frames.append(frames[0])
    outbox.take(1.0)  # handed while the bus is still busy: it goes after the others
    assert outbox.wire_free == pytest.approx(1.0 + 3 * 135e-6) and outbox.handed == 3
    assert outbox.take(5.0) == [] and outbox.handed == 3
    assert Outbox().bitrate == ASSUMED_BITRATE


# ---------------------------------------------------------------------- the zero-reply grace


def _grace() -> tuple[ZeroReplyGrace, Waiter, Timers]:
    matcher, timers = Matcher(), Timers()
    waiter = Waiter([1 << 16 | REPLY], None, [DataType.U32])
    matcher.register(waiter)
    return ZeroReplyGrace(matcher, BusStats(), timers, grace=0.01), waiter, timers


def test_the_grace_holds_back_a_zero_reply_only_once_another_host_was_seen() -> None:
    grace, waiter, _ = _grace()
    zero = ParamValue(1, REPLY, DataType.U32, 0)
    assert not grace.hold(1, REPLY, DataType.U32, zero, 1.0)  # alone on the bus: it is the answer
    grace.other_hosts = True
    assert not grace.hold(2, REPLY, DataType.U32, zero, 1.0)  # nobody waits for motor 2's reply
    assert grace.held == {} and waiter.results == [None]


def test_a_held_zero_reply_answers_its_request_when_its_grace_ends() -> None:
    grace, waiter, timers = _grace()
    grace.other_hosts = True
    zero = ParamValue(1, REPLY, DataType.U32, 0)
    changes = timers.changes
    assert grace.hold(1, REPLY, DataType.U32, zero, 1.0)
    assert grace.hold(1, REPLY, DataType.U32, zero, 1.005)  # a second one: the first one's grace runs on
    assert grace.next_due() == pytest.approx(1.01) and timers.changes == changes + 1
    grace.settle(1.009)
    assert waiter.results == [None]
    grace.settle(1.01)
    assert waiter.results == [zero] and grace.held == {} and grace.next_due() is None


# ---------------------------------------------------------------------- the held start's state machine


def _state(s: BusSession) -> HoldState | None:
    """The held start's state (None: nothing held)."""
    return None if s.hold.current is None else s.hold.current.state


def _held(tx: str) -> tuple[BusSession, list[float], list[BaseException]]:
    """A session whose preset was handed over at 1.0 s on a 1 Mbit/s bus, and a start held behind it."""
    s = BusSession(tx=tx, timeout=0.2, bitrate=1_000_000, tx_latency=0.0, now=1.0)  # type: ignore[arg-type]
    s.send_frames([PresetT(1, 10.0, 20.0).encode()])
    s.data_to_send()
    released: list[float] = []
    failed: list[BaseException] = []
    assert s.hold.begin([1], lambda: released.append(s.now), failed.append)
    return s, released, failed


def test_a_confirming_hold_follows_the_transport_then_the_bus_time() -> None:
    s, released, failed = _held("confirmed")
    assert (_state(s), s.awaiting_confirmation) == (HoldState.CONFIRMING, True)
    s.hold.event(HoldEvent.NOT_SENT)
    s.hold.event(HoldEvent.ANSWERED)  # not a transport's word: ignored
    assert _state(s) is HoldState.CONFIRMING and released == []
    s.hold.event(HoldEvent.UNKNOWN)  # the transport cannot tell: the bus time decides
    assert (_state(s), s.awaiting_confirmation) == (HoldState.TIMED, False)
    assert s.next_deadline() == pytest.approx(1.0 + 135e-6)
    s.advance(1.0 + 100e-6)
    assert released == []
    s.advance(1.0 + 135e-6)
    assert released == [pytest.approx(1.0 + 135e-6)] and _state(s) is None and failed == []


def test_a_confirming_hold_fails_when_no_word_comes_in_time() -> None:
    s, released, failed = _held("confirmed")
    s.advance(1.19)
    assert failed == []
    s.advance(1.2)
    assert released == [] and len(failed) == 1 and isinstance(failed[0], TimeoutError)
    assert s.hold.current is None


def test_a_probing_hold_ignores_the_transport_and_goes_when_its_read_is_answered() -> None:
    s, released, failed = _held("answered")
    (probe,) = s.data_to_send()
    assert probe == ReadParam(1, AXIS0_CONFIG_CAN_NODE_ID, DataType.U32).encode()
    for event in (HoldEvent.SENT, HoldEvent.UNKNOWN, HoldEvent.NOT_SENT):
        s.hold.event(event)
        assert _state(s) is HoldState.PROBING
    assert released == []
    s.receive(ParamValue(1, AXIS0_CONFIG_CAN_NODE_ID, DataType.U32, 1).encode(), 1.001)
    assert released == [1.001] and s.hold.current is None and failed == []


def test_every_transition_leads_to_a_state_and_only_a_confirmation_or_an_answer_confirms() -> None:
    confirming = {pair for pair, state in TRANSITIONS.items() if state is HoldState.CONFIRMED}
    assert confirming == {(HoldState.CONFIRMING, HoldEvent.SENT), (HoldState.PROBING, HoldEvent.ANSWERED)}
    assert not any(state is HoldState.CONFIRMED for state, _ in TRANSITIONS)  # a confirmed start has gone
