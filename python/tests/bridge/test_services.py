"""The ROS 2 services in order: an estop comes after every call that arrived before it, and stays."""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import pytest

from drempower.bridge import rmw, rosmsg
from drempower.bridge.order import ServiceOrder
from drempower.bridge.server import Bridge, BridgeOptions
from drempower.protocol.addresses import AXIS0_ERROR
from drempower.protocol.enums import AxisState
from drempower.protocol.flags import AxisError
from drempower.protocol.ids import Frame
from drempower.transports.sim import SimTransport

from .conftest import free_port, session, wait_for
from .test_bridge import _call

pytestmark = pytest.mark.timeout(60)

IDS = list(range(1, 9))


class _SlowSim(SimTransport):
    """Simulated motors behind a device that takes 3 ms per frame (a busy adapter): calls overlap."""

    def send(self, frame: Frame) -> None:
        time.sleep(0.003)
        super().send(frame)


@pytest.fixture
def slow() -> Iterator[tuple[Bridge, _SlowSim, str]]:
    sim = _SlowSim(IDS)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sess = session(listen=[endpoint])
    bridge = Bridge(sim, sess, BridgeOptions({f"motor_{i}": i for i in IDS}, prefix=f"svc{free_port()}", rate=20))
    try:
        yield bridge, sim, endpoint
    finally:
        bridge.close()
        sess.close()
        sim.close()


def _request() -> bytes:
    t = rosmsg.typestore().types
    return rosmsg.encode(
        t[rosmsg.TRIGGER + "_Request"](structure_needs_at_least_one_member=0), rosmsg.TRIGGER + "_Request"
    )


def _issue(sess: Any, key: str) -> Any:
    """A service call sent without waiting for its reply (as `ros2 service call` from another shell)."""
    import zenoh

    att = rmw.Attachment(1, time.time_ns(), bytes(range(16))).encode()
    return sess.get(key, payload=_request(), attachment=att, target=zenoh.QueryTarget.ALL_COMPLETE, timeout=10)


def _reply(handler: Any) -> Any:
    replies = list(handler)
    assert len(replies) == 1 and replies[0].ok is not None
    return rosmsg.decode(replies[0].ok.payload.to_bytes(), rosmsg.TRIGGER + "_Response")


def _estopped(sim: SimTransport) -> bool:
    return all(
        m.state == AxisState.IDLE and m.errors[AXIS0_ERROR] & AxisError.ESTOP_REQUESTED for m in sim.bus.motors.values()
    )


def test_an_estop_is_not_undone_by_calls_issued_just_before_it(slow: tuple[Bridge, _SlowSim, str]) -> None:
    bridge, sim, endpoint = slow
    keys = bridge.service_keys
    callers = [session(connect=[endpoint]) for _ in range(3)]
    try:
        assert _call(callers[0], keys["enable"], 1)[0].success
        wait_for(lambda: all(m.state == AxisState.CLOSED_LOOP_CONTROL for m in sim.bus.motors.values()))
        time.sleep(0.3)  # the callers' links are up
        for _ in range(4):
            clear = _issue(callers[1], keys["clear_errors"])
            enable = _issue(callers[2], keys["enable"])
            time.sleep(0.005)  # both arrived; each takes 8 x 3 ms on the bus
            stop = _issue(callers[0], keys["estop"])
            assert _reply(stop).success is True
            late = [_reply(clear), _reply(enable)]
            time.sleep(0.1)
            assert _estopped(sim), [(m.state, m.errors) for m in sim.bus.motors.values()]
            assert any("an estop called after it came first" in r.message for r in late if not r.success)
        # an explicit clear after the estop undoes it, and enable then closes the loop
        assert _reply(_issue(callers[1], keys["clear_errors"])).success is True
        assert _reply(_issue(callers[2], keys["enable"])).success is True
        wait_for(lambda: all(m.state == AxisState.CLOSED_LOOP_CONTROL for m in sim.bus.motors.values()))
    finally:
        for c in callers:
            c.close()


def test_service_calls_run_in_arrival_order_and_an_estop_fences_the_earlier_ones() -> None:
    order = ServiceOrder()
    first, second = order.arrive(), order.arrive()
    ran: list[int] = []
    import threading

    def run(ticket: int) -> None:
        with order.turn(ticket):
            ran.append(ticket)

    late = threading.Thread(target=run, args=(second,))
    late.start()
    time.sleep(0.05)
    assert ran == []  # waits for the call that arrived before it
    stop = order.arrive(estop=True)
    assert order.stale(first) and order.stale(second) and not order.stale(stop)
    run(first)
    late.join(5)
    assert ran == [first, second]
    after = order.arrive()
    assert not order.stale(after)
    with order.turn(after):
        pass


def test_an_estop_behind_an_enable_waiting_for_closed_loop_is_not_delayed(
    slow: tuple[Bridge, _SlowSim, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """An enable waits (up to ENABLE_SETTLE s) for closed loop: an estop from the same caller right behind
    it is answered at once and fences it; the enable then says the estop came first, not that the motors
    failed to enter closed loop. The wait is made 3 s long, so that an estop queued behind it (2.9 s) and
    one answered at once (a few bus frames) are told apart on however busy a machine, and so are an
    enable whose wait the estop ended and one that waited it out."""
    import drempower.actions.settle
    from drempower.protocol.flags import MotorError

    monkeypatch.setattr(drempower.actions.settle, "ENABLE_SETTLE", 3.0)  # the command service reads it here
    bridge, sim, endpoint = slow
    sim.bus.motors[8].inject_error(MotorError.DRV_FAULT)  # refuses closed loop: the enable waits for it
    caller = session(connect=[endpoint])
    try:
        time.sleep(0.3)  # the link is up
        enable = _issue(caller, bridge.service_keys["enable"])
        time.sleep(0.1)  # its 8 frames are out (3 ms each); it waits for motor 8
        t0 = time.monotonic()
        stop = _issue(caller, bridge.service_keys["estop"])
        assert _reply(stop).success is True
        took = time.monotonic() - t0
        late = _reply(enable)
        ended = time.monotonic() - t0
        assert took < 1.0, took  # not behind the enable's wait (2.9 s more)
        assert ended < 1.5, ended  # the estop ended the enable's wait too (it would have run 2.9 s more)
        assert late.success is False
        assert late.message == "enable not done: an estop called after it came first (call clear_errors, then enable)"
        time.sleep(0.05)
        assert _estopped(sim)
    finally:
        caller.close()
