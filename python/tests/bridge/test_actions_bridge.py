"""The bridge's ROS 2 topics and services act through drempower.actions and the safety gate, over Zenoh on 127.0.0.1."""

from __future__ import annotations

import math
import re
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from drempower.bridge import rosmsg
from drempower.bridge.bus_face import ENABLE_FIX
from drempower.bridge.hub import driven_nodes
from drempower.bridge.server import Bridge, BridgeOptions, motor_joints
from drempower.errors import MotorIdleError
from drempower.protocol.enums import AxisState
from drempower.protocol.ids import Frame
from drempower.robot.config import load_robot
from drempower.transports.sim import SimTransport

from .conftest import Served, free_port, session, wait_for
from .test_bridge import _call, _command, remote

pytestmark = pytest.mark.timeout(60)


class _Frames:
    """Every frame a host put on the simulated bus, from now on."""

    def __init__(self, sim: SimTransport) -> None:
        self.sim = sim
        self.seen: list[Frame] = []
        self._lock = threading.Lock()
        sim.bus.add_listener(self._add, host_frames=True)

    def _add(self, frame: Frame) -> None:
        with self._lock:
            self.seen.append(frame)

    def driven(self) -> set[int]:
        """Motors that a motion command, preset or start was sent to."""
        with self._lock:
            return driven_nodes(self.seen)

    def close(self) -> None:
        self.sim.bus.remove_listener(self._add)


def _publish_until_refused(served_bridge: Bridge, pub: Any, values: list[float], refused: int) -> str:
    """Publish ``values`` until the bridge has refused ``refused`` commands; its last refusal's words."""
    deadline = time.monotonic() + 5
    while served_bridge.refused < refused:
        assert time.monotonic() < deadline, "the bridge refused nothing"
        pub.put(_command(values))
        time.sleep(0.05)
    assert served_bridge.last_refusal is not None
    return served_bridge.last_refusal


def test_a_command_to_idle_motors_is_refused_with_the_gates_words_and_nothing_sent(served: Served) -> None:
    m1, m2 = served.sim.bus.motors[1], served.sim.bus.motors[2]
    with remote(served) as bus:  # a previous program leaves them idle
        bus.idle([1, 2])
    wait_for(lambda: m1.state == AxisState.IDLE and m2.state == AxisState.IDLE)
    frames = _Frames(served.sim)
    heard: list[Any] = []
    try:
        with session(connect=[served.endpoint]) as ros:
            log_key = f"0/rosout/rcl_interfaces::msg::dds_::Log_/{rosmsg.ros_type_hash(rosmsg.LOG)}"
            sub = ros.declare_subscriber(
                log_key, lambda s: heard.append(rosmsg.decode(s.payload.to_bytes(), rosmsg.LOG))
            )
            pub = ros.declare_publisher(served.bridge.command_keys["position_commands"])
            time.sleep(0.2)
            said = _publish_until_refused(served.bridge, pub, [0.5, -0.25], 1)
            wait_for(lambda: bool(heard))  # the caller is told, on /rosout
            pub.undeclare()
            sub.undeclare()
        assert (heard[0].msg, heard[0].level, heard[0].name) == (said, 30, "drempower_bridge")
        fix = ENABLE_FIX.format(ids="1,2")
        assert said == f"position_commands refused: {MotorIdleError([1, 2], [1, 1], fix=fix)}"
        assert said == (
            "position_commands refused: motors 1, 2 are idle (not in closed loop): enable them first "
            "(call the enable service, or drempower enable 1,2)"
        )
        # the words of the Python API, the CLI and the dashboard, up to the fix in the caller's terms
        with pytest.raises(MotorIdleError) as api:
            served.bridge.bus.set_speeds([1, 2], [1.0, 1.0])
        assert str(api.value).startswith("motors 1, 2 are idle (not in closed loop): enable them first (")
        assert frames.driven() == set()  # no motion frame reached the bus
        assert m1.position == pytest.approx(0.0, abs=1e-6) and m2.position == pytest.approx(0.0, abs=1e-6)
    finally:
        frames.close()


def test_out_of_range_is_refused_naming_field_value_and_range_and_a_valid_command_acts(served: Served) -> None:
    m1, m2 = served.sim.bus.motors[1], served.sim.bus.motors[2]
    with session(connect=[served.endpoint]) as ros:
        resp, _ = _call(ros, served.bridge.service_keys["enable"], 1)  # the enable row, for each motor served
        assert resp.success is True and resp.message == "closed loop on motors 1, 2"
        wait_for(lambda: m1.state == AxisState.CLOSED_LOOP_CONTROL and m2.state == AxisState.CLOSED_LOOP_CONTROL)
        frames = _Frames(served.sim)
        try:
            pub = ros.declare_publisher(served.bridge.command_keys["velocity_commands"])
            time.sleep(0.2)
            said = _publish_until_refused(served.bridge, pub, [100.0, 0.0], 1)  # 100 rad/s = 954.9 r/min
            assert re.fullmatch(
                r"velocity_commands refused: joint 'motor_1' \(velocity 100 rad/s\): "
                r"speed=954\.9\d* is out of range: allowed -327\.68\.\.327\.67 \(r/min\)",
                said,
            ), said
            said = _publish_until_refused(served.bridge, pub, [0.0, math.nan], 2)
            assert said == (
                "velocity_commands refused: joint 'motor_2' (velocity nan rad/s): speed=nan: expected a finite number"
            )
            assert frames.driven() == set()
            assert m1.speed == 0.0 and m2.speed == 0.0
            deadline = time.monotonic() + 5  # a valid command acts (1 rad/s = 9.55 r/min)
            while time.monotonic() < deadline and abs(m1.speed - 60.0 / (2 * math.pi)) > 0.5:
                pub.put(_command([1.0, 0.0]))
                time.sleep(0.02)
            assert m1.speed == pytest.approx(60.0 / (2 * math.pi), abs=0.5)
            assert frames.driven() == {1, 2}
            assert served.bridge.refused == 2
            pub.undeclare()
        finally:
            frames.close()


def test_after_the_estop_service_commands_are_refused_until_enable(served: Served) -> None:
    m1 = served.sim.bus.motors[1]
    with session(connect=[served.endpoint]) as ros:
        assert _call(ros, served.bridge.service_keys["enable"], 1)[0].success
        pub = ros.declare_publisher(served.bridge.command_keys["velocity_commands"])
        time.sleep(0.2)
        wait_for(lambda: (pub.put(_command([1.0, 0.0])), abs(m1.speed) > 1.0)[1])
        resp, _ = _call(ros, served.bridge.service_keys["estop"], 2)  # the estop row, ahead of everything
        assert resp.success is True and resp.message == "estop sent to motors 1, 2"
        wait_for(lambda: m1.state == AxisState.IDLE, limit=1.0)
        refused = served.bridge.refused
        said = _publish_until_refused(served.bridge, pub, [1.0, 0.0], refused + 1)
        assert "motors 1, 2 are idle (not in closed loop): enable them first (call the enable service" in said
        assert _call(ros, served.bridge.service_keys["clear_errors"], 3)[0].success
        assert _call(ros, served.bridge.service_keys["enable"], 4)[0].success
        wait_for(lambda: (pub.put(_command([1.0, 0.0])), abs(m1.speed) > 1.0)[1])
        pub.undeclare()


def test_the_enable_service_succeeds_only_once_the_motors_are_in_closed_loop(served: Served) -> None:
    """A motor with error flags ignores an enable: the service says so (which motor, its state, the fix)
    rather than success, in the words the dashboard uses; after clear_errors it succeeds."""
    from drempower.protocol.flags import MotorError

    m2 = served.sim.bus.motors[2]
    m2.inject_error(MotorError.DRV_FAULT)  # the axis drops to idle and refuses closed loop
    assert m2.state == AxisState.IDLE
    with session(connect=[served.endpoint]) as ros:
        resp, _ = _call(ros, served.bridge.service_keys["enable"], 1)
        assert resp.success is False
        assert resp.message == (
            "enable failed: motor_2 did not enter closed loop (state idle): its error flags are set: "
            "clear errors first, then enable again"
        )
        assert served.sim.bus.motors[1].state == AxisState.CLOSED_LOOP_CONTROL  # the other one was enabled
        assert _call(ros, served.bridge.service_keys["clear_errors"], 2)[0].success
        resp, _ = _call(ros, served.bridge.service_keys["enable"], 3)
        assert resp.success is True and resp.message == "closed loop on motors 1, 2"
        assert m2.state == AxisState.CLOSED_LOOP_CONTROL


def test_a_faulted_enable_is_worded_as_the_dashboard_and_the_cli_word_it(served: Served) -> None:
    """The enable service, the dashboard's enable and the command line's (``drempower actions enable``: the
    command service on one bus) say the same words after their own prefix for a motor that refuses closed
    loop: they all go through the one command service."""
    pytest.importorskip("aiohttp")
    from drempower import actions, open_bus
    from drempower.dash import Hub
    from drempower.errors import DrEmpowerError
    from drempower.protocol.flags import MotorError

    served.sim.bus.motors[2].inject_error(MotorError.DRV_FAULT)
    with session(connect=[served.endpoint]) as ros:
        resp, _ = _call(ros, served.bridge.service_keys["enable"], 1)
    assert resp.success is False and resp.message.startswith("enable failed: ")
    bridge_words = resp.message.removeprefix("enable failed: ")

    def faulted() -> Any:
        bus = open_bus("sim", motors=[1, 2], clock="virtual", stop_on_close=False)
        bus.transport.bus.motors[2].inject_error(MotorError.DRV_FAULT)  # type: ignore[attr-defined]
        return bus

    with faulted() as bus, pytest.raises(DrEmpowerError) as cli:
        actions.Service(actions.OneBus(bus)).run("command line", "enable", {"id": 2})  # as run_row runs it
    bus = faulted()
    hub = Hub(bus, poll_hz=50)
    try:
        with pytest.raises(DrEmpowerError) as dash:
            hub.do_action("page", "enable", {"id": 2})
    finally:
        hub.close()
        bus.close()
    assert bridge_words == str(cli.value) == str(dash.value)
    assert bridge_words.startswith("motor_2 did not enter closed loop (state idle): its error flags are set")


def test_the_clear_errors_service_succeeds_only_once_no_error_remains(served: Served) -> None:
    """An encoder error stays after a clear (it needs zeroing): the service says so rather than success;
    once zeroed, clearing succeeds."""
    from drempower.protocol.flags import EncoderError

    m1 = served.sim.bus.motors[1]
    m1.inject_error(EncoderError.EDR_BATTERY_LOW)
    with session(connect=[served.endpoint]) as ros:
        resp, _ = _call(ros, served.bridge.service_keys["clear_errors"], 1)
        assert resp.success is False
        assert resp.message == (
            "clear_errors failed: motor_1 errors remain after clearing: see its errors "
            "(an encoder error needs zeroing first)"
        )
        next(iter(served.bridge.faces.values())).bus.motor(1).set_zero_position()  # as drempower zero does
        resp, _ = _call(ros, served.bridge.service_keys["clear_errors"], 2)
        assert resp.success is True and resp.message == "errors cleared on motors 1, 2"


def _joint_state_names(bridge: Bridge, endpoint: str) -> list[str]:
    got: list[Any] = []
    with session(connect=[endpoint]) as ros:
        sub = ros.declare_subscriber(
            bridge.joint_states_key, lambda s: got.append(rosmsg.decode(s.payload.to_bytes(), rosmsg.JOINT_STATE))
        )
        wait_for(lambda: len(got) >= 2)
        sub.undeclare()
    return list(got[-1].name)


@pytest.fixture
def plain_bridge() -> Iterator[tuple[Bridge, str]]:
    sim = SimTransport([3, 7])
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sess = session(listen=[endpoint])
    bridge = Bridge(sim, sess, BridgeOptions(motor_joints([3, 7]), prefix=f"plain{free_port()}"))
    try:
        yield bridge, endpoint
    finally:
        bridge.close()
        sess.close()
        sim.close()


def test_joint_states_of_a_plain_bus_name_motors_by_the_naming_rule(plain_bridge: tuple[Bridge, str]) -> None:
    bridge, endpoint = plain_bridge
    assert _joint_state_names(bridge, endpoint) == ["motor_3", "motor_7"]


LIMITED_ROBOT = """
[buses.arm]
interface = "sim"
[joints.base_yaw]
bus = "arm"
id = 1
limits = { position = [-1.0, 1.0] }
[joints.gripper]
bus = "arm"
id = 2
"""


def test_a_robot_files_joint_names_and_soft_limits(tmp_path: Path) -> None:
    path = tmp_path / "robot.toml"
    path.write_text(LIMITED_ROBOT)
    spec = load_robot(path)
    sim = SimTransport([1, 2])
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sess = session(listen=[endpoint])
    bridge = Bridge({"arm": sim}, sess, BridgeOptions(dict(spec.joints), prefix=f"limited{free_port()}"))
    frames = _Frames(sim)
    try:
        assert _joint_state_names(bridge, endpoint) == ["base_yaw", "gripper"]
        with session(connect=[endpoint]) as ros:
            assert _call(ros, bridge.service_keys["enable"], 1)[0].success
            pub = ros.declare_publisher(bridge.command_keys["position_commands"])
            time.sleep(0.2)
            said = _publish_until_refused(bridge, pub, [1.5, 0.0], 1)  # beyond base_yaw's 1 rad
            assert said == (
                "position_commands refused: bus 'arm', joint base_yaw: motor 1: position 85.9437 deg is beyond "
                "its soft limit -57.2958..57.2958 deg (set by joint 'base_yaw' limits)"
            )
            assert frames.driven() == set()
            pub.undeclare()
    finally:
        frames.close()
        bridge.close()
        sess.close()
        sim.close()


@pytest.mark.parametrize("served", [{"command_timeout": 30.0}], indirect=True)  # no idling by silence here
def test_a_motor_a_remote_client_idled_is_refused_too(served: Served) -> None:
    m1 = served.sim.bus.motors[1]
    with session(connect=[served.endpoint]) as ros:
        assert _call(ros, served.bridge.service_keys["enable"], 1)[0].success
        pub = ros.declare_publisher(served.bridge.command_keys["velocity_commands"])
        time.sleep(0.2)
        wait_for(lambda: (pub.put(_command([1.0, 0.0])), abs(m1.speed) > 1.0)[1])  # the bridge knows it enabled
        with remote(served, stop_on_close=False) as bus:  # another host on the bus idles motor 1
            bus.motor(1).idle()
        wait_for(lambda: m1.state == AxisState.IDLE)
        said = _publish_until_refused(served.bridge, pub, [1.0, 0.0], served.bridge.refused + 1)
        assert said == (
            "velocity_commands refused: motor 1 is idle (not in closed loop): enable it first "
            "(call the enable service, or drempower enable 1)"
        )
        assert m1.state == AxisState.IDLE
        pub.undeclare()


def test_rosout_tells_one_refusal_per_topic_and_second(served: Served) -> None:
    heard: list[Any] = []
    with session(connect=[served.endpoint]) as ros:
        log_key = f"0/rosout/rcl_interfaces::msg::dds_::Log_/{rosmsg.ros_type_hash(rosmsg.LOG)}"
        sub = ros.declare_subscriber(log_key, lambda s: heard.append(rosmsg.decode(s.payload.to_bytes(), rosmsg.LOG)))
        pub = ros.declare_publisher(served.bridge.command_keys["effort_commands"])
        time.sleep(0.2)
        _publish_until_refused(served.bridge, pub, [500.0, 0.0], 1)  # beyond 327.67 Nm
        for _ in range(20):
            pub.put(_command([500.0, 0.0]))
        wait_for(lambda: served.bridge.refused >= 21)
        time.sleep(0.2)
        assert len(heard) == 1 and heard[0].msg.startswith("effort_commands refused: joint 'motor_1' (effort 500 Nm)")
        time.sleep(1.0)
        pub.put(_command([500.0, 0.0]))
        wait_for(lambda: len(heard) == 2)
        assert re.search(r"\(and 2\d more like it in 1\.\d s\)$", heard[1].msg), heard[1].msg
        pub.undeclare()
        sub.undeclare()


def test_the_frames_that_take_a_motor_out_of_closed_loop_or_into_it() -> None:
    from drempower.bridge.hub import axis_changed
    from drempower.protocol.ids import SysCmd
    from drempower.protocol.messages import ReadParam, SystemCommand, Velocity, WriteParam
    from drempower.protocol.parameters import DataType

    enable = Frame(0x03F, bytes.fromhex("3375030008000000"))  # set_mode(1, 2), PROTOCOL.md's golden frame
    idle = Frame(0x05F, bytes.fromhex("3375030001000000"))  # set_mode(2, 1)
    assert idle == WriteParam.of(2, "axis0.requested_state", 1).encode()
    assert axis_changed([enable]) == {1} and axis_changed([idle]) == {2}
    assert axis_changed([SystemCommand(3, SysCmd.ESTOP).encode(), SystemCommand(0, SysCmd.CLEAR_ERRORS).encode()]) == {
        3,
        0,
    }
    assert axis_changed([SystemCommand(1, SysCmd.SAVE_CONFIG).encode(), Velocity(1, 10.0).encode()]) == set()
    assert axis_changed([ReadParam(1, 30002, DataType.U32).encode()]) == set()  # a read of the state changes nothing
    assert axis_changed([WriteParam.of(1, "can.config.heartbeat_ms", 10).encode()]) == set()
