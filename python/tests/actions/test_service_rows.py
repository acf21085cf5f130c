"""The command service's confirmation of rows run together (a front end that enables several motors at
once, as the bridge's services do): one wait for all, cut short by the policy's ``interrupted``; on the
simulator's virtual clock."""

from __future__ import annotations

import re
from collections.abc import Iterator

import pytest

import drempower
from drempower import actions
from drempower.errors import DrEmpowerError
from drempower.protocol.enums import AxisState
from drempower.protocol.flags import MotorError

_IDLE = "did not enter closed loop (state idle): its error flags are set: clear errors first, then enable again"


@pytest.fixture
def bus() -> Iterator[drempower.Bus]:
    with drempower.open_bus("sim", motors=[1, 2, 3], clock="virtual", stop_on_close=False) as b:
        yield b


def _enable_all(service: actions.Service, ids: list[int]) -> list[actions.Checked]:
    rows = [service.check("enable", {"id": i}) for i in ids]
    for c in rows:
        service.act("test", c)
    return rows


def test_rows_run_together_share_one_wait_and_name_each_motor_in_order(bus: drempower.Bus) -> None:
    sim = bus.transport.bus  # type: ignore[attr-defined]
    sim.motors[3].inject_error(MotorError.DRV_FAULT)
    sim.motors[1].inject_error(MotorError.DRV_FAULT)
    service = actions.Service(actions.OneBus(bus))
    rows = _enable_all(service, [1, 2, 3])
    t0 = bus.now()
    with pytest.raises(DrEmpowerError) as info:
        service.confirm_all(rows)
    took = bus.now() - t0
    assert str(info.value) == f"motor_1 {_IDLE}; motor_3 {_IDLE}"  # the words of one row's, in the rows' order
    assert sim.motors[2].state == AxisState.CLOSED_LOOP_CONTROL
    # one wait of the policy's settle for the three, not one a motor (virtual s: exact, whatever the machine)
    settle = service.policy.settle
    assert settle <= took < 2 * settle, took


def test_the_policys_interrupted_ends_the_wait_of_all_early(bus: drempower.Bus) -> None:
    sim = bus.transport.bus  # type: ignore[attr-defined]
    sim.motors[2].inject_error(MotorError.DRV_FAULT)
    asked: list[float] = []

    def stop() -> bool:  # an estop came in once the motors were asked twice
        asked.append(bus.now())
        return len(asked) >= 2

    service = actions.Service(actions.OneBus(bus), actions.Policy(interrupted=stop))
    rows = _enable_all(service, [1, 2])
    t0 = bus.now()
    with pytest.raises(DrEmpowerError, match=f"^{re.escape('motor_2 ' + _IDLE)}$"):
        service.confirm_all(rows)
    assert len(asked) == 2 and bus.now() - t0 < actions.ENABLE_SETTLE / 2


def test_confirm_of_one_row_is_confirm_all_of_it(bus: drempower.Bus) -> None:
    service = actions.Service(actions.OneBus(bus))
    rows = _enable_all(service, [1])
    service.confirm(rows[0])  # closed loop: no error
    service.confirm_all([service.check("move", {"id": 1, "angle": 1})])  # a row that is not confirmed: nothing
