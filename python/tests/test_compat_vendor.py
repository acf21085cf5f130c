"""drempower.compat as a drop-in for the vendor's DrEmpower_can.py: a script written against the vendor's
names, argument orders and return values runs unchanged (but for its import) against the simulator."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from drempower import compat as dr
from drempower.protocol import Frame
from drempower.protocol.enums import AxisState
from drempower.sim import SimBus


@pytest.fixture
def sim() -> Iterator[tuple[SimBus, list[Frame]]]:
    """Motors 1 and 2 through compat; the frames the host sends, in order."""
    bus = dr.open("sim", motors=[1, 2], clock="virtual", timeout=1.0)
    simbus: SimBus = bus.transport.bus  # type: ignore[attr-defined]
    sent: list[Frame] = []
    simbus.add_listener(lambda f: None, host_frames=True)
    real_send = simbus.send

    def recording(frame: Frame, origin: object = None) -> None:
        sent.append(frame)
        real_send(frame, origin)  # type: ignore[arg-type]

    simbus.send = recording  # type: ignore[method-assign]
    saved = (dr.enable_replay_state, dr.TRAJ_MODE, dr.READ_FLAG, dr.reply_state_error)
    yield simbus, sent
    dr.close()
    dr.enable_replay_state, dr.TRAJ_MODE, dr.READ_FLAG, dr.reply_state_error = saved


def test_a_vendor_style_script(sim: tuple[SimBus, list[Frame]]) -> None:
    simbus, _ = sim
    # --- the script, as written for the vendor's library
    dr.set_mode(1, 2)
    dr.set_mode(2, 2)
    if dr.dump_error(1) != 0 or dr.dump_error(2) != 0:
        raise AssertionError("a healthy motor's dump_error is 0")
    dr.set_traj_mode(1, 1)
    dr.preset_angle(1, 90, 2.0, 20, 1)  # Q preset: 2 s, 20 (r/min)/s
    dr.preset_angle(2, -45, 2.0, 20, 1)
    dr.send_command(0, 0x08, dr.format_data([0x11, 0], "u32 u32", "encode"))  # start both (Q)
    assert dr.positions_done([1, 2]) is True
    angle, _speed = dr.get_state(1)
    assert dr.READ_FLAG == 1
    pos2 = dr.motor_state[0][0]
    dr.send_command(2, 0x1E, [0] * 8)  # fast read by hand
    data = dr.receive_data()
    assert data is not None
    position, _speed100, _torque100 = dr.format_data(data, "f s16 s16", "decode")
    # --- what it saw
    assert angle == pytest.approx(90, abs=0.05) and pos2 == pytest.approx(90, abs=0.05)
    assert dr.motor_state[0, 3] == 1.0  # trajectory done, numpy-style index
    assert position == pytest.approx(-45, abs=0.05)
    assert dr.TRAJ_MODE == 1
    for m in simbus.motors.values():
        assert m.state is AxisState.CLOSED_LOOP_CONTROL


def test_presets_are_the_vendors_frames(sim: tuple[SimBus, list[Frame]]) -> None:
    _, sent = sim
    dr.set_mode(1, 2)  # the presets pass the safety gate: their motors in closed loop
    dr.set_mode(2, 2)
    sent.clear()
    dr.preset_speed(1, 10, 0, 1)
    dr.preset_torque(1, 3, 10, 0)
    dr.preset_angle(1, 90, 0, 10, 0)
    dr.preset_angle(2, 45, 5, 0.5, 2)
    assert [(f.arbitration_id, f.data.hex(" ").upper()) for f in sent] == [
        (0x02C, "00 00 20 41 00 00 64 00"),  # PROTOCOL.md 1.7, set_speeds' preset
        (0x02C, "00 00 40 40 E8 03 58 02"),  # set_torques' preset
        (0x02C, "00 00 B4 42 00 00 E8 03"),  # T: speed 0, bandwidth 10
        (0x04C, "00 00 34 42 F4 01 32 00"),  # P: speed ff 5, torque ff 0.5
    ]
    sent.clear()
    dr.send_command(1, 0x06, dr.format_data([1], "u32", "encode"))  # no such command: sent as given
    dr.send_command(3, 0x08, [0x06])  # estop, padded to 8 bytes as the vendor's
    assert [(f.arbitration_id, f.data.hex()) for f in sent] == [
        (0x026, "0100000000000000"),
        (0x068, "0600000000000000"),
    ]
    assert dr.format_data([90, 0, 1000], "f s16 s16", "encode") == bytes.fromhex("0000B4420000E803")
    assert dr.format_data([31001, 3, 5], "u16 u16 u32", "encode") == bytes.fromhex("1979030005000000")


def test_dump_error_compares_like_the_vendors_and_carries_the_report(sim: tuple[SimBus, list[Frame]]) -> None:
    healthy = dr.dump_error(1)
    assert healthy == 0 and not healthy and healthy.flags == {}
    dr.estop(2)
    err = dr.dump_error(2)
    assert err != 0 and err == sum(err.words.values()) == err.report.words["axis0.error"]
    assert err.flags == {"axis0.error": ["ESTOP_REQUESTED"]}
    assert isinstance(err, int) and "ESTOP_REQUESTED" in repr(err)


def test_reply_state_follows_enable_replay_state(sim: tuple[SimBus, list[Frame]]) -> None:
    assert dr.MOTOR_NUM == 16 and len(dr.motor_state) == 16
    assert dr.reply_state(1) is None  # the vendor's: nothing unless enable_replay_state
    dr.enable_replay_state = 1
    dr.set_mode(1, 2)
    dr.preset_angle(1, 30, 1, 20, 1)  # reply_state after the preset fills motor_state
    assert dr.motor_state[0][4] == 0.0 and dr.motor_state[0][3] in (0.0, 1.0)
    before = dr.reply_state_error
    assert dr.reply_state(5) is False and dr.reply_state_error == before + 1  # no motor 5
    assert dr.reply_state(17) is None  # beyond MOTOR_NUM


def test_values_the_wire_cannot_hold_send_nothing(sim: tuple[SimBus, list[Frame]]) -> None:
    _, sent = sim
    with pytest.raises(dr.FieldRangeError, match="p2"):
        dr.preset_angle(1, 0, 400, 10, 1)
    with pytest.raises(dr.FieldRangeError, match="cmd"):
        dr.send_command(1, 0x20, [])
    with pytest.raises(dr.ValidationError, match="at most 8"):
        dr.send_command(1, 0x1E, [0] * 9)
    assert sent == []
    assert dr.receive_data(timeout=0.05) is None and dr.READ_FLAG == -1


def test_motors_keep_holding_when_the_script_ends() -> None:
    bus = dr.open("sim", motors=[1], clock="virtual", timeout=1.0)
    simbus: SimBus = bus.transport.bus  # type: ignore[attr-defined]
    dr.set_mode(1, 2)
    dr.set_angle(1, 30, 60, 300, 1)
    dr.position_done(1)
    dr.close()  # what the interpreter does at exit
    assert simbus.motors[1].state is AxisState.CLOSED_LOOP_CONTROL
    # the Bus default stays: motors it commanded go idle
    bus = dr.open("sim", motors=[1], clock="virtual", timeout=1.0, stop_on_close=True)
    simbus = bus.transport.bus  # type: ignore[attr-defined]
    dr.set_mode(1, 2)
    dr.set_angle(1, 30, 60, 300, 1)
    dr.close()
    assert simbus.motors[1].state is AxisState.IDLE
