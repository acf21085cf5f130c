"""The Control view's controls run rows of the table of actions (:mod:`drempower.actions`): each one
moves the simulated motor as its row says and is logged by the row's name; a value outside the row's
domain is refused in the row's words before any frame; the command line says the same."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

pytest.importorskip("aiohttp")

from drempower import actions, open_bus
from drempower.cli import main
from drempower.client import Bus
from drempower.dash import Hub
from drempower.errors import ValidationError
from drempower.protocol import Frame
from drempower.protocol.enums import ControlMode, InputMode
from drempower.sim import SimBus

from .conftest import Served
from .test_browser import reset

BW = "axis0.controller.config.input_filter_bandwidth"


class Lines(logging.Handler):
    """The dashboard's log lines of one test."""

    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(record.getMessage())


@pytest.fixture
def rig() -> Iterator[tuple[Hub, Bus, SimBus, list[Frame], Lines]]:
    """A hub on simulated motors 1 and 2 (no scan: nothing polls), every frame the host sends, its log."""
    bus = open_bus("sim", motors=[1, 2], stop_on_close=False)
    sim: SimBus = bus.transport.bus  # type: ignore[attr-defined]
    hub = Hub(bus, poll_hz=50)
    frames: list[Frame] = []
    sim.add_listener(frames.append, host_frames=True)
    lines = Lines()
    logger = logging.getLogger("drempower.dash")
    logger.addHandler(lines)
    level = logger.level
    logger.setLevel(logging.INFO)
    try:
        yield hub, bus, sim, frames, lines
    finally:
        logger.removeHandler(lines)
        logger.setLevel(level)
        sim.remove_listener(frames.append)
        hub.close()
        bus.close()


def _settles(check: Callable[[], bool], within: float = 2.0) -> bool:
    deadline = time.monotonic() + within
    while not check():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


# (page control, the row it runs, what the row logs, what the simulated drive then holds)
CONTROLS: list[tuple[dict[str, Any], str, str, Callable[[Any], bool]]] = [
    (
        {"action": "T", "angle": 30, "speed": 0, "param": 40},
        "move",
        "move(angle=30.0, mode=T, bandwidth=40.0, enable=False)",
        lambda d: d.input_mode == InputMode.POS_FILTER and d.omega == pytest.approx(40),
    ),
    (
        {"action": "Q", "angle": -30, "speed": 60, "param": 200},
        "move",
        "move(angle=-30.0, mode=Q, speed=60.0, accel=200.0, enable=False)",
        lambda d: d.input_mode == InputMode.TRAP_TRAJ,
    ),
    (
        {"action": "P", "angle": 10, "speed": 1, "param": 0.1},
        "move",
        "move(angle=10.0, mode=P, speed_ff=1.0, torque_ff=0.1, enable=False)",
        lambda d: d.input_mode == InputMode.PASSTHROUGH and d.in_tq == pytest.approx(0.1),
    ),
    (
        {"action": "jog", "delta": 10, "speed": 60, "param": 200},
        "step",
        "step(angle=10.0, mode=Q, speed=60.0, accel=200.0, enable=False)",
        lambda d: d.input_mode == InputMode.TRAP_TRAJ,
    ),
    (
        {"action": "step", "delta": -10},
        "step",
        "step(angle=-10.0, mode=T, bandwidth=25.0, enable=False)",  # the motor's own bandwidth
        lambda d: d.input_mode == InputMode.POS_FILTER and d.omega == pytest.approx(25),
    ),
    (
        {"action": "V", "speed": 30, "mode": 1, "param": 0.1},
        "speed",
        "speed(speed=30.0, mode=1, torque_ff=0.1, enable=False)",
        lambda d: d.mode == ControlMode.VELOCITY_CONTROL and d.input_mode == InputMode.PASSTHROUGH,
    ),
    (
        {"action": "V", "speed": 20, "mode": 2, "param": 300},
        "speed",
        "speed(speed=20.0, mode=2, ramp=300.0, enable=False)",
        lambda d: d.input_mode == InputMode.VEL_RAMP and d.vel_rate > 0,
    ),
    (
        {"action": "C", "torque": 0.2, "mode": 1, "param": 0},
        "torque",
        "torque(torque=0.2, mode=1, enable=False)",
        lambda d: d.mode == ControlMode.TORQUE_CONTROL and d.in_tq == pytest.approx(0.2),
    ),
    (
        {"action": "C", "torque": 0.3, "mode": 6, "param": 10},
        "torque",
        "torque(torque=0.3, mode=6, ramp=10.0, enable=False)",
        lambda d: d.input_mode == InputMode.TORQUE_RAMP and d.tq_rate == pytest.approx(10),
    ),
    (
        {"action": "impedance", "angle": 20, "speed": 1, "torque": 0.1, "kp": 5, "kd": 0.5},
        "impedance",
        "impedance(pos=20.0, kp=5.0, kd=0.5, vel=1.0, tff=0.1, enable=False)",
        lambda d: d.mode == ControlMode.IMPEDANCE_CONTROL and d.imp_kp > 0,
    ),
]


@pytest.mark.parametrize(
    ("control", "row", "logged", "holds"), CONTROLS, ids=lambda v: "check" if callable(v) else str(v)[:40]
)
def test_each_page_control_runs_its_row(
    rig: tuple[Hub, Bus, SimBus, list[Frame], Lines],
    control: dict[str, Any],
    row: str,
    logged: str,
    holds: Callable[[Any], bool],
) -> None:
    hub, bus, sim, _frames, lines = rig
    bus.motor(1).write_property(BW, 25)
    hub.do_control("test", {"id": 1, **control})
    drive = sim.motors[1].drive
    assert _settles(lambda: holds(drive)), vars(drive)
    assert lines.lines[-1].endswith(f"dash: test: motor_1 {logged}"), lines.lines
    assert actions.get(row).safety == "motion" and 1 in hub.commanded


def test_the_synchronised_move_checks_each_motor_by_row_move(rig: tuple[Hub, Bus, SimBus, list[Frame], Lines]) -> None:
    hub, _bus, sim, _frames, lines = rig
    r = hub.do_control("test", {"action": "sync_move", "ids": [1, 2], "angles": [20, -20], "speed": 60, "accel": 300})
    assert r["seconds"] > 0 and hub.targets[1][0] == 20 and hub.targets[2][0] == -20
    assert _settles(lambda: all(abs(sim.motors[i].position - a) < 0.5 for i, a in ((1, 20), (2, -20))), 5)
    assert "set_angles([1, 2], [20.0, -20.0], speed=60.0, param=300.0, mode=1)" in lines.lines[-1]


# (page control, the row and its arguments that refuse the same value)
BAD: list[tuple[dict[str, Any], str, dict[str, Any]]] = [
    ({"action": "T", "angle": 10, "param": 301}, "move", {"angle": 10, "mode": "T", "bandwidth": 301}),
    ({"action": "T", "angle": 10, "param": 0}, "move", {"angle": 10, "mode": "T", "bandwidth": 0}),
    ({"action": "Q", "angle": 10, "speed": 20, "param": 0}, "move", {"angle": 10, "accel": 0}),
    ({"action": "Q", "angle": 10, "speed": -20, "param": 20}, "move", {"angle": 10, "speed": -20}),
    ({"action": "P", "angle": 10, "speed": 0, "param": 400}, "move", {"angle": 10, "mode": "P", "torque_ff": 400}),
    ({"action": "P", "angle": 10, "speed": -400, "param": 0}, "move", {"angle": 10, "mode": "P", "speed_ff": -400}),
    ({"action": "jog", "delta": 10, "speed": 20, "param": 500}, "step", {"angle": 10, "accel": 500}),
    ({"action": "step", "delta": 10, "param": 301}, "step", {"angle": 10, "mode": "T", "bandwidth": 301}),
    ({"action": "V", "speed": 10, "mode": 1, "param": 400}, "speed", {"speed": 10, "torque_ff": 400}),
    ({"action": "V", "speed": 10, "mode": 2, "param": 0}, "speed", {"speed": 10, "mode": 2, "ramp": 0}),
    ({"action": "V", "speed": 10, "mode": 3, "param": 1}, "speed", {"speed": 10, "mode": 3}),
    ({"action": "C", "torque": 0.1, "mode": 6, "param": 0}, "torque", {"torque": 0.1, "mode": 6, "ramp": 0}),
    ({"action": "C", "torque": 0.1, "mode": 6, "param": 400}, "torque", {"torque": 0.1, "mode": 6, "ramp": 400}),
    ({"action": "C", "torque": 0.1, "mode": 2, "param": 1}, "torque", {"torque": 0.1, "mode": 2}),
    ({"action": "impedance", "angle": 0, "kp": 400, "kd": 1}, "impedance", {"pos": 0, "kp": 400, "kd": 1}),
    ({"action": "sync_move", "ids": [1, 2], "angles": [1, 2], "accel": 0}, "move", {"angle": 1, "accel": 0}),
]


@pytest.mark.parametrize(("control", "row", "args"), BAD, ids=lambda v: str(v)[:40])
def test_a_value_outside_the_rows_domain_is_refused_in_its_words_and_nothing_is_sent(
    rig: tuple[Hub, Bus, SimBus, list[Frame], Lines], control: dict[str, Any], row: str, args: dict[str, Any]
) -> None:
    hub, _bus, sim, frames, _lines = rig
    with pytest.raises(ValidationError) as page:
        hub.do_control("test", {"id": 1, **control})
    with pytest.raises(ValidationError) as table:
        actions.validate(row, {"id": 1, **args})
    assert str(page.value) == str(table.value)
    assert frames == []  # refused before anything was asked or sent
    assert hub.commanded == set() and hub.targets == {}
    assert sim.motors[1].drive.in_vel == 0 and sim.motors[1].drive.in_tq == 0


SAME: list[tuple[dict[str, Any], list[str], str, list[str]]] = [
    (
        {"action": "P", "angle": 0, "speed": 0, "param": 400},
        ["move", "1", "0", "--mode", "P", "--torque-ff", "400"],
        "--torque-ff",
        ["actions", "move", "1", "0", "--mode", "P", "--torque-ff", "400"],
    ),
    (
        {"action": "V", "speed": 10, "mode": 1, "param": -400},
        ["speed", "1", "10", "--torque-ff", "-400"],
        "--torque-ff",
        ["actions", "speed", "1", "10", "--torque-ff", "-400"],
    ),
    (
        {"action": "V", "speed": 10, "mode": 2, "param": 0.001},
        ["speed", "1", "10", "--ramp", "0.001"],
        "--ramp",
        ["actions", "speed", "1", "10", "--mode", "2", "--ramp", "0.001"],
    ),
    (
        {"action": "Q", "angle": 0, "speed": 20, "param": 0.001},
        ["move", "1", "0", "--accel", "0.001"],
        "--accel",
        ["actions", "move", "1", "0", "--accel", "0.001"],
    ),
    (
        {"action": "T", "angle": 0, "param": 301},
        ["move", "1", "0", "--mode", "t", "--bandwidth", "301"],
        "--bandwidth",
        ["actions", "move", "1", "0", "--mode", "T", "--bandwidth", "301"],
    ),
    (
        {"action": "step", "delta": 5, "param": 301},
        ["move", "1", "5", "--relative", "--mode", "t", "--bandwidth", "301"],
        "--bandwidth",
        ["step", "1", "5", "--mode", "t", "--bandwidth", "301"],
    ),
]


@pytest.mark.parametrize(("control", "argv", "option", "row_argv"), SAME, ids=lambda v: str(v)[:40])
def test_the_same_bad_value_gets_the_same_words_from_the_command_line_and_the_page(
    rig: tuple[Hub, Bus, SimBus, list[Frame], Lines],
    capsys: pytest.CaptureFixture[str],
    control: dict[str, Any],
    argv: list[str],
    option: str,
    row_argv: list[str],
) -> None:
    """The command of the row (``drempower actions NAME``, or the command generated from it) says exactly
    what the page says; the hand-written command says the same of the option typed."""
    hub, _bus, _sim, frames, _lines = rig
    with pytest.raises(ValidationError) as page:
        hub.do_control("test", {"id": 1, **control})
    assert main([*row_argv, "--sim", "1"]) == 2
    assert capsys.readouterr().err == f"drempower: error: {page.value}\n"
    value, words = str(page.value).split("=", 1)[1].split(" is out of range", 1)
    assert main([*argv, "--sim", "1"]) == 2
    err = capsys.readouterr().err
    assert err.endswith(f"error: argument {option}: {value} is out of range{words}\n"), err
    assert frames == []


def test_the_page_s_step_and_velocity_controls_run_their_rows_in_chromium(page: Any, served: Served) -> None:
    """In headless Chromium: the Step button (a T step through the motor's own filter) moves the motor;
    a ramp of 0 passes the page's own bounds and is refused by row ``speed`` in its words, shown as an
    error, with nothing sent."""
    reset(served)
    page.wait_for_function("document.querySelectorAll('.card').length === 3")
    page.get_by_role("tab", name="Control").click()
    page.locator("#ctl-motor").select_option("1")
    m1 = served.sim.motors[1]
    at = m1.position
    page.locator("#step-delta").fill("30")
    page.get_by_role("button", name="Step", exact=True).click()
    assert _settles(lambda: abs(m1.position - (at + 30)) < 0.5, 8), (at, m1.position)
    assert served.hub.targets[1][0] == pytest.approx(at + 30, abs=0.5)
    page.evaluate("document.querySelector('#msg').textContent = ''")
    page.locator("#vel-speed").fill("30")
    page.locator("#vel-mode").select_option("2")
    page.locator("#vel-param").fill("0")
    page.get_by_role("button", name="Run", exact=True).click()
    page.wait_for_function("document.querySelector('#msg').textContent.includes('ramp=0')")
    msg = page.locator("#msg")
    with pytest.raises(ValidationError) as row:
        actions.validate("speed", {"id": 1, "speed": 30, "mode": 2, "ramp": 0})
    assert msg.inner_text() == str(row.value)
    assert "info" not in (msg.get_attribute("class") or "")  # an error, never green
    time.sleep(0.3)
    assert abs(m1.speed) < 0.5 and m1.drive.in_vel == 0
    reset(served)
