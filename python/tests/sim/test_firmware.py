"""Simulator firmware profiles: each knob changes what a host sees, and only that (sim.firmware)."""

from __future__ import annotations

import itertools
from pathlib import Path

import can
import pytest

import drempower
from drempower.errors import ValidationError
from drempower.protocol import FastRead, PositionP, Preset, PresetQ, Start, SystemCommand, WriteParam
from drempower.protocol.ids import Frame, StartKind, SysCmd
from drempower.protocol.parameters import DataType
from drempower.sim import SimBus
from drempower.sim.firmware import Firmware

from .test_cli_sim import _start

REPLY_STATE = 31214
HEARTBEAT_MS = 21004
_channels = itertools.count()


def _bus(**knobs: object) -> tuple[SimBus, list[Frame]]:
    sim = SimBus([1], **knobs)  # type: ignore[arg-type]
    out: list[Frame] = []
    sim.add_listener(out.append)
    return sim, out


def _cmds(frames: list[Frame]) -> list[int]:
    return [f.arbitration_id & 0x1F for f in frames]


def _reply_state_on(sim: SimBus) -> None:
    sim.send(WriteParam(1, REPLY_STATE, DataType.U32, 1).encode())
    sim.advance(0.01)


@pytest.mark.parametrize(
    ("bits", "fast", "control", "preset"), [("zero", 0x03, 0x01, 0x03), ("kept", 0x1B, 0x19, 0x0B)]
)
def test_status_bits(bits: str, fast: int, control: int, preset: int) -> None:
    sim, out = _bus(status_bits=bits)
    _reply_state_on(sim)
    out.clear()
    sim.send(FastRead(1).encode())
    sim.advance(0.01)
    sim.send(PositionP(1, 10.0).encode())  # T clear while it moves
    sim.advance(0.01)
    sim.send(Preset(1, 10.0, 0.0, 0.0).encode())
    sim.advance(1.0)
    heartbeat_free = _cmds(out)
    assert heartbeat_free[:2] == [fast, control] and heartbeat_free[2] in (preset, preset & ~2)


def test_boot_silence() -> None:
    for boot in (0.1, 0.9):
        sim, out = _bus(boot_s=boot)
        sim.send(SystemCommand(1, SysCmd.REBOOT).encode())
        sim.advance(0.01)
        t0 = sim.now
        while not out:
            sim.send(FastRead(1).encode())
            sim.advance(0.01)
        assert sim.now - t0 == pytest.approx(boot, abs=0.03)


@pytest.mark.parametrize(
    ("triggers", "answered"),
    [
        ("control+preset", {"control", "preset"}),
        ("control", {"control"}),
        ("all", {"control", "preset", "write", "system"}),
    ],
)
def test_reply_state_triggers(triggers: str, answered: set[str]) -> None:
    sim, out = _bus(reply_state=triggers)
    _reply_state_on(sim)
    got = set()
    for name, frame in (
        ("control", PositionP(1, 0.0).encode()),
        ("preset", Preset(1, 0.0, 0.0, 0.0).encode()),
        ("write", WriteParam(1, REPLY_STATE, DataType.U32, 1).encode()),
        ("system", SystemCommand(1, SysCmd.CLEAR_ERRORS).encode()),
    ):
        out.clear()
        sim.send(frame)
        sim.advance(0.01)
        if out:
            got.add(name)
    assert got == answered


def test_fast_read_absent() -> None:
    sim, out = _bus(fast_read=False)
    sim.send(FastRead(1).encode())
    sim.advance(0.05)
    assert out == []
    sim.send(Frame(0x3E, bytes.fromhex("0600030000000000")))  # fw_version still answers
    sim.advance(0.05)
    assert len(out) == 1 and out[0].arbitration_id == 0x3E


@pytest.mark.parametrize(("reading", "moved"), [("fastest", True), ("ignore", False)])
def test_q_time_zero(reading: str, moved: bool) -> None:
    sim, _ = _bus(q_time_zero=reading)
    sim.send(PresetQ(1, 20.0, 0.0, 300.0).encode())
    sim.send(Start(1, StartKind.Q).encode())
    sim.advance(2.0)
    assert (abs(sim.motors[1].position - 20.0) < 0.5) is moved
    assert (abs(sim.motors[1].position) < 0.5) is not moved


@pytest.mark.parametrize("on", [True, False])
def test_heartbeat(on: bool) -> None:
    sim, out = _bus(heartbeat=on)
    sim.send(WriteParam(1, HEARTBEAT_MS, DataType.U32, 50).encode())
    sim.advance(0.52)
    assert len(out) == (10 if on else 0)


def test_factory_id() -> None:
    sim, out = _bus(factory_id=9)
    assert sim.motors[1].node_id == 1  # boots with the id it was made with
    sim.send(SystemCommand(1, SysCmd.ERASE_CONFIG).encode())
    sim.send(SystemCommand(1, SysCmd.REBOOT).encode())
    sim.advance(1.0)
    assert sim.motors[1].node_id == 9
    sim.send(FastRead(9).encode())
    sim.advance(0.01)
    assert [f.arbitration_id >> 5 for f in out] == [9]
    default, _ = _bus()
    default.send(SystemCommand(1, SysCmd.ERASE_CONFIG).encode())
    default.send(SystemCommand(1, SysCmd.REBOOT).encode())
    default.advance(1.0)
    assert default.motors[1].node_id == 1


@pytest.mark.parametrize(
    ("knobs", "words"),
    [
        ({"status_bits": "some"}, "status_bits='some'"),
        ({"boot_s": -1}, "boot_s=-1"),
        ({"reply_state": "none"}, "reply_state='none'"),
        ({"fast_read": "yes"}, "fast_read='yes'"),
        ({"q_time_zero": "slow"}, "q_time_zero='slow'"),
        ({"factory_id": 0}, "factory_id=0"),
    ],
)
def test_bad_knobs_name_the_knob(knobs: dict[str, object], words: str) -> None:
    with pytest.raises(ValidationError, match=words.replace("(", r"\(")):
        SimBus([1], **knobs)  # type: ignore[arg-type]
    with pytest.raises(drempower.TransportError, match=words):
        drempower.open_bus("sim", **knobs)


def test_open_bus_sim_takes_the_knobs() -> None:
    with drempower.open_bus("sim", motors=[2], clock="virtual", status_bits="kept", boot_s=0.5) as bus:
        sim = bus._core.transport.bus  # type: ignore[attr-defined]
        assert sim.firmware == Firmware(status_bits="kept", boot_s=0.5)
        frames: list[Frame] = []
        bus.add_tap(lambda f, tx: None if tx else frames.append(f))
        bus.motor(2).get_state()
        assert [f.arbitration_id for f in frames] == [(2 << 5) | 0x1B]


def test_robot_file_sim_bus_takes_the_knobs(tmp_path: Path) -> None:
    path = tmp_path / "robot.toml"
    path.write_text('[buses.main]\ninterface = "sim"\nstatus_bits = "kept"\n[joints.a]\nbus = "main"\nid = 3\n')
    with drempower.open_robot(path) as robot:
        bus = robot.buses["main"]
        assert bus._core.transport.bus.firmware.status_bits == "kept"  # type: ignore[attr-defined]
        frames: list[Frame] = []
        bus.add_tap(lambda f, tx: None if tx else frames.append(f))
        bus.motor(3).get_state()
        assert [f.arbitration_id & 0x1F for f in frames] == [0x1B]


def test_cli_sim_status_bits_kept() -> None:
    channel = f"cli-sim-firmware-{next(_channels)}"
    thread, stop, out = _start(["--ids", "4", "--python-can", channel, "--status-bits", "kept", "--boot-s", "0.5"])
    try:
        assert "Ctrl-C stops" in out.getvalue(), out.getvalue()
        assert "firmware profile: status_bits=kept, boot_s=0.5" in out.getvalue()
        client = can.Bus(interface="virtual", channel=channel)
        try:
            client.send(can.Message(arbitration_id=0x09E, data=bytes(8), is_extended_id=False))
            msg = client.recv(2.0)
            assert msg is not None and msg.arbitration_id == (4 << 5) | 0x1B
        finally:
            client.shutdown()
    finally:
        stop.set()
        thread.join(5.0)


def test_cli_sim_bad_knob_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    from drempower.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["sim", "--ids", "1", "--status-bits", "some", "--duration", "0.1"])
    assert exc.value.code == 2 and "--status-bits" in capsys.readouterr().err


def test_robot_file_profile_is_relative_to_the_file(tmp_path: Path) -> None:
    (tmp_path / "fw.json").write_text('{"profile": 1, "status_bits": "kept"}')
    path = tmp_path / "robot.toml"
    path.write_text(
        '[buses.main]\ninterface = "sim"\nstatus_bits = "kept"\nprofile = "fw.json"\n[joints.a]\nbus = "main"\nid = 2\n'
    )
    with drempower.open_robot(path) as robot:
        bus = robot.buses["main"]
        assert bus._session.inbox.bits.default == "kept"
        assert bus.motor(2).get_state().node == 2
