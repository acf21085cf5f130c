"""examples/leader_twin.py serves the leader twin of examples/lerobot/leader_twin.toml to another process and
pushes its joints as typed; the example robot files of docs/lerobot.md open with their model."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time

import pytest

import drempower
from drempower.robotfile import load_robot

from .conftest import REPO_ROOT

pytest.importorskip("mujoco")

LEROBOT_FILES = ("follower.toml", "leader.toml", "follower_twin.toml", "leader_twin.toml")
JOINTS = ["base_yaw", "shoulder", "elbow", "wrist_roll", "wrist_pitch", "flange_roll"]


@pytest.mark.parametrize("name", LEROBOT_FILES)
def test_the_lerobot_robot_files_name_every_joint_and_their_model(name: str) -> None:
    spec = load_robot(REPO_ROOT / "examples" / "lerobot" / name)
    assert list(spec.joints) == JOINTS
    assert spec.model is not None and os.path.samefile(spec.model.file, REPO_ROOT / "examples" / "robots" / "arm6.xml")
    assert spec.joints["shoulder"].gear == 2.0
    if name.startswith("follower"):  # the gate's largest step a command, rad
        assert all(j.limits.get("max_step") == (0.25 if "twin" in name else 0.1) for j in spec.joints.values())


def test_a_typed_push_moves_the_leader_twin_seen_from_another_process() -> None:
    proc = subprocess.Popen(
        [sys.executable, str(REPO_ROOT / "examples" / "leader_twin.py"), "--port", "0"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    assert proc.stdin is not None and proc.stdout is not None
    try:
        first = proc.stdout.readline()
        served = re.search(r"socketcand (\S+) port (\d+)", first)
        assert served is not None, first + (proc.stderr.read() if proc.stderr else "")
        with drempower.open_bus("socketcand", "can0", host=served[1], port=int(served[2]), timeout=1.0) as bus:
            bus.motor(1).idle()  # released, as teach mode leaves it to the hand (the motors start holding)
            time.sleep(0.2)
            before = bus.motor(1).get_state().angle
            proc.stdin.write("base_yaw 2 0.3\n")
            proc.stdin.flush()
            assert proc.stdout.readline().startswith("pushed base_yaw with 2 Nm for 0.3 s")
            time.sleep(1.0)
            after = bus.motor(1).get_state().angle
            assert abs(after - before) > 5.0  # deg: the idle joint turned under the push
            proc.stdin.write("?\n")
            proc.stdin.flush()
            shown = dict(w.split("=") for w in proc.stdout.readline().split())
            assert list(shown) == JOINTS
            now = bus.motor(1).get_state().angle
            assert float(shown["base_yaw"]) == pytest.approx(now, abs=2.0)  # the same twin, seen from both sides
            proc.stdin.write("knee 1\n")
            proc.stdin.flush()
            assert proc.stdout.readline().startswith("not a push: 'knee 1'")
        proc.stdin.close()
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
