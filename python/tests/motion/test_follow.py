"""follow: a 6-joint trajectory on the twin arm in T, impedance and P mode; refusals before any frame;
a stop by max_error; the same on the plain simulator, from asyncio, and through the adapter's pty."""

from __future__ import annotations

import asyncio
import math
import time
from pathlib import Path
from typing import Any

import pytest

import drempower
from drempower.errors import ValidationError
from drempower.motion import Trajectory, follow_bus
from drempower.motion.follow_async import follow_bus as follow_bus_async
from drempower.motion.plan import FollowError
from drempower.protocol.ids import Frame
from drempower.sim import SimBus

from ..client.links import link
from ..conftest import REPO_ROOT

ARM = REPO_ROOT / "examples" / "robots" / "arm6.toml"
JOINTS = ("base_yaw", "shoulder", "elbow", "wrist_roll", "wrist_pitch", "flange_roll")
_MOVE = (0.5, 0.3, -0.4, 0.6, 0.4, -0.6)
"""How far (rad) each joint of the arm goes and comes back in 2 s."""


def _arm_path(start: list[float]) -> Trajectory:
    goal = [s + d for s, d in zip(start, _MOVE, strict=True)]
    tr = Trajectory.from_waypoints([start, goal, start], max_speed=1.0, max_accel=3.0, joints=JOINTS)
    return tr.scaled(tr.duration / 2.0)  # exactly 2 s


def _tx_frames(bus: drempower.Bus) -> list[Frame]:
    sent: list[Frame] = []
    bus.add_tap(lambda frame, tx: sent.append(frame) if tx else None)
    return sent


@pytest.mark.parametrize(("mode", "bound"), [("position", 0.03), ("impedance", 0.03), ("p", 0.01)])
def test_six_joint_trajectory_on_the_twin_arm(mode: str, bound: float) -> None:
    pytest.importorskip("mujoco")
    with drempower.open_robot(ARM, sim={"clock": "virtual"}) as robot:
        states = robot.joint_states()
        tr = _arm_path([states[j].position for j in JOINTS])
        assert tr.duration == pytest.approx(2.0)
        report = robot.follow(tr, mode=mode, rate=200.0, kp=30.0, kd=1.0, max_error=0.1)
        twin = robot.twin
        assert twin is not None
        end = twin.joint_positions()
    worst = max(report.max_error.values())
    print(
        f"{mode}: largest tracking error {worst:.4f} rad ({math.degrees(worst):.2f} deg), {report.late} late, "
        f"{report.rate:.1f} Hz over {report.duration:.3f} s; per joint "
        + ", ".join(f"{n} {e:.4f}" for n, e in report.max_error.items())
    )
    assert set(report.max_error) == set(JOINTS)
    assert 0.0 < worst < bound
    assert report.late == 0
    assert report.cycles == 401
    assert report.rate == pytest.approx(200.0, rel=1e-3)
    assert report.duration == pytest.approx(2.0, abs=0.01)
    for name in JOINTS:  # back where it started: the model's joints followed
        assert end[name] == pytest.approx(tr.positions[-1][JOINTS.index(name)], abs=0.02)


def test_a_trajectory_beyond_a_limit_is_refused_before_any_frame() -> None:
    pytest.importorskip("mujoco")
    with drempower.open_robot(ARM, sim={"clock": "virtual"}) as robot:
        sent = _tx_frames(robot.bus("arm"))
        # the elbow's model range is -2.5..2.5 rad
        with pytest.raises(ValidationError) as err:
            robot.follow([0.0, 1.0, 2.0], {"elbow": [0.0, 2.7, 0.0]}, rate=200.0)
        assert "joint 'elbow'" in str(err.value) and "outside its limits -2.5..2.5 rad" in str(err.value)
        # a speed limit given to follow
        with pytest.raises(ValidationError, match=r"speed .* beyond its limit \+-0.5 rad/s"):
            robot.follow([0.0, 1.0], {"elbow": [0.0, 1.0]}, limits={"elbow": {"speed": 0.5}})
        # a rate above what 1 Mbit/s carries for 6 motors
        with pytest.raises(ValidationError, match=r"rate=2000 Hz: above what bus 'arm' carries .* at most \d+ Hz"):
            robot.follow([0.0, 1.0], [[0.0] * 6, [0.1] * 6], rate=2000.0)
        with pytest.raises(ValidationError, match="mode='q': one of"):
            robot.follow([0.0, 1.0], [[0.0] * 6, [0.1] * 6], mode="q")
        assert sent == []


def test_an_obstacle_in_the_path_stops_the_robot_by_max_error() -> None:
    """The twin pushes the elbow back (a rigid 20 Nm obstacle) as it moves: follow stops, holding where it is."""
    pytest.importorskip("mujoco")
    with drempower.open_robot(ARM, sim={"clock": "virtual"}) as robot:
        twin = robot.twin
        assert twin is not None
        states = robot.joint_states()
        tr = _arm_path([states[j].position for j in JOINTS])
        twin.push_joint("elbow", 20.0, duration=10.0)  # the move goes to -0.4 rad: the push resists it
        with pytest.raises(FollowError) as err:
            robot.follow(tr, max_error=0.05)
        report = err.value.report
        assert "joint 'elbow'" in str(err.value) and "above max_error=0.05 rad" in str(err.value)
        assert report.stopped is not None and report.cycles < 401
        assert report.max_error["elbow"] > 0.05
        held = {n: s.position for n, s in robot.joint_states().items()}
        from drempower.client.engine.effects import sleep

        robot.bus("arm").run(sleep(0.5))
        later = robot.joint_states()
    print(f"stopped after {report.cycles} cycles ({report.duration:.3f} s): {report.stopped}")
    for name in ("base_yaw", "wrist_roll", "flange_roll"):  # the joints not pushed stay where they stopped
        assert later[name].position == pytest.approx(held[name], abs=0.01)


def test_bus_follow_on_the_plain_simulator_in_deg() -> None:
    with drempower.open_bus("sim", motors=[1, 2, 3], clock="virtual", bitrate=1_000_000) as bus:
        t = [0.0, 0.5, 1.0]
        report = follow_bus(bus, [1, 2, 3], t, [[0.0, 0.0, 0.0], [30.0, -20.0, 10.0], [0.0, 0.0, 0.0]], max_error=5.0)
        assert set(report.max_error) == {"1", "2", "3"}
        print(f"plain simulator: largest tracking error {max(report.max_error.values()):.3f} deg")
        assert 0.0 < max(report.max_error.values()) < 5.0
        assert report.late == 0 and report.cycles == 201
        far = r"joint '2' is at -?0\.\d+ deg, the trajectory starts at 90 deg: more than start_tolerance"
        with pytest.raises(ValidationError, match=far):
            follow_bus(bus, [1, 2], [0.0, 1.0], [[0.0, 90.0], [0.0, 90.0]])


def test_async_bus_and_robot_follow() -> None:
    async def run() -> tuple[float, float]:
        async with drempower.open_bus_async("sim", motors=[1, 2], clock="virtual") as bus:
            rep = await follow_bus_async(bus, [1, 2], [0.0, 1.0], [[0.0, 0.0], [20.0, -20.0]], mode="impedance", kp=5.0)
        spec = drempower.robot.parse_robot(
            {"buses": {"b": {"interface": "sim"}}, "joints": {"a": {"bus": "b", "id": 1, "gear": 2.0}}}
        )
        async with drempower.open_robot_async(spec, sim={"clock": "virtual"}) as robot:
            rep2 = await robot.follow([0.0, 0.5], [[0.0], [0.3]], mode="p")
        return max(rep.max_error.values()), rep2.max_error["a"]

    deg, rad = asyncio.run(run())
    assert 0.0 < deg < 5.0 and 0.0 < rad < 0.05


def test_follow_through_the_adapter_pty_in_real_time() -> None:
    sim = SimBus([1, 2], bitrate=1_000_000)
    with link("adapter", sim, time_scale=1.0, stop_on_close=True) as bus:
        began = time.monotonic()
        report = follow_bus(bus, [1, 2], [0.0, 0.75, 1.5], [[0.0, 0.0], [15.0, -15.0], [0.0, 0.0]], rate=100.0)
        took = time.monotonic() - began
    worst = max(report.max_error.values())
    print(f"adapter pty: {report.rate:.1f} Hz, {report.late} late, largest error {worst:.2f} deg")
    assert 1.4 < took < 6.0
    assert report.cycles >= 100 and report.rate > 70.0  # real time on a shared host: some cycles late
    assert max(report.max_error.values()) < 10.0


def test_ctrl_c_during_follow_holds_the_joints(tmp_path: Path) -> None:
    """An interruption mid-trajectory (Ctrl-C, or SIGTERM in the CLI) sends each joint a hold where it is."""
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        sent = _tx_frames(bus)
        calls = 0
        original = bus.cycle

        def interrupted(*args: object, **kw: object) -> object:
            nonlocal calls
            calls += 1
            if calls == 50:
                raise KeyboardInterrupt
            return original(*args, **kw)  # type: ignore[arg-type]

        bus.cycle = interrupted  # type: ignore[method-assign]
        with pytest.raises(KeyboardInterrupt):
            follow_bus(bus, [1], [0.0, 1.0], [[0.0], [40.0]])
        last = sent[-1]
        at = bus.motor(1).get_state().angle
    from drempower.protocol.messages import PositionT, decode_command

    msg = decode_command(last.arbitration_id, last.data)
    assert isinstance(msg, PositionT)
    assert msg.position == pytest.approx(at, abs=1.0) and 2.0 < msg.position < 35.0  # mid-way


def test_max_step_checks_each_point_of_a_path_against_the_point_before() -> None:
    """A path that leaves its start by more than ``max_step`` in all is followed: each point is checked
    against the one before it (the first against where the motor is), on a bus and on a robot."""
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        bus.set_limits(1, max_step=20)
        report = follow_bus(bus, [1], [0.0, 3.0], [[0.0], [51.57]], max_error=5.0)
        assert report.stopped is None
        assert bus.motor(1).get_state().angle == pytest.approx(51.57, abs=1.0)
        with pytest.raises(drempower.SoftLimitError, match="motor 1: max_step"):
            follow_bus(bus, [1], [0.0, 0.01, 1.0], [[51.57], [80.0], [80.0]])  # one point 28 deg after the one before
    from drempower.robot import parse_robot

    spec = parse_robot(
        {
            "buses": {"b": {"interface": "sim"}},
            "joints": {"a": {"bus": "b", "id": 1, "limits": {"position": [-1.0, 1.0], "max_step": 0.5}}},
        }
    )
    with drempower.open_robot(spec, sim={"clock": "virtual"}) as robot:
        rep = robot.follow([0.0, 3.0], [[0.0], [0.9]])
        assert rep.stopped is None
        assert robot.joint("a").get_joint_state().position == pytest.approx(0.9, abs=0.02)


def test_a_plan_is_made_as_it_is_followed_with_a_longest_duration() -> None:
    """A plan's memory does not grow with its duration (its cycles' commands are made when asked for), and
    a trajectory longer than MAX_DURATION is refused before anything is sent."""
    import tracemalloc

    from drempower.motion.plan import MAX_DURATION, Lane, Units, make_plan

    def plan_of(seconds: float) -> Any:
        tr = Trajectory([0.0, seconds], [[0.0], [10.0]], joints=["1"])
        lane = Lane("bus", ["1"], [1], [Units(deg=True)], [0], ["idle"], None)
        opts = {"rate": 200.0, "mode": "position", "max_error": None, "kp": 20.0, "kd": 1.0}
        return make_plan(tr, [lane], limits={}, bandwidth=None, torques=None, timeout=None, **opts)

    tracemalloc.start()
    try:
        plan = plan_of(100.0)
        for _ in plan.commands:
            pass
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(plan.commands) == 20001
    assert plan.commands[-1]["bus"][0].position == pytest.approx(10.0)
    print(f"a 100 s plan at 200 Hz, every cycle made: peak {peak / 1e6:.3f} MB")
    assert peak < 2e6, peak  # a list of its 20001 cycles took about 13 MB
    assert MAX_DURATION == 600.0
    with pytest.raises(ValidationError, match=r"the trajectory lasts 6000 s, beyond the longest a plan follows"):
        plan_of(6000.0)
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        sent = _tx_frames(bus)
        with pytest.raises(ValidationError, match="split it; nothing was sent"):
            follow_bus(bus, [1], [0.0, 6000.0], [[0.0], [10.0]])
        assert sent == []
