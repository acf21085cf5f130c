"""Every control mode reaches or tracks its target as the model predicts (simulated clock)."""

from __future__ import annotations

import math

import pytest

from drempower.protocol import (
    PositionP,
    PositionQ,
    PositionT,
    Preset,
    PresetC,
    PresetD,
    PresetP,
    PresetQ,
    PresetT,
    PresetV,
    Start,
    StartImpedance,
    StartKind,
    Torque,
    TorqueMode,
    Velocity,
    VelocityMode,
)
from drempower.sim import MotorModel, SimBus, SimMotor

from .helpers import read, run_until, write


def _bus(*ids: int, **kw: object) -> SimBus:
    return SimBus(ids or (1,), **kw)  # type: ignore[arg-type]


def _q_time(d: float, v: float, a: float, s_curve: bool = False) -> float:
    """The host library's move time (PROTOCOL.md 3.4.3): d deg, v r/min, a (r/min)/s."""
    if s_curve:
        return 4 * math.sqrt(a * d / 12) / a if d <= 12 * v * v / a else d / (6 * v) + 2 * v / a
    return 2 * math.sqrt(d / (6 * a)) if d <= 6 * v * v / a else v / a + d / (6 * v)


def _move(bus: SimBus, m: SimMotor, limit: float) -> tuple[float, float]:
    """Run until the T bit; return the time it took and the highest speed seen."""
    peak = 0.0

    def done() -> bool:
        nonlocal peak
        peak = max(peak, abs(m.speed))
        return m.trajectory_done

    return run_until(bus, done, limit), peak


@pytest.mark.parametrize(("d", "v", "a"), [(90.0, 30.0, 100.0), (10.0, 100.0, 100.0), (-720.0, 200.0, 300.0)])
def test_q_trapezoid_finishes_in_the_trapezoid_time(d: float, v: float, a: float) -> None:
    bus = _bus()
    m = bus.motors[1]
    bus.send(PositionQ(1, d, v, a).encode())
    assert not m.trajectory_done
    took, peak = _move(bus, m, 10.0)
    assert took == pytest.approx(_q_time(abs(d), v, a), abs=0.002)
    assert peak <= v * 1.01
    bus.advance(0.2)
    assert m.position == pytest.approx(d, abs=0.05)
    assert read(bus, 1, "axis0.output_shaft.trap_traj_vel_limit") == pytest.approx(v)
    assert read(bus, 1, "axis0.output_shaft.trap_traj_accel_limit") == pytest.approx(a)


@pytest.mark.parametrize(("d", "v", "a"), [(90.0, 30.0, 100.0), (360.0, 30.0, 100.0)])
def test_q_s_curve_finishes_in_the_s_curve_time_and_starts_gently(d: float, v: float, a: float) -> None:
    bus = _bus()
    m = bus.motors[1]
    write(bus, 1, "axis0.trap_traj.config.traj_mode", 2)
    bus.send(PositionQ(1, d, v, a).encode())
    bus.advance(0.05)
    assert m.speed < 0.6 * a * 0.05  # a trapezoid would be at a*t already
    took, peak = _move(bus, m, 10.0)
    assert 0.05 + took == pytest.approx(_q_time(d, v, a, s_curve=True), abs=0.002)
    assert peak <= v * 1.01


@pytest.mark.parametrize("s_curve", [False, True])
def test_q_target_time_presets_finish_together(s_curve: bool) -> None:
    bus = _bus(1, 2, 3)
    if s_curve:
        for i in (1, 2, 3):
            write(bus, i, "axis0.trap_traj.config.traj_mode", 2)
    targets = {1: 90.0, 2: -45.0, 3: 180.0}
    for i, t in targets.items():
        bus.send(PresetQ(i, t, time=2.0, accel=300.0).encode())
    bus.send(Start(0, StartKind.Q).encode())
    times = {i: _move(bus, bus.motors[i], 5.0)[0] for i in targets}
    assert times[1] <= 2.0 + 0.002
    bus.advance(2.0 - bus.now)
    for i, t in targets.items():
        assert bus.motors[i].trajectory_done
        assert bus.motors[i].position == pytest.approx(t, abs=0.1)
    assert abs(bus.motors[3].speed) < 0.5


def test_q_target_time_too_short_raises_the_acceleration() -> None:
    bus = _bus()
    m = bus.motors[1]
    bus.send(PresetQ(1, 180.0, time=0.5, accel=10.0).encode())
    bus.send(Start(1, StartKind.Q).encode())
    took, _ = _move(bus, m, 2.0)
    assert took == pytest.approx(0.5, abs=0.002)


def test_q_speed_zero_is_an_error_and_accel_zero_is_as_fast_as_possible() -> None:
    bus = _bus()
    m = bus.motors[1]
    bus.send(PositionQ(1, 30.0, 10.0, 0.0).encode())
    took, _ = _move(bus, m, 1.0)
    assert took < 0.3
    bus.send(PositionQ(1, 60.0, 0.0, 10.0).encode())
    assert m.state.name == "IDLE"
    assert read(bus, 1, "axis0.controller.error") == 0x02
    assert m.axis_error == 0x200


def test_t_tracks_through_the_critically_damped_filter() -> None:
    bus = _bus()
    m = bus.motors[1]
    w = 10.0
    bus.send(PositionT(1, 30.0, bandwidth=w).encode())
    for t in (0.1, 0.2, 0.5, 1.0):
        bus.advance(t - bus.now)
        assert m.position == pytest.approx(30.0 * (1 - (1 + w * t) * math.exp(-w * t)), abs=0.3)
    assert read(bus, 1, "axis0.controller.config.input_filter_bandwidth") == w
    bus.advance(0.5)
    assert m.trajectory_done


def test_t_preset_and_relative_start() -> None:
    bus = _bus()
    m = bus.motors[1]
    bus.send(PresetT(1, 20.0, bandwidth=50.0).encode())
    bus.send(Start(0, StartKind.T).encode())
    bus.advance(0.5)
    bus.send(PresetT(1, 20.0, bandwidth=50.0).encode())
    bus.send(Start(0, StartKind.T, relative=True).encode())
    bus.advance(0.5)
    assert m.position == pytest.approx(40.0, abs=0.05)


def test_p_speed_feed_forward_offsets_the_hold_by_ff_over_pos_gain() -> None:
    bus = _bus()
    bus.send(PositionP(1, 0.0, speed_ff=6.0).encode())
    bus.advance(2.0)
    offset_turns = (6.0 / 60.0) / 40.0  # speed FF (turn/s) over pos_gain (1/s)
    assert bus.motors[1].position == pytest.approx(offset_turns * 360.0, abs=0.01)


def test_p_torque_feed_forward_carries_a_load() -> None:
    bus = _bus(model=MotorModel(coulomb=0.0))
    m = bus.motors[1]
    m.external_torque = -3.0
    bus.send(PositionP(1, 10.0, torque_ff=3.0).encode())
    bus.advance(0.5)
    assert m.position == pytest.approx(10.0, abs=0.01)
    assert m.torque == pytest.approx(3.0, abs=0.01)


def test_p_preset_relative() -> None:
    bus = _bus()
    bus.send(PresetP(1, -30.0).encode())
    bus.send(Start(0, StartKind.P, relative=True).encode())
    bus.advance(1.0)
    bus.send(PresetP(1, -30.0).encode())
    bus.send(Start(0, StartKind.P, relative=True).encode())
    bus.advance(1.0)
    assert bus.motors[1].position == pytest.approx(-60.0, abs=0.05)


def test_v_passthrough_with_torque_feed_forward() -> None:
    bus = _bus()
    m = bus.motors[1]
    bus.send(Velocity(1, -20.0, 0.5, VelocityMode.PASSTHROUGH).encode())
    bus.advance(0.3)
    assert m.speed == pytest.approx(-20.0, abs=0.05)
    assert read(bus, 1, "axis0.output_shaft.input_torque") == pytest.approx(0.5)


def test_v_ramp_rises_at_its_rate_and_zero_rate_holds() -> None:
    bus = _bus()
    m = bus.motors[1]
    bus.send(Velocity(1, 100.0, 50.0, VelocityMode.RAMP).encode())
    for t in (0.5, 1.0, 1.5):
        bus.advance(t - bus.now)
        assert m.speed == pytest.approx(50.0 * t, abs=0.3)
    bus.advance(1.0)
    assert m.speed == pytest.approx(100.0, abs=0.1)
    assert read(bus, 1, "axis0.output_shaft.vel_ramp_rate") == pytest.approx(50.0)
    bus.send(Velocity(1, 0.0, 0.0, VelocityMode.RAMP).encode())
    bus.advance(1.0)
    assert m.speed == pytest.approx(100.0, abs=0.1)


def test_v_and_c_presets_carry_the_mode_code_times_100() -> None:
    bus = _bus(1, 2)
    bus.send(PresetV(1, 60.0, 100.0, VelocityMode.RAMP).encode())
    bus.send(PresetC(2, 0.2).encode())
    bus.send(Start(1, StartKind.V).encode())
    bus.send(Start(2, StartKind.C).encode())
    bus.advance(0.3)
    assert bus.motors[1].speed == pytest.approx(30.0, abs=0.3)
    assert bus.motors[2].torque == pytest.approx(0.2)


def test_c_direct_accelerates_the_inertia() -> None:
    bus = _bus(model=MotorModel(coulomb=0.0, viscous=0.0))
    m = bus.motors[1]
    bus.send(Torque(1, 0.6).encode())
    bus.advance(0.1)
    inertia = 3.0e-4 / (2 * math.pi) * 10**2  # kg*m^2 at the output
    expected = 0.6 / inertia * 0.1 * 30 / math.pi  # r/min after 0.1 s
    assert m.torque == pytest.approx(0.6)
    assert m.speed == pytest.approx(expected, rel=0.01)


def test_c_speed_limit_cuts_the_torque() -> None:
    bus = _bus()
    m = bus.motors[1]
    bus.send(Torque(1, 1.0).encode())
    bus.advance(3.0)
    assert m.speed == pytest.approx(300.0, abs=5.0)
    assert m.torque < 0.5


def test_c_ramp_rises_at_its_rate_and_zero_rate_holds() -> None:
    bus = _bus()
    m = bus.motors[1]
    m.locked = True
    bus.send(Torque(1, 5.0, 2.0, TorqueMode.RAMP).encode())
    for t in (0.5, 1.0, 1.5):
        bus.advance(t - bus.now)
        assert m.torque == pytest.approx(2.0 * t, abs=0.01)
    bus.send(Torque(1, 0.0, 0.0, TorqueMode.RAMP).encode())
    bus.advance(0.3)
    assert m.torque == pytest.approx(3.0, abs=0.01)


def test_impedance_stiffness_is_kp() -> None:
    bus = _bus(model=MotorModel(coulomb=0.0))
    m = bus.motors[1]
    bus.send(PresetD(1, 0.0).encode())
    bus.send(StartImpedance(0, kp=10.0, kd=0.5).encode())
    m.external_torque = 1.0
    bus.advance(2.0)
    assert math.radians(m.position) == pytest.approx(1.0 / 10.0, rel=1e-3)
    assert read(bus, 1, "axis0.controller.config.control_mode") == 4


def test_impedance_damping_is_kd() -> None:
    bus = _bus(model=MotorModel(coulomb=0.0, viscous=0.0))
    m = bus.motors[1]
    bus.send(PresetD(1, 0.0, speed=0.0).encode())
    bus.send(StartImpedance(0, kp=0.0, kd=0.2).encode())
    m.external_torque = 0.5
    bus.advance(1.0)
    assert m.speed * math.pi / 30 == pytest.approx(0.5 / 0.2, rel=1e-3)


def test_start_rules() -> None:
    bus = _bus(1, 2)
    bus.send(Start(0, StartKind.P).encode())  # nothing pending: ignored
    bus.send(PresetP(1, 45.0).encode())
    bus.send(PresetP(2, 45.0).encode())
    bus.send(Start(1, StartKind.P).encode())  # to its own id: starts motor 1 only
    bus.advance(0.5)
    assert bus.motors[1].position == pytest.approx(45.0, abs=0.05)
    assert bus.motors[2].position == pytest.approx(0.0, abs=0.05)
    assert bus.motors[1].preset is None
    assert bus.motors[2].preset == Preset(2, 45.0, 0.0, 0.0)
    bus.motors[1].locked = True
    bus.send(PresetV(1, 10.0).encode())
    bus.send(Start(0, StartKind.C).encode())  # a broadcast C start reads the V preset's code 100 as direct
    bus.advance(0.1)
    assert bus.motors[1].torque == pytest.approx(10.0)


def test_a_load_inertia_slows_the_acceleration() -> None:
    speeds = []
    for load in (0.0, 3.0e-4 / (2 * math.pi) * 100):  # none, then as much as the reflected rotor
        bus = _bus(model=MotorModel(coulomb=0.0, viscous=0.0))
        m = bus.motors[1]
        m.load_inertia = load
        bus.send(Torque(1, 0.6).encode())
        bus.advance(0.1)
        speeds.append(m.speed)
    assert speeds[1] == pytest.approx(speeds[0] / 2, rel=1e-3)


def test_currents_and_supply_follow_the_torque() -> None:
    bus = _bus()
    m = bus.motors[1]
    m.locked = True
    bus.send(Torque(1, 5.0).encode())
    bus.advance(0.01)
    assert m.current == pytest.approx(5.0)  # 1 Nm/A at the output
    assert read(bus, 1, "axis0.motor.current_control.Iq_measured") == pytest.approx(5.0)
    assert read(bus, 1, "ibus") == pytest.approx(1.5 * 25 * 0.2 / 24.0, rel=1e-3)  # copper loss only
