"""The bridge's drempower face holds remote peers to the robot file's limits: a remote client gets the
limits with the bus (its refusals are errors where it calls), and raw frames a peer puts on the bus's keys
pass the bridge's gate by the documented policy (:mod:`drempower.bridge.remote_policy`), refusals logged."""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import pytest

from drempower import open_bus
from drempower.bridge.server import Bridge, BridgeOptions
from drempower.errors import SoftLimitError
from drempower.protocol.enums import AxisState
from drempower.protocol.ids import SysCmd
from drempower.protocol.messages import SystemCommand, Velocity, WriteParam
from drempower.robot.config import parse_robot
from drempower.transports.sim import SimTransport
from drempower.transports.zenoh_wire import encode_frames, join_origin, keys

from .conftest import free_port, session, wait_for

pytestmark = pytest.mark.timeout(60)

ROBOT = {
    "buses": {"b": {"interface": "sim"}},
    "joints": {
        "j1": {"bus": "b", "id": 1, "limits": {"position": [-1.0, 1.0], "speed": 1.0}},
        "j2": {"bus": "b", "id": 2},
    },
}


@dataclass
class Face:
    bridge: Bridge
    sim: SimTransport
    endpoint: str
    prefix: str

    def remote(self) -> Any:
        return open_bus("zenoh", f"{self.prefix}/b", connect=self.endpoint, gossip=False, stop_on_close=False)


@pytest.fixture
def face() -> Iterator[Face]:
    spec = parse_robot(ROBOT)
    sim = SimTransport([1, 2])
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sess = session(listen=[endpoint])
    prefix = f"face{free_port()}"
    bridge = Bridge({"b": sim}, sess, BridgeOptions(dict(spec.joints), prefix=prefix))
    try:
        yield Face(bridge, sim, endpoint, prefix)
    finally:
        bridge.close()
        sess.close()
        sim.close()


def test_a_remote_client_is_held_to_the_robot_files_limits(face: Face) -> None:
    with face.remote() as bus:
        m = bus.motor(1)
        m.enable()
        with pytest.raises(SoftLimitError, match=r"motor 1: position 170 deg is beyond its soft limit -57\.29"):
            m.set_angle(170, 5, 20, 1)
        with pytest.raises(SoftLimitError, match="joint 'j1' limits"):
            m.set_speed(30)
        m.set_angle(30, 5, 20, 1)  # within the limits
        m.wait_position_done(timeout=20)
    assert face.sim.bus.motors[1].position == pytest.approx(30, abs=0.5)


def test_raw_frames_of_a_peer_pass_the_bridges_gate(face: Face, caplog: pytest.LogCaptureFixture) -> None:
    face_ = face.bridge.faces["b"]
    k = keys(f"{face.prefix}/b")
    motor = face.sim.bus.motors[1]
    with session(connect=[face.endpoint]) as peer, caplog.at_level(logging.WARNING, "drempower.bridge"):
        wait_for(lambda: peer.get(k["info"], timeout=0.5) is not None)
        tx, estop = peer.declare_publisher(k["tx"]), peer.declare_publisher(k["estop"])
        # the routes to the bridge's subscribers are there (a loaded machine takes longer than any fixed wait)
        wait_for(lambda: tx.matching_status.matching and estop.matching_status.matching, limit=30.0)
        enable = WriteParam.of(1, "axis0.requested_state", 8).encode()
        fast = Velocity(1, 250.0).encode()
        tx.put(
            encode_frames([SystemCommand(1, SysCmd.CLEAR_ERRORS).encode(), enable, fast]),
            attachment=join_origin(b"peer", 1),
        )
        wait_for(lambda: face_.refused >= 3)
        time.sleep(0.3)
        assert abs(motor.speed) < 1 and motor.param("axis0.output_shaft.input_vel") == 0  # nothing of it went
        tx.put(encode_frames([fast]), attachment=join_origin(b"peer", 2))  # alone: refused too
        wait_for(lambda: face_.refused >= 4)
        estop.put(encode_frames([fast]), attachment=join_origin(b"peer", 3))  # no estop: refused
        wait_for(lambda: face_.refused >= 5)
        tx.put(encode_frames([enable, Velocity(1, 5.0).encode()]), attachment=join_origin(b"peer", 4))
        wait_for(lambda: motor.state == AxisState.CLOSED_LOOP_CONTROL and motor.speed > 2)
    refusals = [r.getMessage() for r in caplog.records if "refused" in r.getMessage()]
    assert any("motor 1: speed 250 r/min is beyond its soft limit" in r for r in refusals), refusals
    assert any("only emergency stops are taken there" in r for r in refusals), refusals
