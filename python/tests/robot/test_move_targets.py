"""Robot moves record each joint's target: a wait raises when a joint stops at its angle limits."""

from __future__ import annotations

import asyncio
import time
from pathlib import Path

import pytest

import drempower
from drempower.client import MoveError
from drempower.robot import open_robot


def test_positions_done_raises_when_a_joint_stops_at_its_limit(sim_robot_file: Path) -> None:
    with open_robot(sim_robot_file, sim={"time_scale": 20.0}, timeout=0.5) as robot:
        robot.joint("elbow").set_angle_range(-20, 20)
        move = robot.set_angles({"shoulder": 30.0, "elbow": 60.0}, speed=60.0, param=200.0)
        assert robot.bus("right")._core.session.known.moves[1].target == 60.0
        assert robot.bus("left")._core.session.known.moves[1].move_time == move.move_time
        with pytest.raises(MoveError) as info:
            robot.positions_done(["shoulder", "elbow"], timeout=10)
        e = info.value
        assert e.node == 1 and e.target == 60.0 and e.position == pytest.approx(20.0, abs=0.5)
        robot.set_angles({"shoulder": 10.0, "elbow": 15.0}, speed=0.0, param=20.0, mode=0)  # T mode: no move time
        done = robot.positions_done(["shoulder", "elbow"], timeout=10)
        assert [done["shoulder"].angle, done["elbow"].angle] == pytest.approx([10.0, 15.0], abs=0.5)


async def test_async_robot_positions_done_raises_at_the_limit(sim_robot_file: Path) -> None:
    async with drempower.open_robot_async(sim_robot_file, sim={"time_scale": 20.0}, timeout=0.5) as robot:
        await robot.joint("hip").set_angle_range(-10, 10)
        await robot.set_angles({"hip": -45.0, "elbow": 30.0}, speed=60.0, param=200.0)
        with pytest.raises(MoveError) as info:
            await robot.positions_done(["hip", "elbow"], timeout=10)
        assert info.value.node == 2 and info.value.target == -45.0
        assert info.value.position == pytest.approx(-10.0, abs=0.5)


async def test_async_robot_start_waits_outside_the_event_loop(tmp_path: Path) -> None:
    """At 1 kbit/s (135 ms a frame) the start waits for its presets: the event loop keeps running meanwhile."""
    path = tmp_path / "slow.toml"
    path.write_text(
        '[buses.left]\ninterface = "sim"\nbitrate = 1000\ntime_scale = 1.0\n'
        '[joints.a]\nbus = "left"\nid = 1\n[joints.b]\nbus = "left"\nid = 2\n[joints.c]\nbus = "left"\nid = 3\n'
    )
    async with drempower.open_robot_async(path, timeout=1.0) as robot:
        gaps: list[float] = []
        stop = asyncio.Event()

        async def tick() -> None:
            last = time.monotonic()
            while not stop.is_set():
                await asyncio.sleep(0.005)
                now = time.monotonic()
                gaps.append(now - last)
                last = now

        ticker = asyncio.ensure_future(tick())
        await asyncio.sleep(0.02)
        t0 = time.monotonic()
        await robot.set_angles({"a": 1.0, "b": 2.0, "c": 3.0}, speed=0.0, param=20.0, mode=0, enable=True)
        took = time.monotonic() - t0
        stop.set()
        await ticker
        assert took > 0.35  # three presets on the wire first
        assert max(gaps) < 0.2
