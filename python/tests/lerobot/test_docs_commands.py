"""The command blocks of docs/lerobot.md's "Both arms as twins" run as written: a leader twin moved by typed
pushes drives the follower twin through ``lerobot-teleoperate``, ``lerobot-record`` records an episode of it,
and ``lerobot-replay`` plays it on a follower twin that the dashboard watches.

The commands run from a copy of the repository's ``examples/`` (so that ``datasets/`` is written there), with
the LeRobot venv's ``python``, ``drempower`` and LeRobot's commands, exactly as the page gives them.
"""

from __future__ import annotations

import math
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("lerobot", reason="LeRobot is not installed here: make test-lerobot runs these")

from lerobot.datasets.lerobot_dataset import LeRobotDataset

import drempower

from .conftest import JOINTS, REPO_ROOT, Running, lerobot_command, lerobot_env

PAGE = REPO_ROOT / "docs" / "lerobot.md"
SECTION = "## Both arms as twins"
FOLLOWER_PORT = 29536
TOLERANCE = 0.5
"""deg: the follower against the leader at rest, the replayed follower against the episode's last action."""


def page_commands() -> list[list[str]]:
    """The section's ``sh`` blocks, each a list of commands (continuation lines joined, comments dropped)."""
    text = PAGE.read_text()
    section = text[text.index(SECTION) :]
    section = section[: section.index("\n## ", 1)]
    blocks = []
    for block in re.findall(r"```sh\n(.*?)```", section, re.S):
        joined = block.replace("\\\n", " ")
        commands = [shlex.join(shlex.split(line, comments=True)) for line in joined.splitlines()]
        blocks.append([c for c in commands if c])
    return blocks


def argv(command: str) -> list[str]:
    """A page command's argv in this venv: ``python``, ``drempower`` and LeRobot's commands are its own."""
    words = shlex.split(command)
    program = words[0]
    if program == "python":
        words[0] = sys.executable
    elif program == "drempower" or program.startswith("lerobot-"):
        words[0] = lerobot_command(program)
    else:
        pytest.fail(f"{PAGE.name}: {command!r}: a command this test does not know how to run")
    return words


def follower_degrees() -> dict[str, float]:
    """The follower twin's joints (deg at the joint), read over its socketcand server."""
    gears = {"shoulder": 2.0}
    with drempower.open_bus("socketcand", "can0", host="127.0.0.1", port=FOLLOWER_PORT, timeout=1.0) as bus:
        return {j: bus.motor(i + 1).get_state().angle / gears.get(j, 1.0) for i, j in enumerate(JOINTS)}


class Leader:
    """``python examples/leader_twin.py`` as the page starts it, with a keyboard: pushes and ``?``."""

    def __init__(self, words: list[str], cwd: Path) -> None:
        self.proc = subprocess.Popen(
            words, cwd=cwd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        )
        assert self.proc.stdout is not None
        first = self.proc.stdout.readline()
        assert "leader twin on socketcand 127.0.0.1 port 29537" in first, first

    def type(self, line: str) -> str:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        return self.proc.stdout.readline()

    def degrees(self) -> dict[str, float]:
        return {k: float(v) for k, v in (w.split("=") for w in self.type("?").split())}

    def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        try:
            assert self.proc.wait(10) == 0
        finally:
            if self.proc.poll() is None:
                self.proc.kill()


def _stop(run: Running, timeout: float = 60) -> None:
    """Ctrl-C, as a person ends a command of the page; it must end cleanly."""
    run.proc.send_signal(signal.SIGINT)
    try:
        run.proc.wait(timeout)
    except subprocess.TimeoutExpired:
        run.proc.kill()
        pytest.fail(f"{run.proc.args[0]} still running {timeout} s after Ctrl-C:\n{run.output[-3000:]}")


@pytest.mark.timeout(600)
def test_the_twin_recipes_run_as_written(tmp_path: Path) -> None:
    blocks = page_commands()
    assert [len(b) for b in blocks] == [3, 1, 3], blocks
    (teleop_block, record_block, replay_block) = blocks
    cwd = tmp_path / "work"
    shutil.copytree(REPO_ROOT / "examples", cwd / "examples")
    env = lerobot_env(tmp_path)

    def start(command: str) -> Running:
        return Running(argv(command), env, cwd=cwd)

    # 1. the leader twin, the follower twin, and teleoperation; pushes typed on the leader's keyboard
    leader = Leader(argv(teleop_block[0]), cwd)
    follower = start(teleop_block[1])
    try:
        follower.wait_for("Ctrl-C stops", 60)
        teleop = start(teleop_block[2])
        teleop.wait_for("Teleop loop time", 120)
        time.sleep(3.0)  # the loop's first iterations can stall on a loaded machine: push once it runs
        before = leader.degrees()
        assert leader.type("base_yaw 0.2 0.2").startswith("pushed base_yaw")
        assert leader.type("elbow 0.2 0.2").startswith("pushed elbow")
        time.sleep(4.0)
        led, followed = leader.degrees(), follower_degrees()
        moved = {j: led[j] - before[j] for j in JOINTS}
        print("leader moved", {j: round(v, 2) for j, v in moved.items()})
        print("follower - leader", {j: round(followed[j] - led[j], 3) for j in JOINTS})
        assert abs(moved["base_yaw"]) > 1 and abs(moved["elbow"]) > 0.3, teleop.output[-3000:]
        assert all(math.isclose(followed[j], led[j], abs_tol=TOLERANCE) for j in JOINTS), teleop.output[-3000:]
        _stop(teleop)

        # 2. an episode recorded from the same two twins, pushes typed while it records
        record = start(record_block[0])
        record.wait_for("Recording episode 0", 120)
        time.sleep(1.0)
        leader.type("base_yaw -0.2 0.2")
        record.finish(240)
    finally:
        leader.close()
        _stop(follower)
    dataset = LeRobotDataset("local/arm6-twins", root=cwd / "datasets" / "arm6-twins")
    assert dataset.num_episodes == 1 and dataset.num_frames >= 0.8 * 30 * 8, dataset.num_frames
    last = dataset[dataset.num_frames - 1]["action"].tolist()

    # 3. the follower twin served again, the dashboard watching it, the episode replayed on it
    follower = start(replay_block[0])
    try:
        follower.wait_for("Ctrl-C stops", 60)
        dash = start(replay_block[1])
        try:
            dash.wait_for("http://127.0.0.1:8811", 60)
            replay = start(replay_block[2])
            replay.finish(240)
            time.sleep(1.0)
            ended = follower_degrees()
        finally:
            _stop(dash)
    finally:
        _stop(follower)
    error = {j: ended[j] - last[i] for i, j in enumerate(JOINTS)}
    print("replayed follower - last action", {j: round(v, 3) for j, v in error.items()})
    assert all(abs(v) < TOLERANCE for v in error.values())
