"""One simulated robot reached by joint name from several programs: ``drempower sim --robot FILE`` serves
its ``sim`` buses on socketcand and writes the robot file the others use; one rule for bus options."""

from __future__ import annotations

import io
import json
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

import drempower
from drempower.cli import _robot, build_parser, sim
from drempower.robot import load_robot

from .conftest import Cli

ROBOT = """
[buses.arm]
interface = "sim"
bitrate = 1000000
[joints.shoulder]
bus = "arm"
id = 1
gear = 2.0
[joints.elbow]
bus = "arm"
id = 2
"""


@pytest.fixture
def served(tmp_path: Path) -> Iterator[tuple[str, list[dict[str, object]]]]:
    path = tmp_path / "arm.toml"
    path.write_text(ROBOT)
    args = build_parser().parse_args(["sim", "--robot", str(path), "--time-scale", "20", "--json"])
    out, stop = io.StringIO(), threading.Event()
    thread = threading.Thread(target=sim.run, args=(args, out, stop))
    thread.start()
    try:
        deadline = time.monotonic() + 20.0
        while '"running"' not in out.getvalue() and time.monotonic() < deadline:
            time.sleep(0.01)
        records = [json.loads(line) for line in out.getvalue().splitlines()]
        (ready,) = [str(r["robot_file"]) for r in records if "robot_file" in r]
        yield ready, records
    finally:
        stop.set()
        thread.join(10)
    assert not thread.is_alive() and not Path(ready).exists()  # the ready file goes with the simulator


def test_sim_robot_serves_a_sim_bus_on_socketcand_and_writes_the_file_to_use(
    served: tuple[str, list[dict[str, object]]], cli: Cli
) -> None:
    ready, records = served
    (bus,) = [r for r in records if r.get("bus") == "arm"]
    assert bus["interface"] == "sim" and bus["host"] == "127.0.0.1" and int(str(bus["port"])) > 0
    spec = load_robot(ready)
    assert spec.buses["arm"].interface == "socketcand" and spec.buses["arm"].options["bitrate"] == 1000000
    assert spec.joints["shoulder"].gear == 2.0
    # a command moves the twin's shoulder; a script and a second command see it there: one robot
    r = cli("move", "shoulder", "30", "--wait", "--robot", ready, "--speed", "60", "--accel", "100", "--timeout", "2")
    assert r.code == 0, r.err
    with drempower.open_robot(ready, timeout=2, stop_on_close=False) as robot:
        assert robot.joint("shoulder").get_state().angle == pytest.approx(60, abs=0.5)  # 30 deg at the joint
    r = cli("state", "shoulder", "--robot", ready, "--json", "--timeout", "2")
    assert r.code == 0 and r.records()[0]["position_deg"] == pytest.approx(30, abs=0.5), r.out


def test_the_simulator_and_the_client_refuse_an_adapters_bitrate_in_the_same_words(tmp_path: Path, cli: Cli) -> None:
    path = tmp_path / "arm.toml"
    path.write_text(
        f'[buses.arm]\ninterface = "adapter"\nchannel = "{tmp_path / "link"}"\nbitrate = 1000000\n'
        '[joints.elbow]\nbus = "arm"\nid = 1\n'
    )
    served = cli("sim", "--robot", str(path), "--duration", "0.1")
    client = cli("state", "--robot", str(path))
    words = "the adapter's CAN bitrate is set with the vendor's configuration tool, not by the host"
    assert served.code == 2 and words in served.err, served.err
    assert words in client.err and "Traceback" not in served.err + client.err


def test_a_command_on_a_file_with_sim_buses_says_it_runs_a_twin_of_its_own(
    tmp_path: Path, cli: Cli, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "arm.toml"
    path.write_text(ROBOT)
    monkeypatch.setattr(_robot, "is_terminal", lambda stream: True)
    r = cli("state", "shoulder", "--robot", str(path))
    assert r.code == 0, r.err
    assert f"bus arm of {path} simulated by this command" in r.err and f"drempower sim --robot {path}" in r.err
