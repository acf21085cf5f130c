"""``drempower sim --robot FILE`` serves the twin on every kind of attachment, one twin behind all buses."""

from __future__ import annotations

import io
import json
import math
import threading
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

from drempower.cli import build_parser, sim
from drempower.robot import open_robot

from .conftest import ROBOTS

_GAINS = """
[joints.{0}.sim_params]
"axis0.controller.config.pos_gain" = 20.0
"axis0.controller.config.vel_gain" = 0.5
"axis0.controller.config.vel_integrator_gain" = 5.0
"""


def _file(tmp_path: Path, adapter: Path, uart: Path, channel: str, port: int) -> Path:
    text = f"""
[model]
file = "{ROBOTS / "arm6.xml"}"
[buses.left]
interface = "adapter"
channel = "{adapter}"
timeout = 2
[buses.wrist]
interface = "uart"
channel = "{uart}"
timeout = 2
[buses.right]
interface = "virtual"
channel = "{channel}"
timeout = 2
[buses.remote]
interface = "socketcand"
host = "127.0.0.1"
port = {port}
channel = "can0"
timeout = 2
[joints.base_yaw]
bus = "left"
id = 1
[joints.shoulder]
bus = "left"
id = 2
[joints.elbow]
bus = "left"
id = 3
[joints.wrist_roll]
bus = "wrist"
id = 4
[joints.wrist_pitch]
bus = "right"
id = 5
[joints.flange_roll]
bus = "remote"
id = 6
"""
    path = tmp_path / f"served-{port}.toml"
    path.write_text(text + "".join(_GAINS.format(j) for j in ("base_yaw", "shoulder", "elbow")))
    return path


@contextmanager
def _served(*argv: str) -> Iterator[list[dict[str, Any]]]:
    """``drempower sim ARGV --json`` on a thread: its records once it runs; stopped (and checked) after."""
    args = build_parser().parse_args(["sim", *argv, "--json"])
    out, stop = io.StringIO(), threading.Event()
    thread = threading.Thread(target=sim.run, args=(args, out, stop))
    thread.start()
    try:
        deadline = time.monotonic() + 30.0
        while '"running"' not in out.getvalue() and time.monotonic() < deadline:
            time.sleep(0.01)
        yield [json.loads(line) for line in out.getvalue().splitlines()]
    finally:
        stop.set()
        thread.join(10)
    assert not thread.is_alive()
    assert '"stopped": true' in out.getvalue()


def test_the_twin_behind_adapter_uart_python_can_and_socketcand(tmp_path: Path) -> None:
    adapter, uart = tmp_path / "adapter", tmp_path / "uart"
    channel = f"drempower-twin-{uuid.uuid4().hex}"
    served = _file(tmp_path, adapter, uart, channel, 0)
    with _served("--robot", str(served)) as records:
        assert records[0]["joints"] == ["base_yaw", "shoulder", "elbow", "wrist_roll", "wrist_pitch", "flange_roll"]
        port = next(r["port"] for r in records if r.get("interface") == "socketcand")
        with open_robot(_file(tmp_path, adapter, uart, channel, port), stop_on_close=False) as robot:
            robot.joint("shoulder").set_position(math.radians(40.0))
            deadline = time.monotonic() + 30.0  # about 1 s of simulated time, however loaded the machine
            shoulder = robot.joint("shoulder").get_joint_state()
            while abs(math.degrees(shoulder.position) - 40.0) > 0.5 and time.monotonic() < deadline:
                time.sleep(0.1)
                shoulder = robot.joint("shoulder").get_joint_state()
            time.sleep(0.5)
            states = robot.get_states()
            shoulder = robot.joint("shoulder").get_joint_state()
            assert math.degrees(shoulder.position) == pytest.approx(40.0, abs=0.5)
            assert shoulder.torque < -1.0  # it holds the arm up against gravity (positive turns tip it over)
            assert {n: s.node for n, s in states.items()} == {
                "base_yaw": 1,
                "shoulder": 2,
                "elbow": 3,
                "wrist_roll": 4,
                "wrist_pitch": 5,
                "flange_roll": 6,
            }


def test_sim_robot_names_a_joint_the_model_lacks(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from drempower.cli import main

    path = tmp_path / "bad.toml"
    path.write_text(
        f'[model]\nfile = "{ROBOTS / "pendulum.xml"}"\n[buses.a]\ninterface = "sim"\n[joints.knee]\nbus = "a"\nid = 1\n'
    )
    code = main(["sim", "--robot", str(path), "--duration", "0.1"])
    err = capsys.readouterr().err
    assert code == 2  # a robot file that cannot be used is a validation error
    assert err.count("\n") == 1 and "joint 'knee': model_joint='knee' is not a joint of the model (swing)" in err


def test_sensor_noise_on_the_served_twins_readings() -> None:
    """``--noise``: what a client reads of the served twin scatters by the deviation asked (seeded)."""
    with _served("--robot", str(ROBOTS / "arm6.toml"), "--noise", "position=0.05", "--seed", "4") as records:
        ready = next(r["robot_file"] for r in records if "robot_file" in r)
        with open_robot(ready, stop_on_close=False) as robot:
            base = robot.joint("base_yaw")  # about a vertical axis: at rest where it powered up
            deg = [math.degrees(base.get_joint_state().position) for _ in range(300)]
    mean = sum(deg) / len(deg)
    sd = math.sqrt(sum((x - mean) ** 2 for x in deg) / (len(deg) - 1))
    assert abs(mean) < 0.02  # 300 readings: 7 sigma of the mean
    assert sd == pytest.approx(0.05, rel=0.25)
