"""The command service: validate, gate, confirm, act, confirm the outcome and word it, on the simulator."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import pytest

import drempower
from drempower import actions
from drempower.errors import DrEmpowerError, FieldRangeError, MotorIdleError, ValidationError
from drempower.protocol.addresses import AXIS0_CURRENT_STATE
from drempower.protocol.enums import AxisState
from drempower.protocol.flags import MotorError
from drempower.protocol.ids import Frame
from drempower.protocol.messages import ReadParam, decode_command


class Host:
    """The frames the host put on the simulated bus (every frame seen, less the motors' own)."""

    def __init__(self, bus: drempower.Bus) -> None:
        self.sim = bus.transport.bus  # type: ignore[attr-defined]
        self.all: list[Frame] = []
        self.motors: list[Frame] = []
        self.sim.add_listener(self.all.append, host_frames=True)
        self.sim.add_listener(self.motors.append)

    def sent(self) -> list[Any]:
        """The host's frames so far, decoded, oldest first."""
        left = Counter(self.motors)
        out = []
        for f in self.all:
            if left[f]:
                left[f] -= 1
                continue
            out.append(decode_command(f.arbitration_id, f.data))
        return out

    def state_reads(self) -> list[int]:
        """The motors whose axis state was read, in order."""
        return [m.node for m in self.sent() if isinstance(m, ReadParam) and m.address == AXIS0_CURRENT_STATE]

    def clear(self) -> None:
        self.all.clear()
        self.motors.clear()


@pytest.fixture
def bus() -> Iterator[drempower.Bus]:
    with drempower.open_bus("sim", motors=[1, 2], clock="virtual", stop_on_close=False) as b:
        yield b


@pytest.fixture
def host(bus: drempower.Bus) -> Host:
    return Host(bus)


def _service(bus: drempower.Bus, **policy: Any) -> actions.Service:
    return actions.Service(actions.OneBus(bus), actions.Policy(**policy))


@pytest.mark.parametrize(
    ("name", "args", "words"),
    [
        ("speed", {"id": 1, "speed": 400}, "speed=400 is out of range: allowed -327.68..327.67 (r/min)"),
        ("move", {"id": 64, "angle": 1}, "id=64 is out of range: allowed 1..63"),
        ("torque", {"id": 1, "torque": "x"}, "torque='x': expected a number"),
        ("move", {"id": 1}, "move: angle is missing (target angle, -720000..720000 deg)"),
    ],
)
def test_a_refused_argument_names_field_value_and_range_and_nothing_is_sent(
    bus: drempower.Bus, host: Host, name: str, args: dict[str, Any], words: str
) -> None:
    with pytest.raises(ValidationError) as info:
        _service(bus).run("test", name, args)
    assert words in str(info.value)
    assert host.sent() == []  # not even the closed-loop check's read


def test_read_only_refuses_motion_and_configuration_but_reads_and_stops(bus: drempower.Bus, host: Host) -> None:
    service = _service(bus, read_only=lambda: "read-only here")
    for name, args in (("move", {"id": 1, "angle": 5, "enable": True}), ("enable", {"id": 1})):
        with pytest.raises(ValidationError, match="read-only here"):
            service.run("test", name, args)
    assert host.sent() == []
    state = service.run("test", "state", {"id": 1})
    assert state.said is None and state.result.node == 1  # a record: each front end shows it its own way
    assert service.run("test", "stop", {"id": 1}).said == "stop sent"
    assert [type(m).__name__ for m in host.sent()] == ["FastRead", "Velocity"]


def test_a_motion_to_an_idle_motor_is_refused_with_the_front_ends_fix(bus: drempower.Bus, host: Host) -> None:
    asked: list[Sequence[int]] = []

    def fix(keys: Sequence[int]) -> str:
        asked.append(keys)
        return "(the Enable button)"

    bus.motor(2).idle()
    host.clear()
    with pytest.raises(MotorIdleError) as info:
        _service(bus, enable_fix=fix).run("test", "move", {"id": 2, "angle": 10})
    assert str(info.value) == "motor 2 is idle (not in closed loop): enable it first (the Enable button)"
    assert asked == [[2]]
    assert [type(m).__name__ for m in host.sent()] == ["ReadParam"]  # the state read, no motion
    assert bus.transport.bus.motors[2].state == AxisState.IDLE  # type: ignore[attr-defined]


def test_the_closed_loop_check_reads_each_state_once_and_the_command_none(bus: drempower.Bus, host: Host) -> None:
    service = _service(bus)
    service.run("test", "enable", {"id": 1})
    for angle in (10, 20):
        host.clear()
        out = service.run("test", "move", {"id": 1, "angle": angle})
        assert out.said == "move sent"
        assert host.state_reads() == [1]  # the service's read; the gate learnt it and the move paid none
        assert [type(m).__name__ for m in host.sent()] == ["ReadParam", "PositionQ"]


def test_enable_is_confirmed_or_its_failure_worded(bus: drempower.Bus) -> None:
    service = _service(bus)
    assert service.run("test", "enable", {"id": 1}).said == "enable sent"
    assert bus.transport.bus.motors[1].state == AxisState.CLOSED_LOOP_CONTROL  # type: ignore[attr-defined]
    bus.transport.bus.motors[2].inject_error(MotorError.DRV_FAULT)  # type: ignore[attr-defined]
    with pytest.raises(DrEmpowerError) as info:
        service.run("test", "enable", {"id": 2})
    assert str(info.value) == (
        "motor_2 did not enter closed loop (state idle): its error flags are set: clear errors first, then enable again"
    )
    with pytest.raises(DrEmpowerError, match="motor_2 did not enter closed loop"):
        service.run("test", "enable", {"id": 0})  # a broadcast: each motor the bus knows is confirmed


def test_the_words_are_the_tables(bus: drempower.Bus) -> None:
    service = _service(bus)
    service.run("test", "enable", {"id": 1})
    for name, args in (
        ("get", {"id": 1, "name": "axis0.output_shaft.vel_limit"}),
        ("step", {"id": 1, "angle": 5}),
        ("speed", {"id": 1, "speed": 3}),
        ("stop", {"id": 1}),
        ("errors", {"id": 1}),
    ):
        out = service.run("test", name, args)
        said = actions.outcome(name, out.result)
        assert out.said == (None if said is None else name + said)
        assert out.plain == actions.plain(out.result)
    assert service.run("test", "step", {"id": 1, "angle": 5}).said.startswith("step sent (move time ")  # type: ignore[union-attr]


def test_the_hooks_see_each_step_in_order(bus: drempower.Bus, host: Host) -> None:
    said: list[str] = []

    def limits(act: actions.Action, key: int, typed: Mapping[str, Any]) -> None:
        said.append(f"limits {act.name} {key} speed={typed['speed']}")
        if typed["speed"] > 20:
            raise FieldRangeError("speed", typed["speed"], -20, 20, "r/min, the limit")

    service = _service(
        bus,
        fence=lambda act: said.append(f"fence {act.name}"),
        limits=limits,
        ready=lambda keys: said.append(f"ready {list(keys)}"),
        log=said.append,
    )
    service.run("page", "speed", {"id": 1, "speed": 10, "enable": True})
    assert said == ["fence speed", "limits speed 1 speed=10.0", "ready [1]", "page: motor_1 speed(speed=10.0, mode=1, "
                    "torque_ff=0.0, enable=True)"]  # fmt: skip
    said.clear()
    host.clear()
    with pytest.raises(FieldRangeError, match=r"speed=30\.0 is out of range"):
        service.run("page", "speed", {"id": 1, "speed": 30})
    assert [type(m).__name__ for m in host.sent()] == ["ReadParam"]  # the state read; no command
    said.clear()
    service.run("page", "stop", {"id": 1})
    assert said == ["page: motor_1 stop()"]  # a stop is never fenced


def test_a_fence_refuses_all_but_a_stop(bus: drempower.Bus, host: Host) -> None:
    def fence(act: actions.Action) -> None:
        raise ValidationError("an ESTOP was pressed after this request was issued")

    service = _service(bus, fence=fence)
    for name in ("state", "enable"):
        with pytest.raises(ValidationError, match="ESTOP"):
            service.run("page", name, {"id": 1})
    assert host.sent() == []
    assert service.run("page", "idle", {"id": 1}).said == "idle sent"


def test_the_confirmation_waits_its_settle_time_on_the_bus_clock_unless_interrupted(bus: drempower.Bus) -> None:
    bus.transport.bus.motors[2].inject_error(MotorError.DRV_FAULT)  # type: ignore[attr-defined]
    waits = []
    for policy in ({"settle": 0.5}, {"settle": 0.5, "interrupted": lambda: True}):
        t0 = bus.now()
        with pytest.raises(DrEmpowerError, match="motor_2 did not enter closed loop"):
            _service(bus, **policy).run("test", "enable", {"id": 2})
        waits.append(bus.now() - t0)
    assert waits[0] >= 0.5  # the virtual clock: the whole settle time, asked again and again
    assert waits[1] < 0.02  # an ESTOP since the request ends the wait at the first answer
