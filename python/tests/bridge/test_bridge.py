"""End to end over Zenoh on 127.0.0.1: remote clients, ROS 2 topics and services, safety."""

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

from drempower import open_bus
from drempower.bridge import rmw, rosmsg
from drempower.protocol.enums import AxisState

from .conftest import Served, session, wait_for

pytestmark = pytest.mark.timeout(60)


def remote(served: Served, **kw: Any) -> Any:
    return open_bus("zenoh", served.prefix, connect=served.endpoint, gossip=False, **kw)


def test_remote_client_moves_a_simulated_motor(served: Served) -> None:
    with remote(served) as bus:
        assert bus.transport.info["motors"] == [1, 2]
        m = bus.motor(1)
        m.set_mode(2)
        m.set_angle(30.0, 30.0, 100.0, mode=1)
        m.wait_position_done(timeout=20)
        assert m.get_state().angle == pytest.approx(30.0, abs=0.5)
        assert served.sim.bus.motors[1].position == pytest.approx(30.0, abs=0.5)
        assert m.read_property("axis0.config.can_node_id") == 1


def test_no_bridge_is_a_clear_error() -> None:
    from drempower.transports import TransportError

    from .conftest import free_port

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with session(listen=[endpoint]), pytest.raises(TransportError, match="no drempower bridge answered on nobody/info"):
        open_bus("zenoh", "nobody", connect=endpoint, gossip=False, open_timeout=0.3)


def test_remote_timeout_is_a_timeout(served: Served) -> None:
    from drempower.client.errors import TimeoutError

    with remote(served, timeout=0.1) as bus, pytest.raises(TimeoutError):
        bus.motor(9).get_state()


_CLIENT = """
import sys, time
from drempower import open_bus
bus = open_bus("zenoh", sys.argv[1], connect=sys.argv[2], gossip=False, stop_on_close=False)
bus.motor(1).set_mode(2)
bus.motor(1).set_speed(30.0)
print("running", flush=True)
time.sleep(60)
"""


def test_client_that_disappears_idles_its_motor(served: Served) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-c", _CLIENT, served.prefix, served.endpoint], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "running"
        motor = served.sim.bus.motors[1]
        other = served.sim.bus.motors[2].state
        wait_for(lambda: abs(motor.speed) > 1.0)
        assert motor.state == AxisState.CLOSED_LOOP_CONTROL
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
        took = wait_for(lambda: motor.state == AxisState.IDLE, limit=2.0, step=0.005)
        assert took < served.bridge.options.command_timeout
        assert served.bridge.clients_idled == 1
        assert served.sim.bus.motors[2].state == other  # only the motors it drove
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)


def _call(sess: Any, key: str, seq: int) -> tuple[Any, rmw.Attachment]:
    t = rosmsg.typestore().types
    req = rosmsg.encode(
        t[rosmsg.TRIGGER + "_Request"](structure_needs_at_least_one_member=0), rosmsg.TRIGGER + "_Request"
    )
    gid = bytes(range(100, 116))
    att = rmw.Attachment(seq, time.time_ns(), gid).encode()
    import zenoh

    replies = list(sess.get(key, payload=req, attachment=att, target=zenoh.QueryTarget.ALL_COMPLETE, timeout=5))
    assert len(replies) == 1 and replies[0].ok is not None
    reply = replies[0].ok
    back = rmw.Attachment.decode(reply.attachment.to_bytes())
    assert back.sequence_number == seq and back.gid == gid
    return rosmsg.decode(reply.payload.to_bytes(), rosmsg.TRIGGER + "_Response"), back


def test_estop_through_the_service(served: Served) -> None:
    motor = served.sim.bus.motors[1]
    with remote(served, stop_on_close=False) as bus:
        bus.motor(1).set_mode(2)
        bus.motor(1).set_speed(20.0)
        wait_for(lambda: abs(motor.speed) > 1.0)
    with session(connect=[served.endpoint]) as ros:
        key = served.bridge.service_keys["estop"]
        assert key.startswith("0/estop/std_srvs::srv::dds_::Trigger_/RIHS01_eeff2cd6")
        resp, _ = _call(ros, key, 7)
        assert resp.success is True and "1, 2" in resp.message
        wait_for(lambda: motor.state == AxisState.IDLE, limit=1.0)
        resp, _ = _call(ros, served.bridge.service_keys["clear_errors"], 8)
        assert resp.success is True


def test_joint_states_decode_with_the_cdr_library(served: Served) -> None:
    with remote(served, stop_on_close=False) as bus:
        bus.motor(2).set_mode(2)
        bus.motor(2).set_angle(90.0, 60.0, 200.0, mode=1)
        bus.motor(2).wait_position_done(timeout=20)
    got: list[tuple[Any, bytes]] = []
    done = threading.Event()

    def on(sample: Any) -> None:
        got.append((rosmsg.decode(sample.payload.to_bytes(), rosmsg.JOINT_STATE), sample.attachment.to_bytes()))
        if len(got) >= 5:
            done.set()

    with session(connect=[served.endpoint]) as ros:
        key = f"0/joint_states/sensor_msgs::msg::dds_::JointState_/{rosmsg.ros_type_hash(rosmsg.JOINT_STATE)}"
        sub = ros.declare_subscriber(key, on)
        assert done.wait(5)
        sub.undeclare()
    msg, _ = got[-1]
    assert list(msg.name) == ["motor_1", "motor_2"]
    assert msg.position[0] == pytest.approx(0.0, abs=1e-3)
    assert msg.position[1] == pytest.approx(math.pi / 2, abs=0.01)
    assert msg.position[1] == pytest.approx(math.radians(served.sim.bus.motors[2].position), abs=0.01)
    assert abs(msg.header.stamp.sec - time.time()) < 5
    seqs = [rmw.Attachment.decode(a).sequence_number for _, a in got]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)


def test_liveliness_tokens_of_the_bridge(served: Served) -> None:
    with session(connect=[served.endpoint]) as ros:
        wait_for(lambda: len(list(ros.liveliness().get("@ros2_lv/0/**", timeout=2))) >= 8, limit=5)
        tokens = sorted(str(r.ok.key_expr) for r in ros.liveliness().get("@ros2_lv/0/**", timeout=2))
    zid = str(served.bridge.session.zid())
    js = rosmsg.ros_type_hash(rosmsg.JOINT_STATE)
    arr = rosmsg.ros_type_hash(rosmsg.FLOAT64_MULTI_ARRAY)
    assert f"@ros2_lv/0/{zid}/0/0/NN/%/%/drempower_bridge" in tokens
    assert (
        f"@ros2_lv/0/{zid}/0/1/MP/%/%/drempower_bridge/%joint_states/sensor_msgs::msg::dds_::JointState_/{js}/"
        "::,10:,:,:,," in tokens
    )
    assert (
        f"@ros2_lv/0/{zid}/0/2/MS/%/%/drempower_bridge/%position_commands/std_msgs::msg::dds_::Float64MultiArray_/"
        f"{arr}/::,10:,:,:,," in tokens
    )
    assert sum("/SS/" in t for t in tokens) == 3  # estop, clear_errors, enable


def _command(values: list[float]) -> bytes:
    t = rosmsg.typestore().types
    import numpy as np

    layout = t["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
    msg = t[rosmsg.FLOAT64_MULTI_ARRAY](layout=layout, data=np.array(values, dtype=np.float64))
    return rosmsg.encode(msg, rosmsg.FLOAT64_MULTI_ARRAY)


def test_position_commands_move_the_motors_and_silence_idles_them(served: Served) -> None:
    m1, m2 = served.sim.bus.motors[1], served.sim.bus.motors[2]
    with remote(served, stop_on_close=False) as bus:
        for i in (1, 2):
            bus.motor(i).set_mode(2)
    with session(connect=[served.endpoint]) as ros:
        pub = ros.declare_publisher(served.bridge.command_keys["position_commands"])
        time.sleep(0.2)
        target = [0.5, -0.25]  # rad
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            pub.put(_command(target), attachment=rmw.Attachment(1, time.time_ns(), bytes(16)).encode())
            if abs(m1.position - math.degrees(0.5)) < 1 and abs(m2.position - math.degrees(-0.25)) < 1:
                break
            time.sleep(0.02)
        assert m1.position == pytest.approx(math.degrees(0.5), abs=1)
        assert m2.position == pytest.approx(math.degrees(-0.25), abs=1)
        assert m1.state == AxisState.CLOSED_LOOP_CONTROL
        pub.put(_command([0.1]))  # wrong length: refused, logged, nothing sent
        t0 = time.monotonic()
        wait_for(lambda: m1.state == AxisState.IDLE and m2.state == AxisState.IDLE, limit=2.0, step=0.005)
        assert time.monotonic() - t0 < served.bridge.options.command_timeout + 0.1
        pub.undeclare()


def test_velocity_commands_in_rad_per_s(served: Served) -> None:
    m1 = served.sim.bus.motors[1]
    with remote(served, stop_on_close=False) as bus:
        bus.motor(1).set_mode(2)
        bus.motor(2).set_mode(2)
    with session(connect=[served.endpoint]) as ros:
        pub = ros.declare_publisher(served.bridge.command_keys["velocity_commands"])
        time.sleep(0.2)
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and abs(m1.speed - 60.0 / (2 * math.pi)) > 0.5:
            pub.put(_command([1.0, 0.0]))
            time.sleep(0.02)
        assert m1.speed == pytest.approx(60.0 / (2 * math.pi), abs=0.5)  # 1 rad/s = 9.55 r/min
        pub.undeclare()


def test_remote_estop_travels_on_its_own_key(served: Served) -> None:
    from drempower.transports.zenoh_wire import decode_frames, is_estop

    seen: dict[str, list[bool]] = {"tx": [], "estop": []}

    def watch(kind: str) -> Any:
        return lambda s: seen[kind].extend(is_estop(f) for f in decode_frames(s.payload.to_bytes()))

    from .conftest import free_port

    motor = served.sim.bus.motors[1]
    spy_endpoint = f"tcp/127.0.0.1:{free_port()}"
    with session(listen=[spy_endpoint]) as spy:  # peers do not route: the client connects to the spy too
        subs = [spy.declare_subscriber(f"{served.prefix}/{k}", watch(k)) for k in seen]
        with open_bus(
            "zenoh", served.prefix, connect=[served.endpoint, spy_endpoint], gossip=False, stop_on_close=False
        ) as bus:
            time.sleep(0.3)
            bus.motor(1).set_mode(2)
            bus.motor(1).set_speed(20.0)
            wait_for(lambda: abs(motor.speed) > 1.0)
            bus.estop()
            wait_for(lambda: motor.state == AxisState.IDLE, limit=1.0)
        wait_for(lambda: seen["estop"] == [True])
        for s in subs:
            s.undeclare()
    assert seen["tx"] and not any(seen["tx"])


async def test_async_remote_bus(served: Served) -> None:
    from drempower import open_bus_async

    bus = open_bus_async("zenoh", served.prefix, connect=[served.endpoint], gossip=False)
    try:
        st = await bus.motor(2).get_state()
        assert st.node == 2
    finally:
        await bus.close()


def test_cli_commands_work_remotely(served: Served) -> None:
    import json

    argv = [sys.executable, "-m", "drempower", "state", "--json", "1,2", "-i", "zenoh", "-c", served.prefix]
    run = subprocess.run(
        [*argv, "-o", f"connect={served.endpoint}", "-o", "gossip=false"], capture_output=True, text=True, timeout=30
    )
    assert run.returncode == 0, run.stderr
    rows = [json.loads(line) for line in run.stdout.splitlines()]
    assert [r["id"] for r in rows] == [1, 2]
    assert rows[0]["vbus_v"] == pytest.approx(24.0)


def test_a_failed_bus_is_reported() -> None:
    from drempower.bridge.server import Bridge, BridgeOptions
    from drempower.protocol.ids import Frame
    from drempower.transports.base import Transport

    from .conftest import free_port

    class Broken(Transport):
        description = "a bus that fails"

        def send(self, frame: Frame) -> None:
            pass

        def recv(self, timeout: float | None = None) -> Frame | None:
            raise OSError("adapter unplugged")

        def close(self) -> None:
            pass

    with session(listen=[f"tcp/127.0.0.1:{free_port()}"]) as sess:
        bridge = Bridge(Broken(), sess, BridgeOptions({"j": 1}, prefix=f"broken{free_port()}"))
        try:
            wait_for(lambda: bridge.failure is not None)
            assert "adapter unplugged" in str(bridge.failure)
        finally:
            bridge.close()


def test_options_are_checked() -> None:
    from drempower.bridge.server import BridgeOptions

    with pytest.raises(ValueError, match="command_timeout=0: 0 < timeout <= 60 s"):
        BridgeOptions({"j": 1}, command_timeout=0)
    with pytest.raises(ValueError, match="domain_id=233"):
        BridgeOptions({"j": 1}, domain_id=233)
    with pytest.raises(ValueError, match="at least one motor"):
        BridgeOptions({})


def test_stopping_the_bridge_idles_what_its_clients_and_ros_drove(served: Served) -> None:
    m1, m2 = served.sim.bus.motors[1], served.sim.bus.motors[2]
    with remote(served, stop_on_close=False) as bus, session(connect=[served.endpoint]) as ros:
        bus.motor(1).set_mode(2)
        bus.motor(2).set_mode(2)
        bus.motor(1).set_speed(20.0)  # a connected client's motor
        pub = ros.declare_publisher(served.bridge.command_keys["velocity_commands"])
        time.sleep(0.2)
        pub.put(_command([0.0, 2.0]))  # and ROS 2's
        wait_for(lambda: abs(m1.speed) > 1.0 and abs(m2.speed) > 1.0)
        served.bridge.close()
        wait_for(lambda: m1.state == AxisState.IDLE and m2.state == AxisState.IDLE, limit=1.0)
        pub.undeclare()


class _Bytes:
    def __init__(self, data: bytes) -> None:
        self._data = data

    def to_bytes(self) -> bytes:
        return self._data


class _Sample:
    """What the bridge reads of a Zenoh sample."""

    def __init__(self, key: str, frames: list[Any], attachment: bytes) -> None:
        from drempower.transports.zenoh_wire import encode_frames

        self.key_expr = key
        self.payload = _Bytes(encode_frames(frames))
        self.attachment = _Bytes(attachment)


def test_estop_overtakes_and_drops_what_was_queued_before_it(served: Served) -> None:
    from drempower.client.engine import ops
    from drempower.client.engine.commands import make_speed
    from drempower.protocol.ids import SysCmd
    from drempower.protocol.messages import SystemCommand

    bridge, tx, stop = served.bridge, f"{served.prefix}/tx", f"{served.prefix}/estop"
    seen: list[Any] = []
    served.sim.bus.add_listener(seen.append, host_frames=True)
    enable = ops.set_mode(1, 2).encode()
    speed = make_speed(1, 30.0).encode()
    estop = SystemCommand(1, SysCmd.ESTOP).encode()
    with bridge._write_lock:  # the bus is busy writing: client samples queue up
        bridge._on_tx(_Sample(tx, [enable], b"c1:1"))
        bridge._on_tx(_Sample(tx, [speed], b"c1:2"))
        stopper = threading.Thread(target=bridge._on_estop, args=(_Sample(stop, [estop], b"c1:4"),))
        stopper.start()
        wait_for(lambda: bridge.dropped_by_estop >= 1)  # the queue was emptied before the estop waits
    stopper.join(5)
    bridge._on_tx(_Sample(tx, [speed], b"c1:3"))  # sent before the estop, arrived after it: dropped
    bridge._on_tx(_Sample(tx, [enable], b"c2:1"))  # another client, after the estop: sent
    wait_for(lambda: enable in seen)
    mine = [f for f in seen if f in (enable, speed, estop)]
    assert mine == [estop, enable]
    assert bridge.dropped_by_estop == 3
    served.sim.bus.remove_listener(seen.append)


@pytest.mark.parametrize("served", [{"command_timeout": 30.0}], indirect=True)
def test_a_ros_publisher_that_leaves_idles_its_motors_at_once(served: Served) -> None:
    m1 = served.sim.bus.motors[1]
    with remote(served, stop_on_close=False) as bus:
        bus.motor(1).set_mode(2)
        bus.motor(2).set_mode(2)
    arr = rosmsg.dds_type_name(rosmsg.FLOAT64_MULTI_ARRAY)
    with session(connect=[served.endpoint]) as ros:
        zid = str(ros.zid())
        token = ros.liveliness().declare_token(
            rmw.entity_token(
                0,
                zid,
                0,
                10,
                "MP",
                "",
                "teleop",
                "/velocity_commands",
                arr,
                rosmsg.ros_type_hash(rosmsg.FLOAT64_MULTI_ARRAY),
            )
        )
        pub = ros.declare_publisher(served.bridge.command_keys["velocity_commands"])
        time.sleep(0.2)
        pub.put(_command([2.0, 0.0]))
        wait_for(lambda: abs(m1.speed) > 5.0)
        token.undeclare()  # the ROS 2 node goes away (the command timeout is 30 s here)
        took = wait_for(lambda: m1.state == AxisState.IDLE, limit=5.0, step=0.005)
        assert took < 1.0
        pub.undeclare()


def test_bad_endpoints_are_clear_errors(served: Served) -> None:
    from drempower.transports import TransportError

    with pytest.raises(TransportError, match="connect 'nowhere': a Zenoh endpoint is <protocol>/<address>"):
        open_bus("zenoh", served.prefix, connect="nowhere", gossip=False)
    port_in_use = served.endpoint  # the bridge listens there
    with pytest.raises(TransportError, match=r"cannot open remote bus .*cannot open a Zenoh session"):
        open_bus("zenoh", served.prefix, listen=port_in_use, connect=[], gossip=False)
