"""A hidden truth for the twin fit's tests: the example arm with other joint parameters, recorded in-process.

The "real" robot is ``arm6.xml`` with :data:`TRUTH` as its joints' armature, damping and friction loss
(``friction = "model"``: those are the totals), on the virtual clock; a recorder takes every frame of
its bus stamped with the simulated time (the host's as it sends them, the motors' as they reach the
bus), while the robot follows an excitation in impedance mode and the motors send their state every
5 ms, 3 ms late, with sensor noise (:data:`NOISE`) on what they report.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path

from drempower.motion.trajectory import Trajectory
from drempower.protocol.ids import Frame
from drempower.records.recorder import Recorder
from drempower.robot import open_robot
from drempower.sim.faults import Faults
from drempower.sim.noise import SensorNoise

from .conftest import ROBOTS

TRUTH: dict[str, dict[str, float]] = {
    "base_yaw": {"armature": 0.009, "damping": 0.11, "frictionloss": 0.20},
    "shoulder": {"armature": 0.035, "damping": 0.14, "frictionloss": 0.35},
    "elbow": {"armature": 0.009, "damping": 0.09, "frictionloss": 0.20},
    "wrist_roll": {"armature": 0.008, "damping": 0.09, "frictionloss": 0.08},
    "wrist_pitch": {"armature": 0.0075, "damping": 0.10, "frictionloss": 0.18},
    "flange_roll": {"armature": 0.0035, "damping": 0.04, "frictionloss": 0.07},
}
"""The "real" arm's joint parameters (totals at the joint); the example's twin has others (the model's
damping 0.05 and friction loss 0.02 plus the motor's rotor inertia and friction)."""
NOISE = SensorNoise(position=0.015, speed=0.2, torque=0.01, seed=11)
"""The "real" motors' sensor noise (standard deviations: deg, r/min, Nm): an encoder's position to about
a 24000th of a turn, its speed and the torque estimate from the current a little filtered."""
EPOCH = 1_800_000_000.0
"""Unix time (s) of the recordings' simulated time 0."""


def truth_robot(tmp: Path, truth: Mapping[str, Mapping[str, float]] = TRUTH, *, name: str = "real") -> Path:
    """A robot file (and its model) in ``tmp``: the example arm with ``truth``'s joint parameters."""
    root = ET.parse(ROBOTS / "arm6.xml").getroot()
    for j in root.iter("joint"):
        values = truth.get(j.get("name") or "")
        if values:
            for key, value in values.items():
                j.set(key, repr(value))
    model = tmp / f"{name}.xml"
    ET.ElementTree(root).write(model)
    text = (ROBOTS / "arm6.toml").read_text().replace('file = "arm6.xml"', f'file = "{model}"')
    text = text.replace("bitrate = 1000000\n", "")  # frames take no time on its bus: the recorder's stamps are exact
    for joint in truth:
        text = text.replace(f"[joints.{joint}]\n", f'[joints.{joint}]\nfriction = "model"\n')
    path = tmp / f"{name}.toml"
    path.write_text(text)
    return path


def record(
    robot_file: Path,
    out: Path,
    seconds: float,
    *,
    joints: Sequence[str] | None = None,
    amplitude: float = 0.3,
    mode: str = "impedance",
    heartbeat_ms: int = 5,
    delay: float = 0.003,
    kd: float = 0.1,
    noise: SensorNoise | None = NOISE,
) -> Path:
    """Record ``robot_file``'s arm following an excitation of ``joints`` (default all; the others hold)
    for ``seconds`` s on the virtual clock, to the MCAP file ``out``; the motors' frames reach the
    recorder ``delay`` s late (a transport delay). Impedance ``kp`` 20 Nm/rad and ``kd`` Nm s/rad: a
    ``kd`` well above a joint's own damping would hide it. ``noise``: on the motors' state frames."""
    sim_options = {"clock": "virtual", "faults": Faults(reply_delay=delay), "noise": noise}
    with open_robot(robot_file, sim=sim_options) as robot:
        bus = robot.buses["arm"]
        sim = bus.transport.bus
        names = list(robot.spec.joints) if joints is None else list(joints)
        with Recorder(out) as rec:

            def tap(frame: Frame, tx: bool) -> None:  # the host's frames, as it sends them
                if tx:
                    rec.record(frame, True, EPOCH + sim.now)

            def wire(frame: Frame) -> None:  # the motors' frames, as they reach the bus
                rec.record(frame, False, EPOCH + sim.now)

            bus.add_tap(tap)
            sim.add_listener(wire)
            try:
                for j in robot.spec.joints.values():
                    bus.motor(j.id).write_property("can.config.heartbeat_ms", heartbeat_ms)
                tr = Trajectory.excitation(names, seconds, amplitude=amplitude)
                robot.follow(tr, mode=mode, kp=20.0, kd=kd)
                for j in robot.spec.joints.values():
                    bus.motor(j.id).write_property("can.config.heartbeat_ms", 0)
            finally:
                bus.remove_tap(tap)
                sim.remove_listener(wire)
    return out
