"""The motor's speed protections act on the twin's joint: the torque mode's speed limiter, the over-speed error."""

from __future__ import annotations

from pathlib import Path

import drempower
from drempower.client.engine.effects import sleep
from drempower.protocol.flags import ControllerError

from .conftest import model_copy, robot_file
from .test_impedance import _no_gravity


def test_torque_mode_is_held_to_the_speed_limit(tmp_path: Path) -> None:
    """3 Nm on the free arm would reach 1000 r/min in 1 s; the current-mode limiter holds 300 r/min."""
    model = model_copy(tmp_path, "pendulum.xml", _no_gravity)
    path = robot_file(tmp_path, model, {"swing": {"id": 1, "friction": "model"}})
    with drempower.open_bus("sim", robot=path, clock="virtual") as bus:
        motor = bus.motor(1)
        motor.set_torque(3.0)
        fastest = 0.0
        for _ in range(150):  # 3 s
            bus.run(sleep(0.02))
            fastest = max(fastest, motor.get_state().speed)
        st = motor.get_state()
    assert 295.0 < st.speed <= 301.0 and fastest <= 301.0
    assert not st.error


def test_overspeed_raises_the_error_and_drops_to_idle(tmp_path: Path) -> None:
    model = model_copy(tmp_path, "pendulum.xml", _no_gravity)
    params = {
        "axis0.controller.config.enable_current_mode_vel_limit": 0,
        "axis0.controller.config.enable_overspeed_error": 1,
    }
    path = robot_file(tmp_path, model, {"swing": {"id": 1, "friction": "model", "sim_params": params}})
    with drempower.open_bus("sim", robot=path, clock="virtual") as bus:
        motor = bus.motor(1)
        sim = bus.transport.bus.motors[1]
        motor.set_torque(3.0)  # 18 rad/s^2 on the free arm: 360 r/min (1.2 x the limit) after 2.1 s
        bus.run(sleep(3.0))
        st = motor.get_state()
        error = int(sim.param("axis0.controller.error"))
    assert st.error and error & ControllerError.OVERSPEED
    assert sim.state == 1  # idle: the arm coasts on
    assert sim.speed > 300.0 * 1.2 * 0.99  # beyond what a state frame carries (327.67 r/min)
