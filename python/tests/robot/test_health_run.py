"""The robot file's ``[health]`` supervisor runs on its own once the robot is open: at its period on the bus's
clock, acting per joint, its events logged and kept, stopped on close; on threads and on asyncio."""

from __future__ import annotations

import asyncio
import logging
from pathlib import Path

import pytest

import drempower
from drempower.client.engine.supervisor import FRAMES_PER_MOTOR
from drempower.errors import MotorIdleError
from drempower.protocol import AxisState, ParamValue, State, decode_reply
from drempower.protocol.ids import Frame
from drempower.sim import SimBus

from ..waits import eventually


def _robot(tmp_path: Path, health: str = '[health]\nperiod = 0.5\non_overheat = "hold"\n') -> Path:
    p = tmp_path / "robot.toml"
    p.write_text(
        '[buses.can0]\ninterface = "sim"\n'
        '[joints.a]\nbus = "can0"\nid = 1\non_overheat = "idle"\n'
        '[joints.b]\nbus = "can0"\nid = 2\non_stall = "idle"\n'
        f"{health}"
    )
    return p


def _sim(robot: drempower.Robot | drempower.AsyncRobot) -> SimBus:
    sim = robot.bus("can0").transport.bus  # type: ignore[attr-defined]
    assert isinstance(sim, SimBus)
    return sim


def test_open_robot_runs_the_supervisor_at_its_period_and_acts_per_joint(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, "drempower.health")
    with drempower.open_robot(_robot(tmp_path), sim={"clock": "virtual"}) as robot:
        run = robot.health_run
        assert run is not None and run.running
        sim, bus = _sim(robot), robot.bus("can0")
        bus.pass_time(1.2)
        assert len(run.events) == 0 and run.steps == 3  # t = 0, 0.5, 1.0: healthy, nothing said
        for m in sim.motors.values():
            m.thermal.winding = 91.0  # 4 K below the firmware's 95 degC derating
        bus.pass_time(0.5)
        got = {(e.joint, e.kind, e.action, e.at) for e in run.events}
        assert got == {("a", "overheat", "idle", 1.5), ("b", "overheat", "hold", 1.5)}  # the next step, on time
        assert sim.motors[1].state == AxisState.IDLE
        assert sim.motors[2].state == AxisState.CLOSED_LOOP_CONTROL
        assert run.levels() == {("can0", 1): "warn", ("can0", 2): "warn"}
    assert not run.running
    lines = [r.getMessage() for r in caplog.records if r.name == "drempower.health"]
    assert any("joint a (motor 1)" in x and "Released it (idle)" in x for x in lines)
    assert any("joint b (motor 2)" in x and "Holding it (speed 0)" in x for x in lines)


def test_a_stall_idles_only_the_joint_that_asks_for_it(tmp_path: Path) -> None:
    health = "[health]\nperiod = 0.1\nstall_s = 0.5\n"
    with drempower.open_robot(_robot(tmp_path, health), sim={"clock": "virtual"}) as robot:
        sim = _sim(robot)
        for node in (1, 2):
            sim.motors[node].locked = True
            robot.bus("can0").motor(node).set_angle(90.0, 0.0, 20.0, 0)
        robot.bus("can0").pass_time(1.0)
        stalls = {e.joint: e for e in robot.health_run.events if e.kind == "stall"}  # type: ignore[union-attr]
        assert set(stalls) == {"a", "b"}
        assert stalls["a"].action == "none" and stalls["b"].action == "idle"
        assert 0.5 <= stalls["b"].at <= 0.7
        assert sim.motors[2].state == AxisState.IDLE
        assert sim.motors[1].state == AxisState.CLOSED_LOOP_CONTROL  # [health]'s on_stall: warn
        assert sim.motors[2].errors[33001] == 0  # before the firmware's own stall protection


def test_its_bus_cost_is_twelve_frames_per_motor_and_period(tmp_path: Path) -> None:
    with drempower.open_robot(_robot(tmp_path, "[health]\nperiod = 1.0\n"), sim={"clock": "virtual"}) as robot:
        replies: list[Frame] = []
        bus = robot.bus("can0")
        bus.pass_time(0.5)  # the first step (with the limits) is behind
        _sim(robot).add_listener(replies.append)
        bus.pass_time(10.0)  # steps at 1, 2, ..., 10 s
    decoded = [decode_reply(f.arbitration_id, f.data) for f in replies]
    assert len(decoded) == 10 * 2 * FRAMES_PER_MOTOR // 2  # ten steps, two motors, one reply per request
    assert sum(isinstance(r, State) for r in decoded) == 20
    assert sum(isinstance(r, ParamValue) for r in decoded) == 100


def test_no_health_section_or_supervise_false_runs_nothing(tmp_path: Path) -> None:
    with drempower.open_robot(_robot(tmp_path, ""), sim={"clock": "virtual"}) as robot:
        assert robot.health_run is None
    with drempower.open_robot(_robot(tmp_path), sim={"clock": "virtual"}, supervise=False) as robot:
        assert robot.health_run is None


def test_on_a_wall_clock_a_thread_runs_it_and_close_ends_it(tmp_path: Path) -> None:
    health = '[health]\nperiod = 0.05\non_overheat = "hold"\n'
    with drempower.open_robot(_robot(tmp_path, health)) as robot:
        run = robot.health_run
        assert run is not None
        thread = run._thread
        assert thread is not None and thread.is_alive()
        sim = _sim(robot)
        with sim.lock:
            sim.motors[1].thermal.winding = 91.0
        assert eventually(lambda: sim.motors[1].state == AxisState.IDLE, limit=20.0)
        # the supervisor's thread records the event once its action is sent: the motor may be idle first
        assert eventually(
            lambda: [(e.joint, e.kind, e.action) for e in run.events][:1] == [("a", "overheat", "idle")], limit=20.0
        )
    assert not thread.is_alive()


def test_the_asyncio_robot_runs_it_as_a_task_on_either_clock(tmp_path: Path) -> None:
    async def main(virtual: bool) -> None:
        sim_opts = {"clock": "virtual"} if virtual else None
        health = '[health]\nperiod = 0.05\non_overheat = "hold"\n'
        async with drempower.open_robot_async(_robot(tmp_path, health), sim=sim_opts) as robot:
            run = robot.health_run
            assert run is not None
            assert (run.task is None) == virtual  # on a virtual clock: an operation of the bus's session
            sim = _sim(robot)
            with sim.lock:
                sim.motors[2].thermal.winding = 91.0
            for _ in range(2000):
                if sim.motors[2].speed == 0.0 and any(e.kind == "overheat" for e in run.events):
                    break
                if virtual:
                    await robot.bus("can0").pass_time(0.05)
                else:
                    await asyncio.sleep(0.01)
            assert [(e.joint, e.kind, e.action) for e in run.events] == [("b", "overheat", "hold")]
            task = run.task
        assert not run.running
        if task is not None:
            assert task.done()

    asyncio.run(main(True))
    asyncio.run(main(False))


def test_six_motors_at_the_default_period_take_under_one_percent_of_a_1_mbit_bus(tmp_path: Path) -> None:
    """The documented cost, measured on the simulated wire (frame lengths with stuffing, 1 Mbit/s)."""
    p = tmp_path / "six.toml"
    joints = "".join(f'[joints.j{i}]\nbus = "can0"\nid = {i}\n' for i in range(1, 7))
    p.write_text('[buses.can0]\ninterface = "sim"\nbitrate = 1000000\n' + joints + "[health]\n")
    with drempower.open_robot(p, sim={"clock": "virtual"}) as robot:
        bus = robot.bus("can0")
        sim = _sim(robot)
        bus.pass_time(0.5)  # the first step (with the limits) is behind
        before = sim.stats
        bus.pass_time(60.0)
        after = sim.stats
    frames, busy = after.frames - before.frames, after.busy - before.busy
    steps = frames / (6 * FRAMES_PER_MOTOR)
    assert frames % (6 * FRAMES_PER_MOTOR) == 0 and 58 <= steps <= 60  # a period after each step's end
    assert busy / (after.elapsed - before.elapsed) < 0.01
    assert 1.0e-3 < busy / steps / 6 < 1.7e-3  # s of the bus per motor and step
    print(f"{frames} frames, {steps:.0f} steps in 60 s: {busy / 60 * 100:.2f} % of the bus, "
          f"{busy / steps / 6 * 1e3:.2f} ms per motor and step")  # fmt: skip


def test_a_joint_it_idled_is_refused_motion_until_enabled_again(tmp_path: Path) -> None:
    """A program still commanding the joint (a control loop, a LeRobot step) gets a clear error, not silence."""
    health = '[health]\nperiod = 0.5\non_overheat = "idle"\n'
    with drempower.open_robot(_robot(tmp_path, health), sim={"clock": "virtual"}) as robot:
        a = robot.joint("a")
        robot.cycle({"a": a.make_angle(0.0, 0.0, 20.0, 0)})
        _sim(robot).motors[1].thermal.winding = 91.0
        robot.bus("can0").pass_time(0.6)
        assert _sim(robot).motors[1].state == AxisState.IDLE
        with pytest.raises(MotorIdleError, match="motor 1 is idle"):
            robot.cycle({"a": a.make_angle(10.0, 0.0, 20.0, 0)})
        robot.cycle({"b": robot.joint("b").make_angle(10.0, 0.0, 20.0, 0)})  # the other joint goes on
        a.enable()
        robot.cycle({"a": a.make_angle(10.0, 0.0, 20.0, 0)})
