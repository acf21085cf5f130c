"""Operations on scripted time: waiting for a state, cancelling, closing and aborting the session."""

from __future__ import annotations

import pytest

from drempower.client.engine.effects import Batch, Op, await_state, read_states, request, sleep
from drempower.client.engine.session import BusSession, Operation
from drempower.client.errors import BusClosedError, TimeoutError
from drempower.protocol import (
    DataType,
    FastRead,
    ParamValue,
    PresetT,
    ReadParam,
    Start,
    StartKind,
    State,
    SysCmd,
    SystemCommand,
)
from drempower.protocol.ids import Frame

from .rig import Rig


def _state(node: int, angle: float = 0.0) -> Frame:
    return State(node, angle, 0.0, 0.0, True, False).encode()


def _sleeper(seconds: float) -> Op[str]:
    yield from sleep(seconds)
    return "woke"


def test_await_state_returns_a_newer_state_already_there_without_sending() -> None:
    s = BusSession()
    s.receive(_state(1, 5.0), 0.01)
    opn = s.submit(await_state(1, 0.005, 0.1))
    assert opn.result().angle == 5.0 and s.data_to_send() == []


def test_await_state_waits_for_a_state_of_its_motor_newer_than_asked() -> None:
    s = BusSession()
    s.receive(_state(1, 5.0), 0.01)
    opn = s.submit(await_state(1, 0.01, 0.1))
    assert not opn.done and s.next_deadline() == pytest.approx(0.11)
    s.receive(_state(2, 7.0), 0.02)
    assert not opn.done
    s.receive(_state(1, 9.0), 0.03)
    assert opn.result() == (1, 9.0, 0.0, 0.0, True, False, 0.03)
    assert s.next_deadline() is None and s.data_to_send() == []


def test_await_state_times_out_at_its_timeout() -> None:
    s = BusSession()
    s.advance(1.0)
    opn = s.submit(await_state(4, 1.0, 0.25))
    s.advance(1.25 - 1e-6)
    assert not opn.done
    s.advance(1.25)
    with pytest.raises(TimeoutError, match="motor 4: no answer to a state update") as info:
        opn.result()
    assert info.value.nodes == (4,) and s.next_deadline() is None
    s.receive(_state(4), 1.3)  # nobody waits any more
    assert opn.error is info.value


@pytest.mark.parametrize("what", ["request", "sleep", "await_state"])
def test_cancel_removes_the_operation_s_waiter_and_timers(what: str) -> None:
    rig = Rig([1], timeout=0.1)
    s = rig.session
    ended: list[bool] = []
    op = {"request": read_states([1]), "sleep": _sleeper(0.5), "await_state": await_state(1, 0.0, 0.5)}[what]
    opn: Operation[object] = s.submit(op, lambda: ended.append(True))
    rig.take()
    assert s.next_deadline() is not None
    s.cancel(opn)
    assert opn.done and isinstance(opn.error, BusClosedError) and not ended
    assert len(s.matcher) == 0 and s.next_deadline() is None
    rig.settle()  # the motor's late state arrives: it answers nothing, resumes nothing
    assert opn.done and isinstance(opn.error, BusClosedError)


def test_a_late_reply_to_a_cancelled_read_answers_nothing() -> None:
    s = BusSession(timeout=0.1)
    first = s.submit(request([ReadParam(1, 1, DataType.F32)]))
    s.data_to_send()
    s.cancel(first)
    other = s.submit(request([ReadParam(1, 30001, DataType.U32)]))
    s.data_to_send()
    late = ParamValue(1, 1, DataType.F32, 24.0).encode()
    assert s.receive(late, 0.004) == late
    assert s.unmatched == 1 and s.anomalies == 0 and not other.done
    assert isinstance(first.error, BusClosedError) and len(s.matcher) == 1


def _batch() -> Op[list[int]]:
    where: list[int] = yield Batch([PresetT(n, 10.0, 20.0) for n in (1, 2)], Start(0, StartKind.T), [10.0, 10.0])
    return where


def test_close_fails_every_running_operation_and_every_new_one() -> None:
    rig = Rig([1], timeout=0.1, tx="timed")
    s = rig.session
    rig.motors[1].silent = True
    ended: list[str] = []
    ops = [
        s.submit(read_states([1]), lambda: ended.append("read")),
        s.submit(_sleeper(1.0), lambda: ended.append("sleep")),
        s.submit(await_state(2, 0.0, 1.0), lambda: ended.append("await")),
        s.submit(_batch(), lambda: ended.append("batch")),
    ]
    rig.take()
    assert not any(o.done for o in ops)
    err = BusClosedError("the bus was closed")
    s.close(err)
    assert ended == ["read", "sleep", "await", "batch"] and all(o.error is err for o in ops)
    assert len(s.matcher) == 0 and s.next_deadline() is None and s.data_to_send() == []
    with pytest.raises(BusClosedError):
        s.submit(read_states([1]))
    with pytest.raises(BusClosedError):
        s.send([FastRead(1)])
    with pytest.raises(BusClosedError):
        s.estop([0])


def test_after_a_receive_failure_an_estop_still_goes_out() -> None:
    s = BusSession()
    opn = s.submit(read_states([1]))
    s.close(OSError("device unplugged"), final=False)
    assert isinstance(opn.error, OSError)
    with pytest.raises(OSError, match="unplugged"):
        s.submit(read_states([1]))
    s.estop([0])
    assert s.data_to_send() == [SystemCommand(0, SysCmd.ESTOP).encode()]


def test_abort_fails_running_operations_and_takes_new_ones() -> None:
    rig = Rig([1], timeout=0.1, tx="timed")
    s = rig.session
    read = s.submit(read_states([1]))
    held = s.submit(_batch())
    s.send([FastRead(1)])  # queued, not taken: dropped with the rest
    err = OSError("write failed")
    s.abort(err)
    assert read.error is err and held.error is err
    assert s.data_to_send() == [] and s.next_deadline() is None and len(s.matcher) == 0
    again = rig.run(read_states([1]))
    assert again.result()[0] is not None and rig.now == pytest.approx(0.001)
    where = rig.run(_batch())
    assert where.result() == [0]  # the sequence of starts is free again


def test_an_interrupt_raised_in_an_operation_ends_it_and_reaches_the_thread_resuming_it() -> None:
    """Ctrl-C while a thread resumes an operation (another thread's, when time passes for both): the
    interrupt goes on in that thread, and the operation ends with it rather than staying unfinished."""
    s = BusSession()

    def interrupted() -> Op[str]:
        yield from sleep(0.1)
        raise KeyboardInterrupt

    opn = s.submit(interrupted())
    with pytest.raises(KeyboardInterrupt):
        s.advance(0.1)
    assert opn.done
    with pytest.raises(KeyboardInterrupt):
        opn.result()
    assert s.next_deadline() is None
