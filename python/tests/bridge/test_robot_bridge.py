"""A whole robot on the bridge: two simulated buses, a geared joint, Zenoh on 127.0.0.1 only."""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from drempower import open_bus
from drempower.bridge import rmw, rosmsg
from drempower.bridge.server import Bridge, BridgeOptions
from drempower.protocol.enums import AxisState
from drempower.robot.config import load_robot
from drempower.transports.sim import SimTransport

from ..robots import GEARED_ROBOT
from .conftest import free_port, session, wait_for
from .test_bridge import _call, _command

pytestmark = pytest.mark.timeout(60)

ROBOT = GEARED_ROBOT
NAMES = ["shoulder", "wrist", "elbow"]


@dataclass
class ServedRobot:
    bridge: Bridge
    sims: dict[str, SimTransport]
    endpoint: str
    prefix: str

    def motor(self, bus: str, node: int) -> Any:
        return self.sims[bus].bus.motors[node]

    def remote(self, bus: str) -> Any:
        return open_bus("zenoh", f"{self.prefix}/{bus}", connect=self.endpoint, gossip=False, stop_on_close=False)


@pytest.fixture
def robot_file(tmp_path: Path) -> Path:
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT)
    return path


@pytest.fixture
def served(robot_file: Path) -> Iterator[ServedRobot]:
    spec = load_robot(robot_file)
    sims = {"left": SimTransport([1, 2]), "right": SimTransport([1])}
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sess = session(listen=[endpoint])
    prefix = f"robot{free_port()}"
    bridge = Bridge(sims, sess, BridgeOptions(dict(spec.joints), prefix=prefix))
    try:
        yield ServedRobot(bridge, sims, endpoint, prefix)
    finally:
        bridge.close()
        sess.close()
        for s in sims.values():
            s.close()


def _joint_states(served: ServedRobot, count: int = 3) -> Any:
    got: list[Any] = []

    def on(sample: Any) -> None:
        got.append(rosmsg.decode(sample.payload.to_bytes(), rosmsg.JOINT_STATE))

    with session(connect=[served.endpoint]) as ros:
        sub = ros.declare_subscriber(served.bridge.joint_states_key, on)
        wait_for(lambda: len(got) >= count)
        sub.undeclare()
    return got[-1]


def _closed_loop(served: ServedRobot) -> None:
    for bus, ids in (("left", (1, 2)), ("right", (1,))):
        with served.remote(bus) as b:
            for i in ids:
                b.motor(i).set_mode(2)


def test_each_bus_is_a_remote_bus_under_its_own_prefix(served: ServedRobot) -> None:
    with served.remote("right") as right, served.remote("left") as left:
        assert right.transport.info["motors"] == [1] and right.transport.info["joints"] == ["elbow"]
        assert right.transport.info["bus"] == "right"
        assert left.transport.info["joints"] == ["shoulder", "wrist"]
        m = right.motor(1)
        m.set_mode(2)
        m.set_angle(90.0, 60.0, 200.0, mode=1)
        m.wait_position_done(timeout=20)
        assert served.motor("right", 1).position == pytest.approx(90.0, abs=0.5)
        assert served.motor("left", 1).position == pytest.approx(0.0, abs=0.01)  # the other bus did not move
        w = left.motor(2)
        w.set_mode(2)
        w.set_angle(90.0, 60.0, 200.0, mode=1)
        w.wait_position_done(timeout=20)
    msg = _joint_states(served)
    assert list(msg.name) == NAMES
    # at the joint: radians(deg) / gear + offset
    assert msg.position[0] == pytest.approx(0.0, abs=1e-3)
    assert msg.position[1] == pytest.approx(math.radians(served.motor("left", 2).position) / 2.0, abs=1e-3)
    assert msg.position[1] == pytest.approx(math.pi / 4, abs=0.01)
    assert msg.position[2] == pytest.approx(0.5 - math.radians(served.motor("right", 1).position), abs=1e-3)
    assert msg.position[2] == pytest.approx(0.5 - math.pi / 2, abs=0.01)


def test_position_commands_go_to_each_joints_bus_through_its_gear(served: ServedRobot) -> None:
    _closed_loop(served)
    s1, s2, e1 = served.motor("left", 1), served.motor("left", 2), served.motor("right", 1)
    target = [0.2, 0.3, -0.4]  # rad at the joints
    want = [math.degrees(0.2), math.degrees(0.3 * 2.0), math.degrees((-0.4 - 0.5) * -1.0)]  # deg at the motors
    with session(connect=[served.endpoint]) as ros:
        pub = ros.declare_publisher(served.bridge.command_keys["position_commands"])
        time.sleep(0.2)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            pub.put(_command(target), attachment=rmw.Attachment(1, time.time_ns(), bytes(16)).encode())
            if all(abs(m.position - w) < 0.5 for m, w in zip((s1, s2, e1), want, strict=True)):
                break
            time.sleep(0.02)
        assert [s1.position, s2.position, e1.position] == pytest.approx(want, abs=0.5)
        t0 = time.monotonic()  # silence: every joint of every bus goes idle within the command timeout
        wait_for(lambda: all(m.state == AxisState.IDLE for m in (s1, s2, e1)), limit=2.0, step=0.005)
        assert time.monotonic() - t0 < served.bridge.options.command_timeout + 0.1
        pub.undeclare()
    msg = _joint_states(served)
    assert list(msg.position) == pytest.approx(target, abs=0.02)


def test_velocity_commands_in_rad_per_s_at_the_joint(served: ServedRobot) -> None:
    _closed_loop(served)
    rpm = 60.0 / (2 * math.pi)  # r/min per rad/s
    s2, e1 = served.motor("left", 2), served.motor("right", 1)
    with session(connect=[served.endpoint]) as ros:
        pub = ros.declare_publisher(served.bridge.command_keys["velocity_commands"])
        time.sleep(0.2)
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and (abs(s2.speed - 2 * rpm) > 0.5 or abs(e1.speed + rpm) > 0.5):
            pub.put(_command([0.0, 1.0, 1.0]))
            time.sleep(0.02)
        assert s2.speed == pytest.approx(2 * rpm, abs=0.5)  # gear 2
        assert e1.speed == pytest.approx(-rpm, abs=0.5)  # gear -1
        stop = threading.Event()

        def stream() -> None:
            while not stop.wait(0.02):
                pub.put(_command([0.0, 1.0, 1.0]))

        streamer = threading.Thread(target=stream)
        streamer.start()  # held while joint_states is read: the command timeout is 0.2 s
        try:
            msg = _joint_states(served)
        finally:
            stop.set()
            streamer.join(5)
        assert msg.velocity[1] == pytest.approx(1.0, abs=0.1) and msg.velocity[2] == pytest.approx(1.0, abs=0.1)
        pub.undeclare()


def test_an_invalid_value_sends_nothing_on_any_bus(served: ServedRobot) -> None:
    _closed_loop(served)
    s1, e1 = served.motor("left", 1), served.motor("right", 1)
    with session(connect=[served.endpoint]) as ros:
        pub = ros.declare_publisher(served.bridge.command_keys["position_commands"])
        time.sleep(0.2)
        for _ in range(10):
            pub.put(_command([0.5, 0.5, math.nan]))  # the elbow's value is refused: the left bus gets nothing
            time.sleep(0.02)
        time.sleep(0.3)
        assert s1.position == pytest.approx(0.0, abs=0.01) and e1.position == pytest.approx(0.0, abs=0.01)
        assert s1.state == AxisState.CLOSED_LOOP_CONTROL  # nothing was sent, so nothing was idled either
        pub.undeclare()


def test_estop_clear_errors_and_enable_reach_every_bus(served: ServedRobot) -> None:
    _closed_loop(served)
    motors = [served.motor("left", 1), served.motor("left", 2), served.motor("right", 1)]
    with session(connect=[served.endpoint]) as ros:
        pub = ros.declare_publisher(served.bridge.command_keys["velocity_commands"])
        time.sleep(0.2)
        pub.put(_command([1.0, 1.0, 1.0]))
        wait_for(lambda: all(abs(m.speed) > 1.0 for m in motors))
        resp, _ = _call(ros, served.bridge.service_keys["estop"], 3)
        assert resp.success is True and resp.message == "estop sent to joints shoulder, wrist, elbow"
        wait_for(lambda: all(m.state == AxisState.IDLE for m in motors), limit=1.0)
        resp, _ = _call(ros, served.bridge.service_keys["clear_errors"], 4)
        assert resp.success is True and "shoulder, wrist, elbow" in resp.message
        resp, _ = _call(ros, served.bridge.service_keys["enable"], 5)
        assert resp.success is True and resp.message == "closed loop on joints shoulder, wrist, elbow"
        wait_for(lambda: all(m.state == AxisState.CLOSED_LOOP_CONTROL for m in motors), limit=1.0)
        pub.undeclare()


def test_an_enable_a_joint_refuses_names_it_as_the_dashboard_does(served: ServedRobot) -> None:
    """The enable service on a robot goes through the command service for every joint of every bus: the
    joint that refuses closed loop is named as the dashboard names a robot's joint (name, bus, motor), the
    others are enabled; the keys of two buses with the same motor id do not mix."""
    from drempower.protocol.flags import MotorError

    served.motor("right", 1).inject_error(MotorError.DRV_FAULT)  # elbow; shoulder is motor 1 of bus left
    with session(connect=[served.endpoint]) as ros:
        resp, _ = _call(ros, served.bridge.service_keys["enable"], 1)
    assert resp.success is False
    assert resp.message == (
        "enable failed: elbow (bus right, motor 1) did not enter closed loop (state idle): its error flags are "
        "set: clear errors first, then enable again"
    )
    assert served.motor("left", 1).state == AxisState.CLOSED_LOOP_CONTROL
    assert served.motor("left", 2).state == AxisState.CLOSED_LOOP_CONTROL


def test_options_that_do_not_match_the_buses_are_refused(robot_file: Path) -> None:
    spec = load_robot(robot_file)
    with session(listen=[f"tcp/127.0.0.1:{free_port()}"]) as sess:
        sim = SimTransport([1, 2])
        try:
            with pytest.raises(ValueError, match="joint 'elbow': bus 'right'"):
                Bridge({"left": sim}, sess, BridgeOptions(dict(spec.joints), prefix=f"r{free_port()}"))
            with pytest.raises(ValueError, match="joint 'a': no bus"):
                Bridge({"left": sim}, sess, BridgeOptions({"a": 1}, prefix=f"r{free_port()}"))
        finally:
            sim.close()


def test_cli_serves_the_robot_and_stops_on_sigterm(robot_file: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    prefix = f"cli{free_port()}"
    argv = [sys.executable, "-m", "drempower", "bridge", "--robot", str(robot_file), "--listen", endpoint]
    argv += ["--connect", f"tcp/127.0.0.1:{free_port()}", "--prefix", prefix, "--json"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        record = json.loads(proc.stdout.readline())
        assert record["buses"] == {"left": f"{prefix}/left", "right": f"{prefix}/right"}
        assert record["joints"]["elbow"] == {"bus": "right", "id": 1, "gear": -1.0, "offset": 0.5}
        assert list(record["joints"]) == NAMES
        with open_bus("zenoh", f"{prefix}/right", connect=endpoint, gossip=False) as bus:
            assert bus.motor(1).get_state().node == 1
            assert bus.transport.info["joints"] == ["elbow"]
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=20)
        assert proc.returncode == 128 + signal.SIGTERM, err
        assert f"prefixes {prefix}/left (bus left), {prefix}/right (bus right)" in err
        assert "stopped" in err and "Traceback" not in err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)


@pytest.mark.parametrize(
    ("extra", "message"),
    [(["--ids", "1"], "--ids: not with --robot"), (["--sim", "1"], "--robot and --sim conflict")],
)
def test_cli_robot_usage_errors(robot_file: Path, extra: list[str], message: str) -> None:
    argv = [sys.executable, "-m", "drempower", "bridge", "--robot", str(robot_file), *extra]
    run = subprocess.run([*argv, "--connect", "tcp/127.0.0.1:1"], capture_output=True, text=True, timeout=30)
    assert run.returncode == 2 and message in run.stderr and "Traceback" not in run.stderr


def test_the_bridges_end_holds_a_joint_that_holds_and_idles_one_that_says_idle(tmp_path: Path) -> None:
    """Its way out (Ctrl-C, SIGTERM, SIGHUP): each joint does its on_timeout; a bare motor id still idles."""
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT.replace("gear = -1.0\n", 'gear = -1.0\non_timeout = "idle"\n'))
    spec = load_robot(path)
    sims = {"left": SimTransport([1, 2]), "right": SimTransport([1])}
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    prefix = f"robot{free_port()}"
    with session(listen=[endpoint]) as sess:
        bridge = Bridge(sims, sess, BridgeOptions(dict(spec.joints), prefix=prefix))
        served = ServedRobot(bridge, sims, endpoint, prefix)
        try:
            with served.remote("left") as left, served.remote("right") as right:
                for bus in (left, right):
                    bus.motor(1).set_mode(2)
                    bus.motor(1).set_speed(20.0)
                shoulder, elbow = served.motor("left", 1), served.motor("right", 1)
                wait_for(lambda: abs(shoulder.speed - 20) < 1 and abs(elbow.speed + 0 - 20) < 1, limit=5.0)
                bridge.stop()
                wait_for(lambda: abs(shoulder.speed) < 0.5 and elbow.state == AxisState.IDLE, limit=5.0)
                assert shoulder.state == AxisState.CLOSED_LOOP_CONTROL  # held at speed 0, not dropped
        finally:
            bridge.close()
            for s in sims.values():
                s.close()


def test_the_bridge_refuses_beyond_the_files_limits_in_the_words_of_python(tmp_path: Path) -> None:
    """The robot file's limits reach the bridge from the one place every front end uses: a ROS 2 command
    beyond the elbow's is refused naming the file and the joint, as open_robot and the CLI do."""
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT.replace("offset = 0.5\n", "offset = 0.5\nlimits = { position = [0.0, 1.0] }\n"))
    spec = load_robot(path)
    sims = {"left": SimTransport([1, 2]), "right": SimTransport([1])}
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    prefix = f"robot{free_port()}"
    with session(listen=[endpoint]) as sess:
        bridge = Bridge(sims, sess, BridgeOptions(dict(spec.joints), prefix=prefix, robot=spec))
        served = ServedRobot(bridge, sims, endpoint, prefix)
        try:
            _closed_loop(served)
            e1 = served.motor("right", 1)
            with session(connect=[endpoint]) as ros:
                pub = ros.declare_publisher(bridge.command_keys["position_commands"])
                time.sleep(0.2)
                for _ in range(10):
                    pub.put(_command([0.0, 0.0, 2.0]))  # the elbow at 2 rad: beyond its 0..1 rad
                    time.sleep(0.02)
                wait_for(lambda: bridge.last_refusal is not None, limit=5.0)
                pub.undeclare()
            assert bridge.last_refusal is not None
            assert f"(set by {path}: [joints.elbow] limits)" in bridge.last_refusal, bridge.last_refusal
            assert e1.position == pytest.approx(0.0, abs=0.01)  # nothing was sent
        finally:
            bridge.close()
            for s in sims.values():
                s.close()
