"""``lerobot-record`` of a short episode (the leader driving the follower, both twins of the example arm,
no camera, no hub) into a local dataset that ``LeRobotDataset`` loads with the features, the number of
frames and the values expected; then ``lerobot-replay`` plays its actions on a fresh follower twin."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

pytest.importorskip("lerobot", reason="LeRobot is not installed here: make test-lerobot runs these")

from lerobot.datasets.lerobot_dataset import LeRobotDataset

from .conftest import JOINTS, TIMEOUT, Running, lerobot_command, lerobot_env, served_arms

FPS = 30
SECONDS = 5.0
"""The episode's length (--dataset.episode_time_s)."""
REPO = "local/drempower_arm6"
TOLERANCE = 0.5
"""deg: recorded positions against the twins' (the arms at rest), the replayed follower against the actions."""
PUSHES = {"base_yaw": 1.0, "elbow": 1.0, "wrist_pitch": 0.3}
"""Nm on the leader's joints for 0.2 s, when the episode starts."""


@pytest.mark.timeout(400)
def test_record_an_episode_load_it_and_replay_it(tmp_path: Path) -> None:
    root = tmp_path / "dataset"
    env = lerobot_env(tmp_path)
    with served_arms(tmp_path, ("leader", "follower", "replayed")) as arms:
        leader, follower, replayed = arms["leader"], arms["follower"], arms["replayed"]
        run = Running(
            [
                lerobot_command("lerobot-record"),
                "--robot.type=drempower",
                f"--robot.timeout={TIMEOUT}",
                f"--robot.robot_file={follower.robot_file}",
                "--robot.observe_speeds=true",
                "--robot.observe_torques=true",
                "--robot.id=follower",
                "--teleop.type=drempower_leader",
                f"--teleop.timeout={TIMEOUT}",
                f"--teleop.robot_file={leader.robot_file}",
                "--teleop.id=leader",
                f"--dataset.repo_id={REPO}",
                f"--dataset.root={root}",
                "--dataset.single_task=follow the leader",
                f"--dataset.fps={FPS}",
                f"--dataset.episode_time_s={SECONDS}",
                "--dataset.reset_time_s=0",
                "--dataset.num_episodes=1",
                "--dataset.video=false",
                "--dataset.push_to_hub=false",
                "--play_sounds=false",
            ],
            env,
        )
        started = run.wait_for("Recording episode 0", 120)
        for joint, torque in PUSHES.items():
            leader.twin.push_joint(joint, torque=torque, duration=0.2)
        time.sleep(max(0.0, started + SECONDS - 1.0 - time.monotonic()))  # 1 s before the episode ends
        led, followed = leader.degrees(), follower.degrees()
        output = run.finish(200)

        ds = LeRobotDataset(REPO, root=root)
        state_names = [f"{j}{k}" for j in JOINTS for k in (".pos", ".vel", ".torque")]
        action_names = [f"{j}.pos" for j in JOINTS]
        assert ds.features["observation.state"]["names"] == state_names
        assert ds.features["observation.state"]["dtype"] == "float32"
        assert tuple(ds.features["observation.state"]["shape"]) == (18,)
        assert ds.features["action"]["names"] == action_names
        assert ds.features["action"]["dtype"] == "float32"
        assert tuple(ds.features["action"]["shape"]) == (6,)
        assert ds.meta.robot_type == "drempower" and ds.fps == FPS and ds.num_episodes == 1
        frames = ds.num_frames
        slow = output.count("Record loop is running slower")
        print(
            f"{frames} frames in {SECONDS} s at {FPS} fps asked: {frames / SECONDS:.2f} fps recorded "
            f"({frames / (FPS * SECONDS):.1%} of the frames asked; {slow} late frames logged)"
        )
        assert 0.9 * FPS * SECONDS <= frames <= FPS * SECONDS + 1
        first, last = ds[0], ds[frames - 1]
        assert ds[frames - 1]["timestamp"].item() == pytest.approx((frames - 1) / FPS, abs=1e-4)
        state = {n: float(v) for n, v in zip(state_names, last["observation.state"], strict=True)}
        action = {n: float(v) for n, v in zip(action_names, last["action"], strict=True)}
        start = {n: float(v) for n, v in zip(state_names, first["observation.state"], strict=True)}
        moved = {j: state[f"{j}.pos"] - start[f"{j}.pos"] for j in JOINTS}
        print("recorded follower moved (deg): " + ", ".join(f"{j} {moved[j]:+.2f}" for j in JOINTS))
        assert all(abs(moved[j]) > 5.0 for j in PUSHES), moved
        for j in JOINTS:  # the arms were at rest over the last second
            assert state[f"{j}.pos"] == pytest.approx(followed[j], abs=TOLERANCE), j
            assert action[f"{j}.pos"] == pytest.approx(led[j], abs=TOLERANCE), j
            assert abs(state[f"{j}.vel"]) < 2.0, j

        replay = Running(
            [
                lerobot_command("lerobot-replay"),
                "--robot.type=drempower",
                f"--robot.timeout={TIMEOUT}",
                f"--robot.robot_file={replayed.robot_file}",
                "--robot.id=replayed",
                f"--dataset.repo_id={REPO}",
                f"--dataset.root={root}",
                "--dataset.episode=0",
                f"--dataset.fps={FPS}",
                "--play_sounds=false",
            ],
            env,
        )
        replay.finish(200)
        time.sleep(0.5)  # the last target's filter settles
        ended = replayed.degrees()
    error = {j: ended[j] - action[f"{j}.pos"] for j in JOINTS}
    print("replayed follower - last action (deg): " + ", ".join(f"{j} {error[j]:+.3f}" for j in JOINTS))
    assert max(abs(e) for e in error.values()) < TOLERANCE, error
