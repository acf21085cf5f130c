"""The shadow twin: beside a "real" arm whose model has an obstacle the twin lacks, it flags the contact within
0.2 s and holds the arm as the robot file asks; over ordinary motion it flags nothing."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from drempower.client.engine.effects import sleep
from drempower.motion.trajectory import Trajectory
from drempower.robot import open_robot
from drempower.robot.shadow import Divergence

from .conftest import ROBOTS


def _with_obstacle(tmp: Path) -> Path:
    """arm6 with a rigid ball (radius 5 cm) at x 0.25 m, z 0.45 m: the upper arm meets it near 0.57 rad."""
    root = ET.parse(ROBOTS / "arm6.xml").getroot()
    world = root.find("worldbody")
    assert world is not None
    ET.SubElement(
        world, "geom", name="obstacle", type="sphere", size="0.05", pos="0.25 0 0.45", contype="0", conaffinity="1"
    )
    model = tmp / "obstacle.xml"
    ET.ElementTree(root).write(model)
    robot = tmp / "obstacle.toml"
    text = (ROBOTS / "arm6.toml").read_text().replace('file = "arm6.xml"', f'file = "{model}"')
    # the robot file says what a divergence of the shoulder does (the other joints: "warn", the default)
    robot.write_text(text.replace("[joints.shoulder]\n", '[joints.shoulder]\non_divergence = "hold"\n'))
    return robot


@pytest.mark.timeout(600)
def test_a_contact_is_flagged_within_0_2_s_and_the_arm_held(tmp_path: Path) -> None:
    events: list[Divergence] = []
    with open_robot(_with_obstacle(tmp_path), sim={"clock": "virtual"}) as robot:
        bus = robot.buses["arm"]
        sim = bus.transport.bus
        real = robot.twin
        assert real is not None
        contact: list[float] = []

        def watch(frame: object, tx: bool) -> None:
            if not contact and real.data.ncon > 0:
                contact.append(sim.now)

        bus.add_tap(watch)
        for j in robot.spec.joints.values():
            bus.motor(j.id).write_property("can.config.heartbeat_ms", 5)
        with robot.shadow(model=str(ROBOTS / "arm6.xml"), on_event=events.append, clock=lambda: sim.now) as shadow:
            assert shadow.action("shoulder") == "hold" and shadow.action("elbow") == "warn"
            robot.joint("shoulder").set_position(0.8, bandwidth=5.0)
            bus.run(sleep(3.0))
            assert contact, "the arm never met the obstacle"
            assert len(events) == 1 and events[0].joint == "shoulder" and events[0].kind == "position"
            detection = events[0].flagged - contact[0]
            print(f"contact at {contact[0]:.3f} s, flagged at {events[0].flagged:.3f} s: {detection * 1000:.0f} ms")
            assert 0 < detection <= 0.2
            for _ in range(20):  # the hold is sent from the shadow's own thread
                if shadow.acted.is_set():
                    break
                bus.run(sleep(0.05))
            assert shadow.acted.is_set()
            at = robot.joint_states()["shoulder"].position
            assert at < 0.6  # stopped at the ball
            # held there: the program's target (0.8 rad) is gone, so when the ball goes the arm stays
            real.model.geom("obstacle").contype = 0
            real.model.geom("obstacle").conaffinity = 0
            bus.run(sleep(1.0))
            assert robot.joint_states()["shoulder"].position == pytest.approx(at, abs=0.02)
        bus.remove_tap(watch)


@pytest.mark.timeout(900)
def test_no_false_alarm_over_ordinary_motion(tmp_path: Path) -> None:
    """60 s of the arm following an excitation of every joint (a 200 Hz control loop, states every 5 ms) on
    the virtual clock, the shadow with the robot's own model: nothing flagged, every residual under 3 deg."""
    seconds = 60.0
    events: list[Divergence] = []
    with open_robot(ROBOTS / "arm6.toml", sim={"clock": "virtual"}) as robot:
        bus = robot.buses["arm"]
        sim = bus.transport.bus
        for j in robot.spec.joints.values():
            bus.motor(j.id).write_property("can.config.heartbeat_ms", 5)
        with robot.shadow(on_event=events.append, clock=lambda: sim.now) as shadow:
            largest = [0.0]

            def track(frame: object, tx: bool) -> None:  # after the shadow's own tap: every residual it saw
                if not tx and shadow.residuals:
                    largest[0] = max(largest[0], *(abs(r[0]) for r in shadow.residuals.values()))

            bus.add_tap(track)
            start = sim.now
            robot.follow(Trajectory.excitation(list(robot.spec.joints), seconds, amplitude=0.4))
            watched = sim.now - start
            bus.remove_tap(track)
            worst = largest[0]
    print(f"{watched:.1f} s watched, {len(events)} divergences, largest residual {math.degrees(worst):.4f} deg")
    assert watched >= seconds
    assert events == []
    assert worst < math.radians(3.0)
