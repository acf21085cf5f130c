"""The pendulum on the twin against textbook physics: its period, and the torque that holds it."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest

import drempower
from drempower.client.engine.effects import sleep
from drempower.sim.twin import twin_of

from .conftest import PENDULUM_GAINS, ROBOTS, G, pendulum_arm, pendulum_inertia, robot_file


def _agm(a: float, b: float) -> float:
    while abs(a - b) > 1e-15:
        a, b = (a + b) / 2, math.sqrt(a * b)
    return a


@pytest.mark.parametrize("model", ["pendulum.xml", "pendulum.urdf"])
def test_period_of_the_released_pendulum_is_the_analytic_one(tmp_path: Path, model: str) -> None:
    """Released from 10 deg with the motor idle, the period is 2 pi sqrt(I / m g d) / agm(1, cos(a/2))
    (the same pendulum as MJCF and as URDF)."""
    m, d = pendulum_arm()
    amplitude = math.radians(10.0)
    analytic = 2 * math.pi * math.sqrt(pendulum_inertia() / (m * G * d)) / _agm(1.0, math.cos(amplitude / 2))
    path = robot_file(tmp_path, ROBOTS / model, {"swing": {"id": 1, "friction": "model"}})
    with drempower.open_bus("sim", robot=path, clock="virtual") as bus:
        motor = bus.motor(1)
        motor.set_mode(1)  # idle: the motor applies no torque
        twin = twin_of(bus.transport.bus)
        assert twin is not None
        twin.set_joint("swing", amplitude)
        crossings: list[float] = []
        prev = motor.get_state()
        for _ in range(2500):  # 5 s, a state every 2 ms
            bus.run(sleep(0.002))
            st = motor.get_state()
            if prev.angle < 0.0 <= st.angle:
                frac = -prev.angle / (st.angle - prev.angle)
                crossings.append(prev.timestamp + frac * (st.timestamp - prev.timestamp))
            prev = st
    periods = [b - a for a, b in itertools.pairwise(crossings)]
    assert len(periods) >= 3
    measured = sum(periods) / len(periods)
    print(f"{model} period: measured {measured:.5f} s, analytic {analytic:.5f} s, {measured / analytic - 1:+.3%}")
    assert measured == pytest.approx(analytic, rel=0.01)


@pytest.mark.parametrize("gear", [1.0, -2.0])
@pytest.mark.parametrize("angle_deg", [90.0, 30.0])
def test_holding_torque_is_m_g_d_sin(tmp_path: Path, gear: float, angle_deg: float) -> None:
    """Held in position control, the motor reports the gravity torque m g d sin(angle), through the gear."""
    m, d = pendulum_arm()
    expected = m * G * d * math.sin(math.radians(angle_deg))
    path = robot_file(
        tmp_path,
        ROBOTS / "pendulum.xml",
        {"swing": {"id": 1, "gear": gear, "friction": "model", "sim_params": PENDULUM_GAINS}},
    )
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        joint = robot.joint("swing")
        joint.set_position(math.radians(angle_deg))
        robot.bus("can0").run(sleep(3.0))
        st = joint.get_joint_state()
    print(
        f"gear {gear:+g} at {angle_deg:g} deg: joint torque {st.torque:.4f} Nm (motor {st.motor.torque} Nm), "
        f"m g d sin = {expected:.4f} Nm, {st.torque / expected - 1:+.2%}"
    )
    assert math.degrees(st.position) == pytest.approx(angle_deg, abs=0.1)
    assert st.motor.torque * gear == pytest.approx(expected, rel=0.02)
    assert math.copysign(1.0, st.motor.torque) == math.copysign(1.0, gear)


async def test_the_asyncio_robot_holds_the_pendulum_too(tmp_path: Path) -> None:
    m, d = pendulum_arm()
    path = robot_file(
        tmp_path, ROBOTS / "pendulum.xml", {"swing": {"id": 1, "friction": "model", "sim_params": PENDULUM_GAINS}}
    )
    async with drempower.open_robot_async(path, sim={"clock": "virtual"}) as robot:
        assert robot.twin is not None
        joint = robot.joint("swing")
        await joint.set_position(math.radians(90.0))
        await robot.bus("can0").run(sleep(3.0))
        st = await joint.get_joint_state()
    assert st.torque == pytest.approx(m * G * d, rel=0.02)
