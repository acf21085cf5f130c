"""A row added to the table of actions in this module (one operation, one row) appears in the CLI and the
dashboard with no other change: listed by ``drempower actions``, run as ``drempower volcur``, offered and
run by the page's Actions view; refusals in the table's words everywhere, nothing run after one."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from drempower import actions, open_bus, open_robot
from drempower.cli import main
from drempower.client import PositionMode
from drempower.dash.hub import Hub
from drempower.errors import MotorIdleError, ValidationError
from drempower.naming import number_text
from drempower.protocol.enums import AxisState
from drempower.sim.defaults import MotorModel

from .conftest import serve_in_thread


def _volcur(bus: Any, a: Any) -> Any:
    return bus.motor(a["id"]).get_volcur()


VOLCUR = actions.Action("volcur", "read", "supply voltage (V) and q-axis current (A)", (actions.MOTOR,), _volcur)
"""The new query: one operation (a call of the bus API) and one row."""


@pytest.fixture
def volcur() -> Iterator[actions.Action]:
    actions.register(VOLCUR)
    try:
        yield VOLCUR
    finally:
        actions.unregister("volcur")


def test_the_new_row_is_listed_by_drempower_actions(volcur: actions.Action, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["actions"]) == 0
    lines = capsys.readouterr().out.splitlines()
    row = next(line for line in lines if line.startswith("volcur"))
    assert row.split()[:3] == ["volcur", "read", "drempower"] and "drempower volcur" in row
    assert "id 1..63" in row and "supply voltage (V) and q-axis current (A)" in row
    # row stop (speed 0) is run by its table name: drempower stop is the emergency stop
    assert "drempower actions stop" in next(line for line in lines if line.startswith("stop "))
    assert main(["actions", "--json"]) == 0
    rows = {r["name"]: r for r in map(json.loads, capsys.readouterr().out.splitlines())}
    assert rows["volcur"]["safety"] == "read"
    assert rows["volcur"]["args"] == [actions.describe(VOLCUR)["args"][0]]
    assert rows["volcur"]["args"][0]["domain"] == "1..63"


def test_the_new_row_is_a_command(volcur: actions.Action, capsys: pytest.CaptureFixture[str]) -> None:
    vbus = MotorModel().vbus  # what the simulated motor reports
    assert main(["volcur", "1", "--sim", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out == {"id": 1, "action": "volcur", "result": [vbus, 0.0]}
    assert main(["volcur", "1", "--sim", "1"]) == 0
    assert capsys.readouterr().out == f"motor 1: volcur: {vbus:g}, 0\n"
    assert main(["actions", "volcur", "1", "--sim", "1"]) == 0  # and by its table name
    assert capsys.readouterr().out == f"motor 1: volcur: {vbus:g}, 0\n"
    with pytest.raises(SystemExit):
        main(["volcur", "--help"])
    assert "the motor's id (1..63)" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["volcur", "64"], "drempower: error: id=64 is out of range: allowed 1..63\n"),
        (["volcur", "1.5"], "drempower: error: id=1.5: expected a whole number\n"),
    ],
)
def test_the_new_command_refuses_in_the_tables_words(
    volcur: actions.Action, capsys: pytest.CaptureFixture[str], argv: list[str], words: str
) -> None:
    assert main([*argv, "--sim", "1"]) == 2
    captured = capsys.readouterr()
    assert captured.err == words and captured.out == ""
    with pytest.raises(ValidationError) as api:  # the API's words are the same
        actions.validate("volcur", {"id": json.loads(argv[1])})
    assert f"drempower: error: {api.value}\n" == words


def test_the_hub_runs_the_new_row_and_the_page_hears_of_it(volcur: actions.Action) -> None:
    bus = open_bus("sim", motors=[1, 2], stop_on_close=False)
    motor2 = bus.transport.bus.motors[2]  # type: ignore[attr-defined]
    motor2.model = dataclasses.replace(motor2.model, vbus=31.5)
    _url, hub, dash, loop, thread = serve_in_thread(bus)
    try:
        assert hub.do_control("test", {"action": "volcur", "args": {"id": 2}}) == [31.5, 0.0]
        with pytest.raises(ValidationError, match=r"^id=64 is out of range: allowed 1\.\.63$"):
            hub.do_control("test", {"action": "volcur", "args": {"id": 64}})
        with pytest.raises(ValidationError, match=r"^no action 'volcurr': the actions are .*volcur$"):
            hub.do_control("test", {"action": "volcurr", "args": {"id": 1}})
        hub.read_only = True  # a query is what a read-only dashboard may do
        assert hub.do_control("test", {"action": "volcur", "args": {"id": 2}}) == [31.5, 0.0]
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


def test_the_page_offers_and_runs_the_new_row(volcur: actions.Action, browser: Any) -> None:
    """In headless Chromium: the Actions view lists the row the server's hello sent, runs it, shows the
    motor's values; a refusal is shown as one, in the table's words, never as success."""
    bus = open_bus("sim", motors=[1, 2], stop_on_close=False)
    motors = bus.transport.bus.motors  # type: ignore[attr-defined]
    motors[2].model = dataclasses.replace(motors[2].model, vbus=31.5)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    ctx = browser.new_context()
    errors: list[str] = []
    try:
        p = ctx.new_page()
        p.set_default_timeout(10_000)
        p.on("pageerror", lambda e: errors.append(str(e)))
        p.goto(url)
        p.wait_for_function("window.dashStats && window.dashStats.connected")
        p.get_by_role("tab", name="Actions").click()
        p.wait_for_selector("#act-name option[value=volcur]", state="attached")
        p.select_option("#act-name", "volcur")
        assert p.locator("#act-help").inner_text() == "supply voltage (V) and q-axis current (A)"
        p.fill("#act-arg-id", "2")
        p.get_by_role("button", name="Run").click()
        p.wait_for_function("document.querySelector('#act-result').textContent.includes('31.5')")
        assert json.loads(p.locator("#act-result").inner_text().removeprefix("volcur: ")) == [31.5, 0]
        p.fill("#act-arg-id", "64")
        p.get_by_role("button", name="Run").click()
        p.wait_for_function("document.querySelector('#act-result').textContent.includes('refused')")
        assert p.locator("#act-result").inner_text() == "volcur refused: id=64 is out of range: allowed 1..63"
        # a motion row on an idle motor: the gate's refusal, and the motor stays idle
        bus.motor(1).idle()
        p.select_option("#act-name", "step")
        p.fill("#act-arg-id", "1")
        p.fill("#act-arg-angle", "30")
        p.get_by_role("button", name="Run").click()
        p.wait_for_function("document.querySelector('#act-result').textContent.startsWith('step refused')")
        text = p.locator("#act-result").inner_text()
        assert "motor 1 is idle" in text and "the Enable button" in text, text
        assert motors[1].state == AxisState.IDLE and 1 not in hub.commanded
        # with enable: the step is sent, said as the command line says it (its move time named, in s),
        # never "done" (the motor is on its way)
        with open_bus("sim", motors=[1], clock="virtual", stop_on_close=False) as alone:
            move_time = alone.motor(1).step_angle(30, 10.0, 10.0, PositionMode.Q, enable=True)
        assert move_time is not None and move_time > 0
        p.check("#act-arg-enable")
        p.get_by_role("button", name="Run").click()
        p.wait_for_function("document.querySelector('#act-result').textContent.startsWith('step sent')")
        assert p.locator("#act-result").inner_text() == "step" + str(actions.outcome("step", move_time))
        assert p.locator("#act-result").inner_text().startswith("step sent (move time ")
        assert p.locator("#msg").inner_text() == "step sent"
        assert motors[1].state == AxisState.CLOSED_LOOP_CONTROL and 1 in hub.commanded
    finally:
        ctx.close()
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()
    assert not errors, errors


def test_the_hubs_checks_apply_to_the_tables_rows() -> None:
    """Read-only lets reading and stopping through and refuses the rest; a motion row to an idle motor is
    the gate's refusal with the page's fix (nothing sent); ``enable`` enables it first; targets follow."""
    bus = open_bus("sim", motors=[1], stop_on_close=False)
    motor = bus.transport.bus.motors[1]  # type: ignore[attr-defined]
    _url, hub, dash, loop, thread = serve_in_thread(bus)
    try:
        bus.motor(1).idle()
        with pytest.raises(MotorIdleError, match="the Enable button"):
            hub.do_control("test", {"action": "speed", "args": {"id": 1, "speed": 20}})
        assert motor.state == AxisState.IDLE and 1 not in hub.commanded
        hub.do_control("test", {"action": "move", "args": {"id": 1, "angle": 10, "enable": True}})
        assert motor.state == AxisState.CLOSED_LOOP_CONTROL and hub.targets[1][0] == 10.0
        with pytest.raises(ValidationError, match=r"^speed=400 is out of range: allowed -327\.68\.\.327\.67"):
            hub.do_control("test", {"action": "speed", "args": {"id": 1, "speed": 400}})
        hub.read_only = True
        assert hub.do_control("test", {"action": "state", "args": {"id": 1}})["node"] == 1
        for row, args in (("speed", {"id": 1, "speed": 5}), ("zero", {"id": 1}), ("save", {"id": 1})):
            with pytest.raises(ValidationError, match=r"read-only"):
                hub.do_control("test", {"action": row, "args": args})
        assert hub.do_control("test", {"action": "stop", "args": {"id": 1}}) is None  # stopping always
        assert hub.targets[1][1] == 0.0
        assert hub.do_control("test", {"action": "idle", "args": {"id": 1}}) is None
        assert motor.state == AxisState.IDLE and 1 not in hub.commanded and 1 not in hub.targets
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


def test_the_actions_view_gets_the_command_lines_words_from_the_hub(tmp_path: Path) -> None:
    """``Hub.do_row`` (the Actions view's request) returns the result and the words the command line
    prints for it: a command "sent" (a broadcast over two buses too, not a list of nothings), a number
    named in its unit, a read's value; a record is left to the page (JSON)."""
    path = tmp_path / "robot.toml"
    path.write_text(
        '[buses.left]\ninterface = "sim"\n[buses.right]\ninterface = "sim"\n'
        '[joints.shoulder]\nbus = "left"\nid = 1\n[joints.elbow]\nbus = "right"\nid = 1\n',
        encoding="utf-8",
    )
    with open_robot(path, stop_on_close=False) as robot:
        hub = Hub(robot)
        try:
            keys = sorted(hub.names())
            assert len(keys) == 2
            said = hub.do_row("test", {"action": "stop", "args": {"id": 0}})  # each bus's broadcast
            assert said == {"result": None, "said": "stop sent"}
            step = hub.do_row("test", {"action": "step", "args": {"id": keys[1], "angle": 20, "enable": True}})
            assert isinstance(step["result"], float) and step["result"] > 0
            assert step["said"] == f"step sent (move time {number_text(step['result'], None)} s)"
            got = hub.do_row("test", {"action": "get", "args": {"id": keys[0], "name": "vbus_voltage"}})
            assert got == {"result": 24.0, "said": "get: 24"}
            st = hub.do_row("test", {"action": "state", "args": {"id": keys[0]}})
            assert st["said"] is None and st["result"]["node"] == 1
            with pytest.raises(ValidationError, match=r"args=None: expected an object"):
                hub.do_row("test", {"action": "state"})
        finally:
            hub.close()
