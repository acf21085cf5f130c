"""The asyncio robot: the same calls as coroutines, each bus's part a task."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import drempower
from drempower.client.engine.commands import q_move_time
from drempower.errors import BusClosedError, ValidationError
from drempower.robot import AsyncJoint, AsyncRobot
from drempower.sim import SimBus

from ..client.links import Recorder


async def test_async_robot_moves_stops_and_cycles(sim_robot_file: Path) -> None:
    async with drempower.open_robot_async(sim_robot_file, sim={"time_scale": 20.0}, timeout=0.5) as robot:
        assert isinstance(robot, AsyncRobot) and isinstance(robot.joint("elbow"), AsyncJoint)
        sims: dict[str, SimBus] = {n: b.transport.bus for n, b in robot.buses.items()}  # type: ignore[attr-defined]
        move = await robot.set_angles({"shoulder": 30.0, "elbow": 60.0}, speed=30.0, param=100.0)
        assert move.move_time == math.ceil(q_move_time(60.0, 30.0, 100.0) * 100) / 100
        assert set(move.starts) == {"left", "right"} and move.skew >= 0
        done = await robot.positions_done(["shoulder", "elbow"], timeout=10)
        assert done["shoulder"].angle == pytest.approx(30.0, abs=0.1)
        assert done["elbow"].angle == pytest.approx(60.0, abs=0.1)
        js = await robot.joint("elbow").get_joint_state()
        assert js.position == pytest.approx(math.radians(60.0) / -2.0 + 0.5, abs=1e-3)
        await robot.move_joints({"elbow": 0.5}, speed=1.0, accel=5.0)
        await robot.positions_done(["elbow"], timeout=10)
        assert (await robot.joint_states(["elbow"]))["elbow"].motor.angle == pytest.approx(0.0, abs=0.1)
        states = await robot.cycle({"hip": robot.joint("hip").make_speed(3.0)})
        assert list(states) == ["hip"] and states["hip"].node == 2
        with pytest.raises(ValidationError, match="no such joint"):
            await robot.get_states(["knee"])
        recs = {n: Recorder(s) for n, s in sims.items()}
        await robot.estop()
        assert all(len(r.frames) == 1 for r in recs.values())
        assert all(m.axis_error for s in sims.values() for m in s.motors.values())
        await robot.bus("right").close()
        with pytest.raises(BusClosedError):
            await robot.estop(["shoulder", "elbow"])
        assert len(recs["left"].frames) == 2  # the open bus still got its stop
    assert robot.closed
