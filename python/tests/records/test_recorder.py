"""MCAP recordings read back with independent readers: mcap's reader and rosbags."""

from __future__ import annotations

import math
import time
from collections import Counter
from pathlib import Path

import pytest

from drempower import open_bus
from drempower.protocol.ids import Frame
from drempower.records.recorder import Recorder

mcap_reader = pytest.importorskip("mcap.reader")
highlevel = pytest.importorskip("rosbags.highlevel")

MOTORS = [1, 2, 3, 4, 5, 6]


def _rosbags_messages(path: Path) -> list[tuple[str, int, object]]:
    with highlevel.AnyReader([path]) as reader:
        return [(c.topic, t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages()]


def test_capture_rate_six_motors_at_1mbit_loses_no_frame(tmp_path: Path) -> None:
    """6 simulated motors with 1 ms heartbeats on the 1 Mbit/s timing model: every frame reaches the file."""
    path = tmp_path / "rate.mcap"
    seen: list[Frame] = []
    with open_bus("sim", motors=MOTORS, bitrate=1_000_000) as bus:
        simbus = bus.transport.bus  # type: ignore[attr-defined]
        rec = Recorder(path).attach(bus)
        simbus.add_listener(seen.append, host_frames=True)  # every frame on the simulated wire, both ways
        for i in MOTORS:
            bus.motor(i).write_property("can.config.heartbeat_ms", 1)
        time.sleep(1.5)
        for i in MOTORS:
            bus.motor(i).write_property("can.config.heartbeat_ms", 0)
        time.sleep(0.2)
        simbus.remove_listener(seen.append)
        time.sleep(0.1)
        rec.close()
    assert rec.stats.frames_lost == 0

    with open(path, "rb") as fh:
        reader = mcap_reader.make_reader(fh)
        summary = reader.get_summary()
        counts = {c.topic: summary.statistics.channel_message_counts[i] for i, c in summary.channels.items()}
    assert counts["/can/tx"] + counts["/can/rx"] == len(seen)
    assert counts["/can/tx"] == 2 * len(MOTORS)

    msgs = _rosbags_messages(path)
    states = [(t, m) for topic, t, m in msgs if topic == "/joint_states"]
    # the motors sent only heartbeats (parameter writes have no reply): one joint state each
    assert len(states) == counts["/joint_states"] == counts["/can/rx"]
    per_motor = Counter(m.name[0] for _, m in states)  # type: ignore[attr-defined]
    assert set(per_motor) == {f"motor_{i}" for i in MOTORS}  # the naming rule (was motor{i})
    times = sorted(t for t, _ in states)
    window = (times[-1] - times[0]) / 1e9
    rates = {name: n / window for name, n in per_motor.items()}
    print(
        f"capture: {len(seen)} frames on the wire, {len(seen) - counts['/can/tx'] - counts['/can/rx']} lost; "
        f"samples/s per motor {min(rates.values()):.0f}..{max(rates.values()):.0f}"
    )
    assert min(rates.values()) >= 500


def test_states_parameters_and_errors_decode_with_rosbags(tmp_path: Path) -> None:
    path = tmp_path / "session.mcap"
    with open_bus("sim", motors=[1, 2]) as bus, Recorder(path, names={1: "shoulder"}) as rec:
        rec.attach(bus)
        bus.motor(1).set_angle(90.0, speed=30.0, param=20.0, mode=1)
        st = bus.motor(2).get_state()
        voltage = bus.motor(1).read_property("vbus_voltage")
        time.sleep(0.05)
        rec.record(Frame(0x7E0, b"\x01\x02", False, False), tx=False, timestamp=1700000000.5)
    msgs = _rosbags_messages(path)
    topics = Counter(topic for topic, _, _ in msgs)
    assert topics["/can/tx"] >= 3 and topics["/can/rx"] >= 2

    joint = [m for topic, _, m in msgs if topic == "/joint_states"]
    names = {m.name[0] for m in joint}  # type: ignore[attr-defined]
    assert "motor_2" in names
    m2 = next(m for m in joint if m.name[0] == "motor_2")  # type: ignore[attr-defined]
    assert m2.position[0] == pytest.approx(math.radians(st.angle))  # type: ignore[attr-defined]
    assert m2.velocity[0] == pytest.approx(st.speed * 2 * math.pi / 60)  # type: ignore[attr-defined]

    params = [m for topic, _, m in msgs if topic == "/drempower/parameters"]
    vb = next(p for p in params if p.address == 1)  # type: ignore[attr-defined]
    assert (vb.node, vb.name, vb.unit) == (1, "vbus_voltage", "V")  # type: ignore[attr-defined]
    assert vb.value == pytest.approx(voltage, rel=1e-6)  # type: ignore[attr-defined]

    errors = [(t, m) for topic, t, m in msgs if topic == "/drempower/errors"]
    t, bad = errors[-1]
    assert t == 1700000000_500000000
    assert bad.source == "frame" and "0x7E0" in bad.text  # type: ignore[attr-defined]
    raw = [m for topic, _, m in msgs if topic == "/can/rx" and m.id == 0x7E0]  # type: ignore[attr-defined]
    assert raw[0].dlc == 2 and list(raw[0].data[:2]) == [1, 2]  # type: ignore[attr-defined]


def test_missing_directory_is_a_clear_error(tmp_path: Path) -> None:
    from drempower.errors import DrEmpowerError

    with pytest.raises(DrEmpowerError, match="cannot write"):
        Recorder(tmp_path / "no" / "such.mcap")


async def test_an_async_bus_records_too(tmp_path: Path) -> None:
    from drempower import open_bus_async

    path = tmp_path / "async.mcap"
    async with open_bus_async("sim", motors=[1]) as bus:
        with Recorder(path) as rec:
            rec.attach(bus)
            await bus.motor(1).get_state()
    assert rec.stats.as_dict() == {
        "errors": 0,
        "frames_in": 2,
        "frames_written": 2,
        "parameters": 0,
        "states": 1,
        "frames_lost": 0,
    }
    topics = [topic for topic, _, _ in _rosbags_messages(path)]
    assert topics == ["/can/tx", "/can/rx", "/joint_states"]
