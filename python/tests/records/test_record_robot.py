"""``record --robot FILE``: every bus of a robot in one MCAP file, read back with rosbags and mcap."""

from __future__ import annotations

import time
from collections import Counter, defaultdict
from pathlib import Path

import pytest

from drempower.robot import open_robot

from ..cli.conftest import Cli
from ..robots import GEARED_ROBOT

highlevel = pytest.importorskip("rosbags.highlevel")
mcap_reader = pytest.importorskip("mcap.reader")

ROBOT = GEARED_ROBOT


@pytest.fixture
def robot_file(tmp_path: Path) -> str:
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT)
    return str(path)


def _joint_states(path: Path) -> dict[str, list[tuple[float, float, float]]]:
    """Joint name -> (position, velocity, effort) of every JointState in the file, read by rosbags."""
    out: dict[str, list[tuple[float, float, float]]] = defaultdict(list)
    with highlevel.AnyReader([path]) as reader:
        for c, _, raw in reader.messages():
            if c.topic == "/joint_states":
                m = reader.deserialize(raw, c.msgtype)
                out[m.name[0]].append((m.position[0], m.velocity[0], m.effort[0]))
    return out


def _topics(path: Path) -> Counter[str]:
    """Messages per topic, counted by the mcap reader (no decoding)."""
    with open(path, "rb") as fh:
        return Counter(ch.topic for _, ch, _ in mcap_reader.make_reader(fh).iter_messages())


def test_recorder_writes_each_bus_on_its_topics_and_states_at_the_joint(tmp_path: Path, robot_file: str) -> None:
    from drempower.records import Recorder

    out = tmp_path / "robot.mcap"
    with open_robot(robot_file, sim={"time_scale": 20}) as robot:
        robot.move_joints({"shoulder": 0.4, "wrist": -0.3, "elbow": 1.2}, speed=2.0, accel=10.0)
        robot.positions_done(timeout=10)
        expected: dict[str, tuple[float, float, float]] = {}
        with Recorder(out) as rec:
            for bus_name, bus in robot.buses.items():
                rec.attach(bus, name=bus_name, joints=robot.spec.joints_on(bus_name))
            time.sleep(0.05)
            for name in ("shoulder", "wrist", "elbow"):
                js = robot[name].get_joint_state()
                expected[name] = (js.position, js.velocity, js.torque)
        assert rec.stats.frames_lost == 0
    states = _joint_states(out)
    assert set(states) == {"shoulder", "wrist", "elbow"}
    for name, (pos, vel, eff) in expected.items():
        last = states[name][-1]  # the reply get_joint_state() read
        assert last == pytest.approx((pos, vel, eff), abs=1e-9), name
    assert states["elbow"][-1][0] == pytest.approx(1.2, abs=0.02)  # at the joint: gear -1, offset 0.5
    assert states["wrist"][-1][0] == pytest.approx(-0.3, abs=0.02)  # gear 2
    topics = _topics(out)
    assert {"/can/left/tx", "/can/left/rx", "/can/right/tx", "/can/right/rx"} <= set(topics)
    assert "/can/tx" not in topics and "/can/rx" not in topics


def test_record_cli_records_every_bus_of_the_robot(tmp_path: Path, robot_file: str, cli: Cli) -> None:
    out = tmp_path / "run.mcap"
    r = cli("record", "-w", str(out), "--robot", robot_file, "--poll", "50", "--duration", "0.4", "--json")
    assert r.code == 0, r.err
    (summary,) = r.records()
    assert summary["buses"] == ["left", "right"] and summary["frames_lost"] == 0
    states = _joint_states(out)
    assert set(states) == {"shoulder", "wrist", "elbow"}
    assert all(len(v) >= 10 for v in states.values())
    # fresh simulated motors read 0 deg: the joint is at its offset
    assert {p for p, _, _ in states["elbow"]} == {0.5}
    assert {p for p, _, _ in states["shoulder"]} == {0.0}
    topics = _topics(out)
    assert topics["/can/left/tx"] == 2 * topics["/can/right/tx"] >= 20  # each poll: 2 reads left, 1 right
    assert topics["/can/right/rx"] == len(states["elbow"])
    assert topics["/can/left/rx"] == len(states["shoulder"]) + len(states["wrist"])
    with highlevel.AnyReader([out]) as reader:  # each bus's frames say which bus in frame_id
        ids = {
            (c.topic, reader.deserialize(raw, c.msgtype).header.frame_id)
            for c, _, raw in reader.messages()
            if c.topic.startswith("/can/")
        }
    assert {fid for topic, fid in ids if topic.startswith("/can/left/")} == {"left"}
    assert {fid for topic, fid in ids if topic.startswith("/can/right/")} == {"right"}
    decoded = cli("decode", "--json", str(out)).records()  # decode reads every bus's frames back
    assert {x.get("channel") for x in decoded} == {"left", "right"}
    assert len(decoded) == sum(n for t, n in topics.items() if t.startswith("/can/"))


def test_record_cli_watches_the_buses_of_the_joints_named(tmp_path: Path, robot_file: str, cli: Cli) -> None:
    out = tmp_path / "elbow.mcap"
    r = cli("record", "elbow", "-w", str(out), "--robot", robot_file, "--heartbeat-ms", "10", "--duration", "0.3")
    assert r.code == 0, r.err
    assert "0 frames lost" in r.err
    states = _joint_states(out)
    assert set(states) == {"elbow"} and len(states["elbow"]) > 50  # ~600 heartbeats at 20x
    assert all(p == 0.5 for p, _, _ in states["elbow"])
    topics = _topics(out)
    assert not any(t.startswith("/can/left/") for t in topics)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--names", "1=a"], "--names: not with --robot"),
        (["knee"], "joint 'knee': not in"),
        (["--sim", "1"], "--robot and --sim conflict"),
    ],
)
def test_record_robot_usage_errors(argv: list[str], message: str, tmp_path: Path, robot_file: str, cli: Cli) -> None:
    out = tmp_path / "x.mcap"
    r = cli("record", "-w", str(out), "--robot", robot_file, *argv)
    assert r.code == 2 and message in r.err and "Traceback" not in r.err
    assert not out.exists()
