"""A joint driven into a rigid obstacle of the model stops there, and the motor stalls as the simulator models it."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import drempower
from drempower.client.engine.effects import sleep
from drempower.sim import behaviour as bh

from .conftest import PENDULUM_GAINS, model_copy, robot_file

_CENTRE_DEG, _REACH, _RADIUS, _ROD = 50.0, 0.35, 0.05, 0.012
"""The obstacle: a sphere of radius _RADIUS m whose centre is _REACH m from the axis at 50 deg; the rod's radius."""


def _obstacle(root: ET.Element) -> None:
    world = root.find("worldbody")
    assert world is not None
    a = math.radians(_CENTRE_DEG)
    ET.SubElement(
        world,
        "geom",
        name="obstacle",
        type="sphere",
        size=str(_RADIUS),
        pos=f"{-_REACH * math.sin(a)} 0 {-_REACH * math.cos(a)}",
        contype="0",
        conaffinity="1",
        solref="0.002 1",  # a rigid obstacle: the stiffest contact MuJoCo allows at the 1 ms step
        solimp="0.99 0.999 0.001",
    )


def test_driven_into_an_obstacle_it_stops_and_the_motor_stalls(tmp_path: Path) -> None:
    contact_deg = _CENTRE_DEG - math.degrees(math.asin((_RADIUS + _ROD) / _REACH))
    model = model_copy(tmp_path, "pendulum.xml", _obstacle)
    path = robot_file(tmp_path, model, {"swing": {"id": 1, "sim_params": PENDULUM_GAINS}})
    with drempower.open_bus("sim", robot=path, clock="virtual") as bus:
        motor = bus.motor(1)
        sim = bus.transport.bus.motors[1]
        motor.set_speed(10.0)  # 1 rad/s towards the obstacle
        highest = -math.inf
        strongest = 0.0
        stalled_at = None
        for _ in range(1000):  # 5 s
            bus.run(sleep(0.005))
            st = motor.get_state()
            highest = max(highest, st.angle)
            strongest = max(strongest, st.torque)
            if st.error and stalled_at is None:
                stalled_at = (st.timestamp, st.angle, int(sim.param("axis0.motor.error")))
        blocked_torque = sim.torque
    print(f"obstacle at {contact_deg:.2f} deg: highest angle {highest:.2f} deg; stall error at {stalled_at}")
    assert contact_deg - 1.0 < highest < contact_deg + 0.5  # it got there, and nothing passed through
    assert stalled_at is not None, "the motor never stalled against the obstacle"
    t, angle, motor_error = stalled_at
    assert motor_error & bh.STALL_FLAG
    assert abs(angle - contact_deg) < 1.0  # it stalled at the obstacle
    assert t > 2.0  # after the stall time (2 s) at the torque limit
    assert strongest == 12.0  # pressing at the motor's torque limit (1.2 Nm rotor x 10:1), no further
    assert sim.state == 1 and blocked_torque == 0.0  # the stall dropped the axis to idle
