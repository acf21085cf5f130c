"""Done detection on scripted time (``ops.wait_done``): a move is done only when the motor took it and
ended at its target; faults, timeouts and lost moves are named; the poll interval is kept."""

from __future__ import annotations

import pytest

from drempower.client.engine.effects import Batch, Op
from drempower.client.engine.ops import wait_done
from drempower.client.engine.state import MotorState
from drempower.client.errors import MoveError, MoveFaultError, MoveTimeoutError
from drempower.protocol import FastRead, PositionT, Preset, PresetT, ReadParam, Start, StartKind, parameter
from drempower.protocol.flags import AxisError, CanError

from .rig import Rig

STALE = (0.0, True, False)
"""A state from before the motor took the move: T = 1, at the old position."""
MOVING = (12.0, False, False)
AT_30 = (30.0, True, False)


def _moved(rig: Rig, target: float = 30.0) -> Rig:
    """Motor 1 commanded to ``target`` deg at time 0 (T mode, a direct command)."""
    rig.session.send([PositionT(1, target, 20.0)])
    rig.take()
    return rig


def _wait(rig: Rig, nodes: list[int], timeout: float = 1.0, poll: float = 0.01) -> Op[dict[int, MotorState]]:
    return wait_done(rig.session, nodes, timeout, poll)


def test_stale_done_states_are_not_the_end_and_t0_then_t1_at_target_is() -> None:
    rig = _moved(Rig([1], timeout=0.05))
    rig.motors[1].states = [STALE, STALE, MOVING, AT_30]
    opn = rig.run(_wait(rig, [1]))
    st = opn.result()[1]
    assert (st.angle, st.trajectory_done) == (30.0, True)
    reads = rig.sent(FastRead)
    assert len(reads) == 4 and not rig.motors[1].states
    assert rig.session.known.moves[1].took == pytest.approx(reads[2][0] + 0.001)  # the arrival of the T = 0 state


def test_a_move_with_a_planned_time_is_done_by_t1_after_that_time() -> None:
    rig = Rig([1, 2], timeout=0.05, tx="in_order")

    def batch() -> Op[list[int]]:
        where: list[int] = yield Batch([PresetT(n, 30.0, 20.0) for n in (1, 2)], Start(0, StartKind.T), None, 0.05)
        return where

    rig.run(batch())
    for n in (1, 2):
        rig.motors[n].states = [STALE] * 5
        rig.motors[n].angle = 30.0
    opn = rig.run(_wait(rig, [1, 2]))
    assert opn.result()[1].angle == 30.0  # target unknown: the T = 1 states before 50 ms did not count
    assert rig.sent(FastRead)[-1][0] >= 0.05


def test_ending_away_from_the_target_raises_move_error() -> None:
    rig = _moved(Rig([1], timeout=0.05))
    rig.motors[1].states = [MOVING, (20.0, True, False)]
    opn = rig.run(_wait(rig, [1]))
    with pytest.raises(MoveError, match="motor 1") as info:
        opn.result()
    e = info.value
    assert not isinstance(e, MoveTimeoutError)
    assert (e.node, e.target, e.position, e.flags) == (1, 30.0, 20.0, {})
    assert "-10.00 deg off its target" in str(e)


def test_an_error_bit_raises_move_fault_error_with_the_flags() -> None:
    rig = _moved(Rig([1], timeout=0.05))
    rig.motors[1].states = [MOVING, (14.0, False, True)]
    rig.motors[1].params[parameter("axis0.error").address] = int(AxisError.ESTOP_REQUESTED)
    opn = rig.run(_wait(rig, [1]))
    with pytest.raises(MoveFaultError) as info:
        opn.result()
    e = info.value
    assert (e.node, e.target, e.position) == (1, 30.0, 14.0)
    assert e.flags == {"axis0.error": ["ESTOP_REQUESTED"]}
    assert len(rig.sent(ReadParam)) == 7  # the seven error words, read once


def test_the_timeout_names_each_motor_still_moving_or_that_never_took_the_move() -> None:
    rig = Rig([1, 2], timeout=0.05)
    rig.session.send([PositionT(1, 30.0, 20.0), PositionT(2, -30.0, 20.0)])
    rig.take()
    rig.motors[1].angle, rig.motors[1].done = 12.0, False  # moving for ever
    rig.motors[2].params[parameter("can.error").address] = int(CanError.DUPLICATE_CAN_IDS)  # without the E bit
    opn = rig.run(_wait(rig, [1, 2], timeout=0.2, poll=0.03))
    with pytest.raises(MoveTimeoutError) as info:
        opn.result()
    e = info.value
    assert e.nodes == (1, 2) and e.timeout == 0.2 and (e.node, e.target, e.position) == (1, 30.0, 12.0)
    assert str(e).startswith("motor 1: still moving after 0.2 s (motors 1, 2 not done): target 30.00 deg")
    assert "; motor 2: no sign that it took the move after 0.2 s: target -30.00 deg, reached 0.00 deg" in str(e)
    assert "(can.error: DUPLICATE_CAN_IDS)" in str(e) and e.flags == {}
    assert [(o.node, o.target, o.flags) for o in e.others] == [(2, -30.0, {"can.error": ["DUPLICATE_CAN_IDS"]})]
    reads = [t for t, _ in rig.sent(FastRead)]
    assert reads[-1] == pytest.approx(0.2) and all(t <= 0.2 + 1e-9 for t in reads)


def test_with_retries_a_lost_move_is_sent_again_to_that_motor() -> None:
    rig = _moved(Rig([1], timeout=0.05, retries=1))
    rig.motors[1].states = [STALE] * 3  # 1, 12 and 23 ms: lost only once 20 ms have passed
    opn = rig.submit(_wait(rig, [1]))
    s = rig.session
    rig.settle(lambda: s.moves_resent == 1)
    again = rig.sent(PositionT)
    assert [(c.node, c.position) for _, c in again] == [(1, 30.0), (1, 30.0)]
    assert again[1][0] == pytest.approx(0.023) and len(rig.sent(FastRead)) == 3
    rig.motors[1].states = [MOVING, AT_30]
    rig.settle(lambda: opn.done)
    assert opn.result()[1].angle == 30.0 and s.moves_resent == 1
    assert s.known.moves[1].sent == pytest.approx(0.023) and s.known.moves[1].target == 30.0


def test_a_lost_preset_of_a_batch_is_sent_again_with_a_start_to_that_motor_only() -> None:
    rig = Rig([1, 2, 3], timeout=0.05, retries=2, tx="in_order")

    def batch() -> Op[list[int]]:
        where: list[int] = yield Batch(
            [PresetT(n, 10.0 * n, 20.0) for n in (1, 2, 3)], Start(0, StartKind.T), [10.0 * n for n in (1, 2, 3)]
        )
        return where

    rig.run(batch())
    for n in (1, 3):
        rig.motors[n].angle = 10.0 * n
    rig.motors[2].states = [STALE] * 3
    rig.motors[2].angle = 20.0  # after the resend
    opn = rig.run(_wait(rig, [1, 2, 3]))
    assert [round(opn.result()[n].angle) for n in (1, 2, 3)] == [10, 20, 30]
    assert rig.session.moves_resent == 1
    presets = [c.node for _, c in rig.sent(Preset)]
    starts = [c.node for _, c in rig.sent(Start)]
    assert (presets, starts) == ([1, 2, 3, 2], [0, 2])


def test_without_retries_the_lost_move_ends_in_a_timeout_naming_it() -> None:
    rig = _moved(Rig([1], timeout=0.05))
    opn = rig.run(_wait(rig, [1], timeout=0.1))
    with pytest.raises(MoveTimeoutError, match="motor 1: no sign that it took the move"):
        opn.result()
    assert rig.session.moves_resent == 0 and len(rig.sent(PositionT)) == 1


def test_the_poll_interval_is_kept_on_scripted_time() -> None:
    rig = _moved(Rig([1], timeout=0.05))
    rig.motors[1].states = [MOVING, MOVING]
    rig.motors[1].angle = 30.0
    opn = rig.submit(_wait(rig, [1], poll=0.05))
    assert rig.take() == [FastRead(1)]
    rig.at(0.001)  # the state arrives; the wait sleeps 50 ms from here
    wake = rig.session.next_deadline()
    assert wake == pytest.approx(0.051)
    rig.at(wake - 1e-6)
    assert rig.take() == []
    rig.at(wake)
    assert rig.take() == [FastRead(1)]
    rig.settle(lambda: opn.done)
    assert [t for t, _ in rig.sent(FastRead)] == pytest.approx([0.0, 0.051, 0.102])
    assert opn.result()[1].angle == 30.0


def test_resends_are_counted_per_motor_and_end_at_retries() -> None:
    rig = _moved(Rig([1], timeout=0.05, retries=2))
    opn = rig.run(_wait(rig, [1], timeout=0.3))
    with pytest.raises(MoveTimeoutError, match="motor 1: no sign that it took the move"):
        opn.result()
    assert rig.session.moves_resent == 2 and len(rig.sent(PositionT)) == 3


def test_without_retries_a_lost_preset_of_a_timed_move_ends_off_target_naming_the_motor() -> None:
    rig = Rig([1, 2], timeout=0.05, tx="in_order")

    def batch() -> Op[list[int]]:
        where: list[int] = yield Batch(
            [PresetT(n, 10.0, 20.0) for n in (1, 2)], Start(0, StartKind.T), [10.0, 10.0], 0.1
        )
        return where

    rig.run(batch())
    rig.motors[1].angle = 10.0  # motor 2 never got its preset: T = 1 where it was
    opn = rig.run(_wait(rig, [1, 2], timeout=5.0))
    with pytest.raises(MoveError, match="motor 2") as info:
        opn.result()
    assert not isinstance(info.value, MoveTimeoutError)
    assert (info.value.target, info.value.position) == (10.0, 0.0)
    assert 0.1 <= rig.now < 0.2 and rig.session.moves_resent == 0
