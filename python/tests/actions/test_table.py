"""The actions table: one validation with the same words, one way to run, a new query in one row."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator

import pytest

import drempower
from drempower import actions
from drempower.client.engine.effects import sleep
from drempower.errors import DomainError, FieldRangeError, MotorIdleError, ValidationError


@pytest.fixture
def bus() -> Iterator[drempower.Bus]:
    with drempower.open_bus("sim", motors=[1, 2], clock="virtual", stop_on_close=False) as b:
        yield b


def test_every_action_has_a_safety_class_help_and_typed_arguments() -> None:
    names = [a.name for a in actions.table()]
    for expected in ("state", "get", "set", "move", "step", "speed", "torque", "impedance", "stop", "idle"):
        assert expected in names
    assert {"enable", "clear", "estop", "zero", "save", "reboot", "errors"} <= set(names)
    for a in actions.table():
        assert a.safety in ("read", "configure", "motion", "stop") and a.help
        assert a.args[0].name == "id"
        if a.safety == "motion":
            assert "enable" in [x.name for x in a.args]  # every motion action can enable first
    assert actions.get("speed").arg("speed").domain_text() == "-327.68..327.67 r/min"
    assert actions.get("move").arg("angle").domain_text() == "-720000..720000 deg"


@pytest.mark.parametrize(
    ("name", "args", "error", "words"),
    [
        (
            "torque",
            {"id": 1, "torque": 3e38},
            FieldRangeError,
            "torque=3e+38 is out of range: allowed -327.68..327.67 (Nm)",
        ),
        (
            "speed",
            {"id": 1, "speed": "-1e30"},
            FieldRangeError,
            "speed='-1e30' is out of range: allowed -327.68..327.67",
        ),
        ("move", {"id": 64, "angle": 1}, FieldRangeError, "id=64 is out of range: allowed 1..63"),
        ("move", {"id": 1, "angle": "x"}, ValidationError, "angle='x': expected a number"),
        ("move", {"id": 1}, ValidationError, "move: angle is missing (target angle, -720000..720000 deg)"),
        ("move", {"id": 1, "angle": 1, "sped": 3}, ValidationError, "move: no argument 'sped'; its arguments are id,"),
        ("move", {"id": 1, "angle": 1, "speed": 0.001}, FieldRangeError, "speed=0.001 is out of range: allowed 0.01"),
        (
            "speed",
            {"id": 1, "speed": 1, "duration": 0},
            FieldRangeError,
            "duration=0 is out of range: allowed 0.001..inf",
        ),
        ("set", {"id": 1, "name": "axis0.config.can_node_id", "value": 64}, DomainError, "can_node_id=64 is outside"),
        ("get", {"id": 1, "name": "no.such"}, ValidationError, "name='no.such': no such parameter"),
        ("move", {"id": 1, "angle": 1, "enable": "maybe"}, ValidationError, "enable='maybe': expected true or false"),
        ("jump", {"id": 1}, ValidationError, "no action 'jump': the actions are state, errors, get"),
    ],
)
def test_validation_names_field_value_and_range(
    bus: drempower.Bus, name: str, args: dict[str, object], error: type[Exception], words: str
) -> None:
    with pytest.raises(error) as info:
        actions.run(bus, name, args)
    assert words in str(info.value)
    assert bus.stats["frames_received"] == 0  # nothing was asked: nothing was sent


def test_command_line_text_is_typed() -> None:
    assert actions.validate("speed", {"id": "2", "speed": "12.5", "enable": "yes"}) == {
        "id": 2,
        "speed": 12.5,
        "mode": 1,
        "torque_ff": 0.0,
        "ramp": None,
        "duration": None,
        "enable": True,
    }
    assert actions.validate("get", {"id": 1, "name": "31001"})["name"] == "axis0.config.can_node_id"


def test_run_moves_reads_and_stops(bus: drempower.Bus) -> None:
    actions.run(bus, "move", {"id": 1, "angle": 45, "speed": 30, "accel": 60})
    bus.motor(1).wait_position_done(10)
    assert actions.run(bus, "state", {"id": 1}).angle == pytest.approx(45, abs=0.5)
    assert actions.run(bus, "get", {"id": 2, "name": "axis0.config.can_node_id"}) == 2
    actions.run(bus, "speed", {"id": 2, "speed": 20, "duration": 0.5})
    bus.run(sleep(1.0))
    sim = bus.transport.bus.motors  # type: ignore[attr-defined]
    assert sim[2].speed == pytest.approx(0, abs=0.5)  # the timed speed ended by itself
    actions.run(bus, "idle", {"id": 1})
    with pytest.raises(MotorIdleError) as info:
        actions.run(bus, "move", {"id": 1, "angle": 0})
    with pytest.raises(MotorIdleError) as direct:
        bus.motor(1).set_angle(0, 10, 10, 1)
    assert str(info.value) == str(direct.value)  # the same words from the table and from the API
    actions.run(bus, "move", {"id": 1, "angle": 0, "enable": True})
    bus.motor(1).wait_position_done(10)


def test_outcomes_say_sent_for_commands_and_name_a_number_with_its_unit(bus: drempower.Bus) -> None:
    """A command is "sent", never "done" (a motion command returns before the motor gets there); the
    number a row returns is named with its unit, as its description says; a read is its value."""
    t = actions.run(bus, "step", {"id": 1, "angle": 30})
    assert isinstance(t, float) and t > 0
    assert actions.describe("step")["result"] == "move time" and actions.describe("step")["result_unit"] == "s"
    assert actions.outcome("step", t) == f" sent (move time {t:.6g} s)"
    assert not bus.motor(1).get_state().trajectory_done  # sent, and on its way
    assert actions.outcome("step", None) == " sent"  # modes T and P return no time
    assert actions.outcome("move", actions.run(bus, "move", {"id": 2, "angle": 10})) == " sent"
    assert actions.outcome("get", actions.run(bus, "get", {"id": 2, "name": "axis0.config.can_node_id"})) == ": 2"
    # numbers as the command line's tables show them (7 significant digits, no "-0"); records and lists
    # are left to each front end's own form
    for value, text in [(24.0, "24"), (3.14159265, "3.141593"), (1234567.0, "1234567"), (2e-05, "2e-05"), (-0.0, "0")]:
        assert actions.outcome("get", value) == f": {text}"
    assert actions.outcome("get", 7) == ": 7" and actions.outcome("get", True) == ": True"
    assert actions.outcome("state", actions.run(bus, "state", {"id": 1})) is None
    assert actions.outcome("state", {"node": 1}) is None and actions.outcome("get", [1, 2]) is None
    assert actions.describe("get")["result"] == "" and actions.describe("get")["result_unit"] == ""


def test_run_async_on_an_asyncio_bus() -> None:
    async def main() -> float:
        async with drempower.open_bus_async("sim", motors=[1], clock="virtual", stop_on_close=False) as b:
            await actions.run_async(b, "move", {"id": 1, "angle": -30, "speed": 30, "accel": 60})
            await b.motor(1).wait_position_done(10)
            st = await actions.run_async(b, "state", {"id": 1})
            return float(st.angle)

    assert asyncio.run(main()) == pytest.approx(-30, abs=0.5)


def test_a_new_query_is_one_operation_and_one_row(bus: drempower.Bus) -> None:
    """The CLI and the dashboard list actions.table(): a row added here is theirs too."""
    row = actions.Action(
        "volcur",
        "read",
        "supply voltage (V) and q-axis current (A)",
        (actions.MOTOR,),
        lambda b, a: b.motor(a["id"]).get_volcur(),
    )
    actions.register(row)
    try:
        assert row in list(actions.table())
        volts, _amps = actions.run(bus, "volcur", {"id": 2})
        assert volts > 10
        with pytest.raises(FieldRangeError, match=r"id=0 is out of range: allowed 1\.\.63"):
            actions.run(bus, "volcur", {"id": 0})
        with pytest.raises(ValidationError, match="action 'volcur' exists already"):
            actions.register(row)
    finally:
        actions.unregister("volcur")
    assert "volcur" not in [a.name for a in actions.table()]


def test_the_settle_after_an_enable_waits_on_the_buss_clock() -> None:
    """why_not_enabled asks again every 20 ms of the bus's time: on the virtual clock its wait takes simulated
    time, not wall time, and an estopped motor that ignores the enable is named with its fix."""
    import time as _time

    import drempower
    from drempower import actions as _actions

    with drempower.open_bus("sim", motors=[1], clock="virtual", stop_on_close=False) as bus:
        bus.motor(1).estop()
        bus.pass_time(0.05)
        _actions.run(bus, "enable", {"id": 1})  # an estopped motor keeps its error flags: it stays idle
        t0, wall0 = bus.now(), _time.monotonic()
        why = _actions.why_not_enabled(bus, [1], within=30.0)
        assert bus.now() - t0 >= 30.0 and _time.monotonic() - wall0 < 15.0
    assert why == {
        1: "did not enter closed loop (state idle): its error flags are set: clear errors first, then enable again"
    }
