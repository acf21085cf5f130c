"""The bridge's watch over its remote controllers: frozen clients, ROS 2 publishers, resuming after a timeout."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import threading
import time
from typing import Any

import pytest

from drempower.bridge import rmw, rosmsg
from drempower.protocol.enums import AxisState

from .conftest import Served, session, wait_for
from .test_bridge import _call, _command, remote

pytestmark = pytest.mark.timeout(60)

_CLIENT = """
import sys, time
from drempower import open_bus
bus = open_bus("zenoh", sys.argv[1], connect=sys.argv[2], gossip=False, stop_on_close=False)
bus.motor(1).set_mode(2)
bus.motor(1).set_speed(30.0)
print("running", flush=True)
time.sleep(60)
"""


def test_a_frozen_client_has_its_motor_idled_within_the_command_timeout(served: Served) -> None:
    timeout = served.bridge.options.command_timeout
    proc = subprocess.Popen(
        [sys.executable, "-c", _CLIENT, served.prefix, served.endpoint], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "running"
        motor = served.sim.bus.motors[1]
        wait_for(lambda: abs(motor.speed) > 1.0)
        time.sleep(4 * timeout)  # a client with nothing to send: its keep-alives hold its motor
        assert motor.state == AxisState.CLOSED_LOOP_CONTROL and abs(motor.speed) > 1.0
        assert served.bridge.clients_idled == 0
        os.kill(proc.pid, signal.SIGSTOP)  # frozen: its liveliness token outlives it by the Zenoh lease
        took = wait_for(lambda: motor.state == AxisState.IDLE, limit=3.0, step=0.005)
        assert took < timeout + 0.15
        assert served.bridge.clients_idled == 1
        os.kill(proc.pid, signal.SIGCONT)
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGCONT)
            proc.kill()
            proc.wait(10)


def test_a_quiet_client_keeps_its_motors_through_a_long_move(served: Served) -> None:
    motor = served.sim.bus.motors[1]
    with remote(served, stop_on_close=False) as bus:
        assert bus.transport.keepalive_period == pytest.approx(served.bridge.options.command_timeout / 4)
        m = bus.motor(1)
        m.set_mode(2)
        m.set_angle(60.0, 60.0, 100.0, mode=1)  # about 1 s, far beyond the 0.2 s timeout
        m.wait_position_done(timeout=20)
        time.sleep(0.5)
        assert motor.state == AxisState.CLOSED_LOOP_CONTROL
        assert motor.position == pytest.approx(60.0, abs=0.5)
        assert served.bridge.clients_idled == 0


def _position_stream(served: Served, pub: Any, target: list[float]) -> None:
    m1, m2 = served.sim.bus.motors[1], served.sim.bus.motors[2]
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        pub.put(_command(target))
        if abs(m1.position - math.degrees(target[0])) < 1 and abs(m2.position - math.degrees(target[1])) < 1:
            return
        time.sleep(0.02)


def test_the_enable_service_resumes_after_a_command_timeout(served: Served) -> None:
    m1, m2 = served.sim.bus.motors[1], served.sim.bus.motors[2]
    with remote(served, stop_on_close=False) as bus:
        for i in (1, 2):
            bus.motor(i).set_mode(2)
    with session(connect=[served.endpoint]) as ros:
        key = served.bridge.service_keys["enable"]
        assert key.startswith("0/enable/std_srvs::srv::dds_::Trigger_/RIHS01_eeff2cd6")
        pub = ros.declare_publisher(served.bridge.command_keys["position_commands"])
        time.sleep(0.2)
        _position_stream(served, pub, [0.5, -0.25])
        assert m1.position == pytest.approx(math.degrees(0.5), abs=1)
        wait_for(lambda: m1.state == AxisState.IDLE and m2.state == AxisState.IDLE, limit=2.0)  # silent: timeout
        resp, _ = _call(ros, key, 3)
        assert resp.success is True and "1, 2" in resp.message
        wait_for(lambda: m1.state == AxisState.CLOSED_LOOP_CONTROL and m2.state == AxisState.CLOSED_LOOP_CONTROL)
        _position_stream(served, pub, [-0.5, 0.25])
        assert m1.position == pytest.approx(math.degrees(-0.5), abs=1)
        assert m2.position == pytest.approx(math.degrees(0.25), abs=1)
        pub.undeclare()


def _publisher_token(ros: Any, entity: int, node: str) -> Any:
    arr = rosmsg.dds_type_name(rosmsg.FLOAT64_MULTI_ARRAY)
    h = rosmsg.ros_type_hash(rosmsg.FLOAT64_MULTI_ARRAY)
    token = rmw.entity_token(0, str(ros.zid()), 0, entity, "MP", "", node, "/velocity_commands", arr, h)
    return ros.liveliness().declare_token(token)


@pytest.mark.parametrize("served", [{"command_timeout": 30.0}], indirect=True)
def test_one_of_two_publishers_leaving_keeps_the_motors_driven(served: Served) -> None:
    m1 = served.sim.bus.motors[1]
    with remote(served, stop_on_close=False) as bus:
        bus.motor(1).set_mode(2)
        bus.motor(2).set_mode(2)
    with session(connect=[served.endpoint]) as ros_a, session(connect=[served.endpoint]) as ros_b:
        token_a, token_b = _publisher_token(ros_a, 10, "teleop"), _publisher_token(ros_b, 10, "planner")
        pub_a = ros_a.declare_publisher(served.bridge.command_keys["velocity_commands"])
        pub_b = ros_b.declare_publisher(served.bridge.command_keys["velocity_commands"])
        stop = threading.Event()

        def stream() -> None:
            while not stop.wait(0.02):
                pub_b.put(_command([2.0, 0.0]))

        streamer = threading.Thread(target=stream)
        time.sleep(0.2)
        pub_a.put(_command([2.0, 0.0]))
        streamer.start()
        try:
            wait_for(lambda: abs(m1.speed) > 5.0)
            token_a.undeclare()  # one node goes; the other still streams
            time.sleep(0.5)
            assert m1.state == AxisState.CLOSED_LOOP_CONTROL and abs(m1.speed) > 5.0
            stop.set()
            streamer.join(5)
            token_b.undeclare()  # the last one goes: idle at once (the command timeout is 30 s here)
            took = wait_for(lambda: m1.state == AxisState.IDLE, limit=5.0, step=0.005)
            assert took < 1.0
        finally:
            stop.set()
            streamer.join(5)
            pub_a.undeclare()
            pub_b.undeclare()
