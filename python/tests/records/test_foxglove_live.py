"""The Foxglove live sink, watched with a plain WebSocket client speaking the Foxglove protocol."""

from __future__ import annotations

import json
import struct
import time
from pathlib import Path

import pytest

from drempower import open_bus

pytest.importorskip("foxglove")
ws_client = pytest.importorskip("websockets.sync.client")
mcap_reader = pytest.importorskip("mcap.reader")

from drempower.records.foxglove_live import FoxgloveLive  # noqa: E402


def test_live_states_and_frames_reach_a_websocket_client_and_the_sdk_mcap(tmp_path: Path) -> None:
    log = tmp_path / "live.mcap"
    with open_bus("sim", motors=[1]) as bus, FoxgloveLive(port=0, mcap=log, names={1: "elbow"}) as live:
        live.attach(bus)
        with ws_client.connect(live.url, subprotocols=["foxglove.sdk.v1"], open_timeout=10) as ws:  # type: ignore[list-item]
            channels: dict[str, int] = {}
            deadline = time.monotonic() + 10
            while len(channels) < 5 and time.monotonic() < deadline:
                msg = json.loads(ws.recv(timeout=5))
                if msg.get("op") == "advertise":
                    channels.update({c["topic"]: c["id"] for c in msg["channels"]})
            assert {"/can/tx", "/can/rx", "/joint_states"} <= set(channels)
            subs = {1: "/joint_states", 2: "/can/rx"}
            ws.send(
                json.dumps(
                    {"op": "subscribe", "subscriptions": [{"id": i, "channelId": channels[t]} for i, t in subs.items()]}
                )
            )
            time.sleep(0.2)
            st = bus.motor(1).get_state()
            got: dict[str, list[dict[str, object]]] = {"/joint_states": [], "/can/rx": []}
            deadline = time.monotonic() + 10
            while not all(got.values()) and time.monotonic() < deadline:
                data = ws.recv(timeout=5)
                if isinstance(data, bytes) and data[0] == 0x01:  # message data: op, subscription, time, payload
                    sub, _ = struct.unpack_from("<IQ", data, 1)
                    got[subs[sub]].append(json.loads(data[13:]))
        joint = got["/joint_states"][0]
        assert joint["name"] == ["elbow"] and joint["position"][0] == pytest.approx(st.angle * 3.141592653589793 / 180)
        frame = got["/can/rx"][0]
        assert frame["id"] >> 5 == 1 and frame["id"] & 1 and frame["dlc"] == 8  # the state reply of motor 1
    with open(log, "rb") as fh:
        topics = [c.topic for _, c, _ in mcap_reader.make_reader(fh).iter_messages()]
    assert "/joint_states" in topics and "/can/tx" in topics


def test_bad_port_is_a_clear_error() -> None:
    from drempower.errors import DrEmpowerError

    with pytest.raises(DrEmpowerError, match=r"allowed 0\.\.65535"):
        FoxgloveLive(port=70000)


def test_a_robot_bus_gets_its_own_frame_topics_and_joint_states_at_the_joint(tmp_path: Path) -> None:
    from drempower.robot.config import JointSpec

    log = tmp_path / "robot.mcap"
    elbow = JointSpec("elbow", "right", 1, gear=-1.0, offset=0.5)
    with open_bus("sim", motors=[1], time_scale=20) as bus, FoxgloveLive(port=0, mcap=log) as live:
        m = bus.motor(1)
        m.set_mode(2)
        m.set_angle(30.0, 30.0, 100.0, mode=1)
        m.wait_position_done(timeout=20)
        live.attach(bus, name="right", joints=[elbow])
        st = m.get_state()
        time.sleep(0.1)
    with open(log, "rb") as fh:
        messages = [(c.topic, json.loads(m.data)) for _, c, m in mcap_reader.make_reader(fh).iter_messages()]
    topics = {t for t, _ in messages}
    assert {"/can/right/tx", "/can/right/rx", "/joint_states"} <= topics
    assert not {"/can/tx", "/can/rx"} & topics
    (joint,) = [m for t, m in messages if t == "/joint_states"]
    assert joint["name"] == ["elbow"]
    assert st.angle == pytest.approx(30.0, abs=0.5)
    assert joint["position"][0] == pytest.approx(-st.angle * 3.141592653589793 / 180 + 0.5)  # gear -1, offset 0.5
    assert joint["effort"][0] == pytest.approx(-st.torque)
