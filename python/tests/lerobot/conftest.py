"""Helpers of the LeRobot plugin tests: arms of the example robot served as twins on adapter ptys, and
LeRobot's commands run in a subprocess with a local home (nothing fetched, no display, no sound).

These tests run in the LeRobot venv (``make test-lerobot``); the main run skips them (no LeRobot).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from contextlib import ExitStack, contextmanager
from pathlib import Path

import pytest

from drempower.robot import load_robot
from drempower.sim.adapter_pty import attach_adapter_pty
from drempower.sim.bus import SimBus
from drempower.sim.twin import Twin, TwinRunner, couple_robot

REPO_ROOT = Path(__file__).resolve().parents[3]
ARM = REPO_ROOT / "examples" / "robots" / "arm6.toml"
TIMEOUT = 1.0
"""s per request of the arms served here (the buses' own 0.1 s is short on a loaded, shared machine)."""
JOINTS = ("base_yaw", "shoulder", "elbow", "wrist_roll", "wrist_pitch", "flange_roll")


class ServedArm:
    """An arm twin served on an adapter pty: ``robot_file`` reaches it as a real arm would be reached."""

    def __init__(self, robot_file: Path, twin: Twin) -> None:
        self.robot_file = robot_file
        self.twin = twin

    def degrees(self) -> dict[str, float]:
        """Every joint's angle on the twin (deg)."""
        return {j: math.degrees(self.twin.joint_position(j)) for j in JOINTS}


@contextmanager
def served_arms(tmp_path: Path, names: Sequence[str]) -> Iterator[dict[str, ServedArm]]:
    """One twin of the example arm per name, each behind its own USB-CAN adapter pty, on wall time."""
    spec = load_robot(ARM)
    text = (
        ARM.read_text()
        .replace('file = "arm6.xml"', f'file = "{ARM.parent / "arm6.xml"}"')
        .replace("bitrate = 1000000\n", "")  # an adapter's CAN bit rate is its own setting
    )
    with ExitStack() as stack:
        arms: dict[str, ServedArm] = {}
        for name in names:
            sim = SimBus([j.id for j in spec.joints.values()], bitrate=1_000_000)
            twin = couple_robot(spec, {"arm": sim})
            assert twin is not None
            stack.enter_context(TwinRunner([sim]))
            pty = stack.enter_context(attach_adapter_pty(sim))
            client = tmp_path / f"{name}.toml"
            client.write_text(text.replace('interface = "sim"', f'interface = "adapter"\nchannel = "{pty.path}"'))
            arms[name] = ServedArm(client, twin)
        yield arms


def idle_on_timeout(robot_file: Path, joint: str) -> None:
    """Give ``joint`` of ``robot_file`` (an example arm's copy) ``on_timeout = "idle"``."""
    text = robot_file.read_text()
    entry = f"[joints.{joint}]\n"
    assert text.count(entry) == 1
    robot_file.write_text(text.replace(entry, f'{entry}on_timeout = "idle"\n'))


def lerobot_env(home: Path) -> dict[str, str]:
    """The environment of a LeRobot command: its homes under ``home``, offline, unbuffered, headless."""
    env = dict(os.environ)
    env.pop("DISPLAY", None)
    env.pop("WAYLAND_DISPLAY", None)
    env.update(
        HF_HOME=str(home / "hf"),
        HF_LEROBOT_HOME=str(home / "lerobot"),
        HF_LEROBOT_CALIBRATION=str(home / "calibration"),
        HF_HUB_OFFLINE="1",
        HF_DATASETS_OFFLINE="1",
        WANDB_MODE="disabled",
        PYTHONUNBUFFERED="1",
    )
    return env


def lerobot_command(name: str) -> str:
    """The path of LeRobot's console script ``name`` in this environment."""
    path = Path(sys.executable).parent / name
    if not path.exists():
        pytest.skip(f"{name} is not installed here (make test-lerobot installs LeRobot)")
    return str(path)


class Running:
    """A LeRobot command in a subprocess; its output is collected, ``started`` waits for a marker."""

    def __init__(self, argv: Sequence[str], env: dict[str, str], cwd: Path | None = None) -> None:
        self.proc = subprocess.Popen(
            list(argv), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env, text=True, errors="replace", cwd=cwd
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line)

    @property
    def output(self) -> str:
        return "".join(self.lines)

    def wait_for(self, marker: str, timeout: float) -> float:
        """Wait until ``marker`` appears in the output; returns ``time.monotonic()`` then."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if any(marker in line for line in self.lines):
                return time.monotonic()
            if self.proc.poll() is not None:
                self._reader.join(5)
                pytest.fail(f"exited with {self.proc.returncode} before {marker!r}:\n{self.output[-4000:]}")
            time.sleep(0.01)
        pytest.fail(f"no {marker!r} within {timeout} s:\n{self.output[-4000:]}")

    def finish(self, timeout: float, returncode: int = 0) -> str:
        """Wait for the command to end (killed after ``timeout`` s); asserts its exit status; its output."""
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(10)
            pytest.fail(f"still running after {timeout} s:\n{self.output[-4000:]}")
        self._reader.join(5)
        assert self.proc.returncode == returncode, self.output[-4000:]
        return self.output
