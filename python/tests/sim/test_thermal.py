"""Heat: the winding and board against their documented time constants, derating, the over-temperature trip."""

from __future__ import annotations

import math

import pytest

from drempower.protocol import AxisError, AxisState, FastRead, Torque
from drempower.protocol.flags import FetThermistorError, MotorThermistorError
from drempower.sim import SimBus
from drempower.sim.defaults import MotorModel
from drempower.sim.thermal import ThermalModel, derated_limit

from .helpers import exchange, read, write

TM = ThermalModel()
R_PHASE = 0.2
"""The factory phase resistance (ohm, axis0.motor.config.phase_resistance)."""
MOTOR_T = "axis0.motor_thermistor.temperature"
BOARD_T = "axis0.fet_thermistor.temperature"
EFFECTIVE = "axis0.motor.effective_current_lim"


def _pushing(amps: float) -> SimBus:
    """A motor with its shaft blocked pushing ``amps`` A (= Nm at the output: 0.1 Nm/A x 10:1)."""
    bus = SimBus([1])
    bus.motors[1].locked = True
    exchange(bus, Torque(1, amps))
    return bus


def test_the_winding_and_board_rise_by_1_minus_1_over_e_in_one_time_constant() -> None:
    amps = 3.0
    rise_w = 1.5 * amps**2 * R_PHASE * TM.winding_r_th
    rise_b = (TM.board_idle_w + 1.5 * amps**2 * TM.fet_resistance) * TM.board_r_th
    bus = _pushing(amps)
    assert read(bus, 1, MOTOR_T) == pytest.approx(TM.ambient_c)
    bus.advance(TM.board_tau)
    assert read(bus, 1, BOARD_T) - TM.ambient_c == pytest.approx(rise_b * (1 - math.exp(-1)), rel=2e-3)
    bus.advance(TM.winding_tau - TM.board_tau)
    assert read(bus, 1, MOTOR_T) - TM.ambient_c == pytest.approx(rise_w * (1 - math.exp(-1)), rel=2e-3)
    bus.advance(4 * TM.winding_tau)
    assert read(bus, 1, MOTOR_T) - TM.ambient_c == pytest.approx(rise_w * (1 - math.exp(-5)), rel=2e-3)
    assert read(bus, 1, BOARD_T) - TM.ambient_c == pytest.approx(rise_b, rel=2e-3)


def test_an_idle_motor_cools_to_ambient_with_the_same_time_constant() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    write(bus, 1, "axis0.requested_state", AxisState.IDLE)
    m.thermal.winding = 85.0
    bus.advance(TM.winding_tau)
    assert read(bus, 1, MOTOR_T) - TM.ambient_c == pytest.approx(60.0 * math.exp(-1), rel=2e-3)
    board_rise = TM.board_idle_w * TM.board_r_th  # the board's own consumption keeps it a little warm
    assert read(bus, 1, BOARD_T) - TM.ambient_c == pytest.approx(board_rise, rel=0.01)


def test_the_effective_limit_derates_linearly_between_lower_and_upper() -> None:
    bus = _pushing(9.0)  # below the stall protection's 10 A
    m = bus.motors[1]
    seen: list[tuple[float, float, float]] = []
    while m.state == AxisState.CLOSED_LOOP_CONTROL and bus.now < 600.0:
        bus.advance(1.0)
        t, lim = read(bus, 1, MOTOR_T), read(bus, 1, EFFECTIVE)
        seen.append((t, lim, abs(m.torque)))
    assert m.state == AxisState.CLOSED_LOOP_CONTROL  # the derating keeps the winding below the trip
    assert min(lim for _, lim, _ in seen) < 9.0
    for t, lim, torque in seen:
        assert lim == pytest.approx(min(15.0, 15.0 * (100.0 - t) / 5.0), abs=0.02)
        assert torque == pytest.approx(min(9.0, lim), abs=0.05)  # 1 Nm per A at the output
    final_t = seen[-1][0]
    assert 95.0 < final_t < 100.0
    # the winding settles where the derated current's loss balances its cooling
    lim = seen[-1][1]
    assert final_t - TM.ambient_c == pytest.approx(1.5 * lim**2 * R_PHASE * TM.winding_r_th, rel=0.02)


@pytest.mark.parametrize(
    ("node", "word", "flag"),
    [
        ("winding", "axis0.motor_thermistor.error", MotorThermistorError.OVER_TEMP),
        ("board", "axis0.fet_thermistor.error", FetThermistorError.OVER_TEMP),
    ],
)
def test_above_the_upper_limit_the_thermistor_trips_and_the_axis_idles(node: str, word: str, flag: int) -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    setattr(m.thermal, node, 99.9)  # a heat gun; ambient 25 degC pulls it down from here
    bus.advance(0.01)
    assert m.state == AxisState.CLOSED_LOOP_CONTROL
    assert read(bus, 1, word) == 0
    t = read(bus, 1, "axis0.motor_thermistor.temperature" if node == "winding" else BOARD_T)
    assert 99.8 < t < 99.9
    assert read(bus, 1, EFFECTIVE) == pytest.approx(15.0 * (100.0 - t) / 5.0, abs=1e-3)
    setattr(m.thermal, node, 100.05)
    bus.advance(0.01)  # the limiter's period (HEAT_STEPS)
    assert m.state == AxisState.IDLE
    assert read(bus, 1, word) == flag
    assert read(bus, 1, "axis0.error") & AxisError.OVER_TEMP
    (st,) = exchange(bus, FastRead(1))
    assert st.error  # type: ignore[union-attr]


def test_a_lower_upper_limit_trips_earlier_and_a_disabled_thermistor_never() -> None:
    bus = SimBus([1, 2])
    write(bus, 1, "axis0.motor_thermistor.config.temp_limit_lower", 50.0)
    write(bus, 1, "axis0.motor_thermistor.config.temp_limit_upper", 60.0)
    write(bus, 2, "axis0.motor_thermistor.config.enabled", 0)
    for m in bus.motors.values():
        m.thermal.winding = 55.0
    bus.advance(0.01)
    assert read(bus, 1, EFFECTIVE) == pytest.approx(derated_limit(15.0, 55.0, 50.0, 60.0), abs=0.01)
    assert read(bus, 2, EFFECTIVE) == 15.0
    for m in bus.motors.values():
        m.thermal.winding = 150.0
    bus.advance(0.01)
    assert bus.motors[1].state == AxisState.IDLE
    assert bus.motors[2].state == AxisState.CLOSED_LOOP_CONTROL
    assert read(bus, 2, "axis0.motor_thermistor.error") == 0


def test_holding_the_example_load_for_ten_minutes_heats_the_motor_into_derating() -> None:
    """The issue's case: 4.9 Nm held for ten simulated minutes (the shaft pushed by gravity's torque)."""
    bus = SimBus([1])
    m = bus.motors[1]
    m.external_torque = -4.9
    bus.advance(1.0)
    amps = abs(m.current)  # the load and the gearbox's friction
    assert 4.9 <= amps < 5.1
    bus.advance(479.0)
    expected = TM.ambient_c + 1.5 * amps**2 * R_PHASE * TM.winding_r_th * (1 - math.exp(-480.0 / TM.winding_tau))
    assert read(bus, 1, MOTOR_T) == pytest.approx(expected, rel=2e-3)
    assert read(bus, 1, EFFECTIVE) == 15.0
    angle = m.position
    bus.advance(120.0)
    assert 95.0 < read(bus, 1, MOTOR_T) < 100.0
    assert read(bus, 1, EFFECTIVE) < amps  # derated below what holding takes:
    assert m.position < angle - 10.0  # the load sags
    assert read(bus, 1, EFFECTIVE) < 15.0
    assert m.state == AxisState.CLOSED_LOOP_CONTROL


def test_a_motor_model_sets_the_ambient_it_starts_at_and_cools_to() -> None:
    bus = SimBus([1], model=MotorModel(thermal=ThermalModel(ambient_c=40.0)))
    assert read(bus, 1, MOTOR_T) == pytest.approx(40.0)
    bus.motors[1].thermal.winding = 60.0
    write(bus, 1, "axis0.requested_state", AxisState.IDLE)
    bus.advance(3 * TM.winding_tau)
    assert read(bus, 1, MOTOR_T) == pytest.approx(40.0 + 20.0 * math.exp(-3), rel=1e-3)
