"""Multi-motor moves, start addressing, the control cycle, scan, closing."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

import drempower
from drempower.client import Bus, PositionMode, q_move_time
from drempower.protocol import (
    FastRead,
    PositionT,
    PresetQ,
    ReadParam,
    Start,
    StartImpedance,
    StartKind,
    SysCmd,
    SystemCommand,
    TrajMode,
    WriteParam,
)
from drempower.transports.capabilities import Capabilities

from ..scripted import FakeMotors, ScriptedTransport


@pytest.mark.parametrize(
    ("ids", "angles", "speed", "param", "mode"),
    [
        ([1, 2], [90], 10, 20, 1),  # length mismatch
        ([1, 1], [90, 90], 10, 20, 1),  # id twice
        ([1, 64], [90, 90], 10, 20, 1),  # id out of range
        ([0, 1], [90, 90], 10, 20, 1),  # broadcast in a list
        ([], [], 10, 20, 1),
        ([1, 2], [90, math.nan], 10, 20, 1),
        ([1, 2], [90, 90], 0, 20, 1),  # Q speed 0
        ([1, 2], [90, 90], 10, -1, 1),  # Q accel < 0
        ([1, 2], [90, 90], 400, 20, 1),  # s16 overflow
        ([1, 2], [90, 90], 10, 0, 0),  # T bandwidth 0
        ([1, 2], [90, 90], 10, 301, 0),  # T bandwidth > 300
        ([1, 2], [90, 90], 500, 1, 2),  # P speed FF overflow
        ([1, 2], [90, 90], 10, 20, 3),  # unknown mode
    ],
)
def test_set_angles_validation_sends_nothing(
    bus: Bus, scripted: ScriptedTransport, ids: list[int], angles: list[float], speed: float, param: float, mode: int
) -> None:
    with pytest.raises(drempower.ValidationError):
        bus.set_angles(ids, angles, speed, param, mode)
    with pytest.raises(drempower.ValidationError):
        bus.step_angles(ids, angles, speed, param, mode)
    assert scripted.sent == []


def test_speeds_torques_validation_sends_nothing(bus: Bus, scripted: ScriptedTransport) -> None:
    for call in (
        lambda: bus.set_speeds([1, 2, 3], [10, 20, 30], 400, mode=2),
        lambda: bus.set_speeds([1, 2], [10, 20], 10, mode=5),
        lambda: bus.set_torques([1, 2, 3], [1, 2, 3], 1000, mode=6),
        lambda: bus.set_torques([1, 2], [1, math.inf]),
    ):
        with pytest.raises(drempower.ValidationError):
            call()
    assert scripted.sent == []


def test_q_move_too_long_sends_no_motion(bus: Bus, scripted: ScriptedTransport) -> None:
    with pytest.raises(drempower.FieldRangeError, match=r"327\.67 s"):
        bus.set_angles([1, 2], [7e5, 0], 1, 1, 1)  # within the angle range, too far for the Q preset
    assert all(isinstance(c, (FastRead, ReadParam)) for c in scripted.commands())


def test_q_time_uses_fresh_positions_and_real_traj_mode(
    bus: Bus, scripted: ScriptedTransport, motors: FakeMotors
) -> None:
    motors.positions.update({1: 30.0, 2: -10.0})
    motors.params[2][35104] = TrajMode.S_CURVE
    t = bus.set_angles([1, 2], [90, 100], 10, 20, PositionMode.Q)
    expected = max(q_move_time(60, 10, 20, 1), q_move_time(110, 10, 20, 2))
    assert t == math.ceil(expected * 100) / 100
    presets = [c for c in scripted.commands() if c.cmd == 0x0C]
    assert [round(p.as_kind(StartKind.Q).time, 2) for p in presets] == [t, t]
    # traj modes are remembered: a second move reads only positions
    scripted.sent.clear()
    motors.positions.update({1: 90.0, 2: 100.0})
    bus.set_angles([1, 2], [90, 100], 10, 20, 1)
    reads = [c for c in scripted.commands() if isinstance(c, ReadParam)]
    assert reads == []


def test_q_move_time_formulas() -> None:
    assert q_move_time(90, 10, 20, 1) == pytest.approx(2.0)  # cruise: v/a + d/(6v)
    assert q_move_time(6, 10, 20, 1) == pytest.approx(2 * math.sqrt(6 / 120))  # triangle
    assert q_move_time(300, 10, 20, 2) == pytest.approx(300 / 60 + 1.0)
    assert q_move_time(12, 10, 20, 2) == pytest.approx(4 * math.sqrt(20 * 12 / 12) / 20)
    with pytest.raises(drempower.ValidationError):
        q_move_time(1, 1, 1, 3)


def test_set_traj_mode_is_verified_and_remembered(bus: Bus, motors: FakeMotors) -> None:
    bus.motor(1).set_traj_mode(2)
    assert motors.params[1][35104] == 2
    assert bus._core.session.known.traj_mode[1] == 2
    assert bus.motor(1).get_traj_mode() is TrajMode.S_CURVE


def starts(t: ScriptedTransport) -> list[tuple[int, object]]:
    return [(c.node, c) for c in t.commands() if isinstance(c, (Start, StartImpedance))]


def test_single_motor_starts_go_to_that_motor(bus: Bus, scripted: ScriptedTransport) -> None:
    bus.motor(2).step_angle(30, 10, 20, mode=1)
    bus.motor(3).impedance_control(10, 0, 0, 2, 0.1)
    bus.set_angles([1], [5], 10, 20, 1)
    assert [n for n, _ in starts(scripted)] == [2, 3, 1]


def test_multi_motor_start_is_broadcast_only_when_every_motor_of_the_bus_moves(motors: FakeMotors) -> None:
    """Presets another command left behind are unknown: a broadcast would fire them. So "auto" broadcasts
    only when the bus's motors are known (the simulator declares them) and all in the move."""

    class FailAfter(ScriptedTransport):
        fail_at: int | None = None

        @property
        def capabilities(self) -> Capabilities:
            return replace(super().capabilities, motor_ids=frozenset((1, 2, 3)))  # as the simulator declares

        def send(self, frame: object) -> None:
            if self.fail_at is not None and len(self.sent) == self.fail_at:
                raise drempower.TransportError("cable pulled")
            super().send(frame)  # type: ignore[arg-type]

    t = FailAfter(motors)
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        bus.set_speeds([1, 2, 3], [10, 10, 10])
        assert [n for n, _ in starts(t)] == [0]
        t.sent.clear()
        bus.set_speeds([1, 2], [10, 10])  # motor 3 may hold another command's preset
        assert [n for n, _ in starts(t)] == [1, 2]
        t.fail_at = len(t.sent) + 1  # the preset for motor 3 goes out, then the link fails
        with pytest.raises(drempower.TransportError):
            bus.set_speeds([3, 1], [5, 5])
        t.fail_at = None
        t.sent.clear()
        bus.set_speeds([1, 2, 3], [0, 0, 0])  # every motor (and preset holder) is in the move
        assert [n for n, _ in starts(t)] == [0]
    unknown = ScriptedTransport(motors)
    with Bus(unknown, timeout=0.25, stop_on_close=False) as bus:
        bus.set_speeds([1, 2, 3], [1, 1, 1])  # the bus's motors are unknown: one start each
        assert [n for n, _ in starts(unknown)] == [1, 2, 3]


def test_start_policies(motors: FakeMotors) -> None:
    t = ScriptedTransport(motors)
    with Bus(t, timeout=0.25, stop_on_close=False, start="broadcast") as bus:
        bus.motor(1).step_angle(10, 0, 50)
    with Bus(t, timeout=0.25, stop_on_close=False, start="node") as bus:
        bus.enable([1, 2])  # the transport is closed: no reply reaches this bus, so the gate cannot read
        bus.set_torques([1, 2], [0.1, 0.2])
    assert [n for n, _ in starts(t)] == [0, 1, 2]


def test_cycle_uses_fewest_frames(bus: Bus, scripted: ScriptedTransport, motors: FakeMotors) -> None:
    m1, m2 = bus.motor(1), bus.motor(2)
    bus.enable([1, 2])  # known in closed loop: the safety gate reads nothing
    scripted.sent.clear()
    states = bus.cycle([m1.make_angle(1, 0, 50), m2.make_angle(2, 0, 50)])
    assert set(states) == {1, 2}
    kinds = [type(c).__name__ for c in scripted.commands()]
    assert kinds == ["ReadParam", "ReadParam", "PositionT", "PositionT", "FastRead", "FastRead"]

    # with reply-state on, the command frames are answered directly
    def reply_to_control(f: object) -> list[object]:
        out = motors(f)  # type: ignore[arg-type]
        if f.arbitration_id & 0x1F in (0x19, 0x1A, 0x1B, 0x1C, 0x1D):  # type: ignore[attr-defined]
            out += motors(FastRead(f.arbitration_id >> 5).encode())  # type: ignore[attr-defined]
        return out

    scripted.respond = reply_to_control
    scripted.sent.clear()
    states = bus.cycle([m1.make_angle(1, 0, 50), m2.make_angle(2, 0, 50)], reply_state=True)
    assert set(states) == {1, 2}
    assert all(isinstance(c, PositionT) for c in scripted.commands())


def test_cycle_timeout_names_the_silent_motors(bus: Bus, motors: FakeMotors) -> None:
    motors.silent.update({2, 3})
    bus.enable([1, 2, 3])  # known in closed loop: the safety gate reads nothing
    cmds = [bus.motor(n).make_speed(0) for n in (1, 2, 3)]
    with pytest.raises(drempower.TimeoutError, match="motors 2, 3: no answer to a control cycle") as info:
        bus.cycle(cmds, reply_state=False)
    assert info.value.nodes == (2, 3)


def test_cycle_rejects_reads_and_duplicates(bus: Bus, scripted: ScriptedTransport) -> None:
    with pytest.raises(drempower.ValidationError):
        bus.cycle([FastRead(1)])
    with pytest.raises(drempower.ValidationError):
        bus.cycle([bus.motor(1).make_speed(1), bus.motor(1).make_speed(2)])
    assert scripted.sent == []


def test_scan_finds_motors_in_one_window(motors: FakeMotors) -> None:
    motors.params[2].update({5: 3, 6: 0x10203})
    t = ScriptedTransport(motors, virtual=True)
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        found = bus.scan()
        assert [m.id for m in found] == [1, 2, 3]
        assert len(t.sent) == 63
        info = bus.scan([2, 9], versions=True)
    assert [(m.id, m.hw_version, m.fw_version) for m in info] == [(2, 3, 0x10203)]


def test_positions_done(bus: Bus, motors: FakeMotors) -> None:
    motors.done[2] = False
    with pytest.raises(drempower.TimeoutError, match="motor 2: still moving"):
        bus.positions_done([1, 2], timeout=0.05)
    motors.done[2] = True
    assert set(bus.positions_done([1, 2], timeout=1)) == {1, 2}


def test_wait_position_done_raises_on_motor_error(bus: Bus, motors: FakeMotors) -> None:
    motors.done[1] = False
    motors.error[1] = True
    motors.params[1][30001] = 0x4000
    with pytest.raises(drempower.MotorFaultError, match="ESTOP_REQUESTED") as info:
        bus.motor(1).wait_position_done(5)
    assert info.value.flags == {"axis0.error": ["ESTOP_REQUESTED"]}


@pytest.mark.parametrize(("option", "expected"), [(True, "idle"), ("idle", "idle"), ("estop", "estop"), (False, None)])
def test_stop_on_close(motors: FakeMotors, option: object, expected: str | None) -> None:
    t = ScriptedTransport(motors)
    with Bus(t, timeout=0.25, stop_on_close=option) as bus:  # type: ignore[arg-type]
        bus.motor(2).set_speed(10)
        bus.motor(3).get_state()  # only read: not stopped
        n = len(t.sent)
    tail = t.commands()[n:]
    if expected is None:
        assert tail == []
    elif expected == "idle":
        assert tail == [WriteParam(2, 30003, WriteParam.of(2, 30003, 1).dtype, 1)]
    else:
        assert tail == [SystemCommand(2, SysCmd.ESTOP)]


def test_bus_estop_broadcast(bus: Bus, scripted: ScriptedTransport) -> None:
    bus.estop()
    bus.estop([2, 3])
    assert scripted.commands() == [SystemCommand(n, SysCmd.ESTOP) for n in (0, 2, 3)]


def test_presets_are_presets(bus: Bus, scripted: ScriptedTransport) -> None:
    bus.set_angles([1, 2], [10, 20], 10, 20, 1)
    presets = [c.as_kind(StartKind.Q) for c in scripted.commands() if c.cmd == 0x0C]
    assert all(isinstance(p, PresetQ) for p in presets)


def test_impedance_of_several_motors_has_one_start() -> None:
    from drempower.protocol import Preset, PresetD, StartImpedance, StartKind, decode_command
    from drempower.sim import SimBus

    from ..links import Recorder, link

    sim = SimBus(ids=[1, 2])
    rec = Recorder(sim)
    with link("inprocess", sim, timeout=1.0) as bus:
        bus.enable([1, 2, 3])  # known in closed loop: the safety gate reads nothing
        rec.frames.clear()
        with pytest.raises(drempower.ValidationError, match=r"pos_list \(motor 2\)"):
            bus.impedance_controls([1, 2], [10, 1e40], kp=5, kd=0.5)
        assert rec.frames == []
        bus.impedance_controls([1, 2], [10, -10], kp=5, kd=0.5)
        sent = [decode_command(f.arbitration_id, f.data) for f in rec.frames]
        assert [type(m) for m in sent] == [Preset, Preset, StartImpedance]
        assert sent[2] == StartImpedance(0, 5.0, 0.5)
        assert [m.as_kind(StartKind.D) for m in sent[:2]] == [PresetD(1, 10.0), PresetD(2, -10.0)]  # type: ignore[attr-defined]
        bus.estop()
