"""The dashboard's controls go through the command service: one closed-loop check a move (one read of
each motor's state, which the bus's safety gate then knows), the service's confirmation and words."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

pytest.importorskip("aiohttp")

from drempower import actions, open_bus
from drempower.client import Bus
from drempower.dash import Hub
from drempower.errors import DrEmpowerError, MotorIdleError
from drempower.protocol.flags import MotorError
from drempower.protocol.messages import PositionQ, ReadParam
from drempower.sim import SimBus

from ..actions.test_service import Host as Sent


@pytest.fixture
def rig() -> Iterator[tuple[Hub, Bus, SimBus, Sent]]:
    """A hub on simulated motors 1 and 2 (no scan: nothing polls), and what the host sends."""
    bus = open_bus("sim", motors=[1, 2], stop_on_close=False)
    sim: SimBus = bus.transport.bus  # type: ignore[attr-defined]
    hub = Hub(bus, poll_hz=50)
    try:
        yield hub, bus, sim, Sent(bus)
    finally:
        hub.close()
        bus.close()


def test_a_dashboard_move_checks_closed_loop_once(rig: tuple[Hub, Bus, SimBus, Sent]) -> None:
    hub, _, _, sent = rig
    hub.do_control("page", {"action": "enable", "id": 1})
    hub.do_control("page", {"action": "enable", "id": 2})
    for angle in (10.0, 20.0):
        sent.clear()
        hub.do_control("page", {"action": "Q", "id": 1, "angle": angle, "speed": 10, "param": 10})
        assert sent.state_reads() == [1]  # the service's read; the gate learnt it: the move paid none
        assert [type(m) for m in sent.sent()] == [ReadParam, PositionQ]
    sent.clear()
    hub.do_control("page", {"action": "sync_move", "ids": [1, 2], "angles": [5, 6], "speed": 10, "accel": 10})
    assert sent.state_reads() == [1, 2]  # one read of each motor, together
    assert hub.targets[1][0] == 5 and hub.targets[2][0] == 6


def test_an_idle_motor_is_refused_with_the_enable_button(rig: tuple[Hub, Bus, SimBus, Sent]) -> None:
    hub, bus, _, sent = rig
    bus.motor(2).idle()
    sent.clear()
    with pytest.raises(MotorIdleError) as info:
        hub.do_control("page", {"action": "V", "id": 2, "speed": 5})
    assert str(info.value) == (
        "motor 2 is idle (not in closed loop): enable it first (the Enable button, or drempower enable 2)"
    )
    assert [type(m) for m in sent.sent()] == [ReadParam]  # nothing but the check's read
    assert 2 not in hub.commanded


def test_an_enable_that_fails_is_worded_and_one_that_works_said(rig: tuple[Hub, Bus, SimBus, Sent]) -> None:
    hub, _, sim, _ = rig
    row = hub.do_row("page", {"action": "enable", "args": {"id": 1}})
    assert row == {"result": None, "said": "enable" + (actions.outcome("enable", None) or "")}
    sim.motors[2].inject_error(MotorError.DRV_FAULT)
    with pytest.raises(DrEmpowerError) as info:
        hub.do_control("page", {"action": "enable", "id": 2})
    assert str(info.value) == (
        "motor_2 did not enter closed loop (state idle): its error flags are set: clear errors first, then enable again"
    )
    got = hub.do_row("page", {"action": "get", "args": {"id": 1, "name": "vbus_voltage"}})
    assert got["said"] == "get" + (actions.outcome("get", got["result"]) or "")


def test_a_tuning_step_checks_closed_loop_once(rig: tuple[Hub, Bus, SimBus, Sent]) -> None:
    hub, bus, _, sent = rig
    bus.motor(1).enable()
    for mode, amplitude in (("position", 5.0), ("velocity", 3.0)):
        sent.clear()
        run = hub.do_step("page", {"id": 1, "mode": mode, "amplitude": amplitude, "duration": 0.1, "bandwidth": 20})
        assert run["target"] == pytest.approx(run["base"] + amplitude)
        assert sent.state_reads() == [1]  # the service's one read before anything was sent
    bus.motor(1).idle()
    sent.clear()
    with pytest.raises(MotorIdleError):
        hub.do_step("page", {"id": 1, "mode": "position", "amplitude": 5.0, "duration": 0.1})
    sent_types = {type(m).__name__ for m in sent.sent()}
    assert "PositionT" not in sent_types and "WriteParam" not in sent_types  # no heartbeat, no step
