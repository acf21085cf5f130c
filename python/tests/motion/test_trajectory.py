"""Trajectories: interpolation exact on polynomials, validation, time parameterisation within limits, files."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from drempower.errors import ValidationError
from drempower.motion import Trajectory


def _cubic(t: float) -> tuple[float, float]:
    return 1.0 - 2.0 * t + 0.5 * t**2 + 0.3 * t**3, -2.0 + t + 0.9 * t**2


def _quintic(t: float) -> tuple[float, float, float]:
    c = (0.2, -1.0, 0.5, 0.7, -0.4, 0.06)
    p = sum(k * t**i for i, k in enumerate(c))
    v = sum(i * k * t ** (i - 1) for i, k in enumerate(c) if i)
    a = sum(i * (i - 1) * k * t ** (i - 2) for i, k in enumerate(c) if i > 1)
    return p, v, a


def test_cubic_hermite_is_exact_on_a_cubic() -> None:
    times = [0.0, 0.4, 1.1, 2.0]
    tr = Trajectory(times, [[_cubic(t)[0]] for t in times], [[_cubic(t)[1]] for t in times])
    for k in range(41):
        t = k * 0.05
        s = tr.sample(t)
        assert s.positions[0] == pytest.approx(_cubic(t)[0], abs=1e-12)
        assert s.velocities[0] == pytest.approx(_cubic(t)[1], abs=1e-12)


def test_quintic_is_exact_on_a_quintic() -> None:
    times = [0.0, 0.7, 1.5, 2.5]
    rows = [_quintic(t) for t in times]
    tr = Trajectory(times, [[r[0]] for r in rows], [[r[1]] for r in rows], [[r[2]] for r in rows])
    for k in range(51):
        t = k * 0.05
        s = tr.sample(t)
        p, v, a = _quintic(t)
        assert s.positions[0] == pytest.approx(p, abs=1e-11)
        assert s.velocities[0] == pytest.approx(v, abs=1e-10)
        assert s.accelerations[0] == pytest.approx(a, abs=1e-9)


def test_spline_from_rest_to_rest_is_exact_and_c2() -> None:
    """Without velocities: the C2 spline at rest at both ends reproduces the smoothstep 3t^2 - 2t^3 exactly."""
    times = [0.0, 0.3, 0.5, 0.8, 1.0]
    tr = Trajectory(times, {"a": [3 * t**2 - 2 * t**3 for t in times]})
    assert tr.joints == ("a",)
    for k in range(21):
        t = k * 0.05
        assert tr.sample(t).positions[0] == pytest.approx(3 * t**2 - 2 * t**3, abs=1e-12)
    # continuity of the acceleration at an interior knot, on a path that is no polynomial
    tr2 = Trajectory([0.0, 1.0, 1.5, 3.0], [[0.0], [1.0], [-0.5], [0.2]])
    left, right = tr2.sample(1.5 - 1e-9), tr2.sample(1.5 + 1e-9)
    assert left.accelerations[0] == pytest.approx(right.accelerations[0], abs=1e-5)
    assert tr2.sample(0.0).velocities[0] == 0.0 and tr2.sample(3.0).velocities[0] == pytest.approx(0.0, abs=1e-12)
    assert tr2.sample(5.0).positions == [pytest.approx(0.2)]  # held after the end


@pytest.mark.parametrize(
    ("times", "positions", "words"),
    [
        ([0.0], [[0.0]], "at least 2 times"),
        ([0.5, 1.0], [[0.0], [1.0]], "times[0]=0.5: a trajectory starts at 0 s"),
        ([0.0, 1.0, 1.0], [[0.0], [1.0], [2.0]], "times[2]=1.0: must be above times[1]=1.0"),
        ([0.0, math.nan], [[0.0], [1.0]], "times[1]=nan: expected a finite number"),
        ([0.0, 1.0], [[0.0, 1.0], [1.0]], "positions[1]: 1 values, but row 0 has 2"),
        ([0.0, 1.0], [[0.0], [math.inf]], "positions[1][0]=inf: expected a finite number"),
        ([0.0, 1.0], [[0.0]], "positions: 1 rows for 2 times"),
        ([0.0, 1.0], {"a": [0.0]}, "positions['a']: 1 values for 2 times"),
    ],
)
def test_bad_input_names_the_field_and_value(times: list[float], positions: object, words: str) -> None:
    with pytest.raises(ValidationError) as err:
        Trajectory(times, positions)  # type: ignore[arg-type]
    assert words in str(err.value)


def test_from_waypoints_respects_each_joints_limits() -> None:
    waypoints = [[0.0, 0.0, 0.0], [1.0, -0.2, 0.05], [1.0, 0.6, -2.0], [-0.5, 0.6, -2.0]]
    vmax, amax = [1.0, 0.5, 2.0], [2.0, 4.0, 3.0]
    tr = Trajectory.from_waypoints(waypoints, max_speed=vmax, max_accel=amax, joints=["a", "b", "c"])
    peaks = tr.peaks(0.0005)
    for j in range(3):
        assert peaks.speed[j] <= vmax[j] * (1 + 1e-9)
        assert peaks.accel[j] <= amax[j] * (1 + 1e-9)
    # every waypoint is reached, at rest
    for row in waypoints:
        hits = [k for k, p in enumerate(tr.positions) if p == pytest.approx(row)]
        assert hits and all(v == pytest.approx([0.0] * 3) for v in (tr.velocities[k] for k in hits))
    # each segment is as short as its limiting joint allows: one joint reaches its limit
    assert max(peaks.speed[j] / vmax[j] for j in range(3)) == pytest.approx(1.0, rel=1e-6) or max(
        peaks.accel[j] / amax[j] for j in range(3)
    ) == pytest.approx(1.0, rel=1e-6)
    # a short move is a triangle: 1 rad at 4 rad/s^2 under a high speed limit takes 2 sqrt(1/4) = 1 s
    tri = Trajectory.from_waypoints([[0.0], [1.0]], max_speed=10.0, max_accel=4.0)
    assert tri.duration == pytest.approx(1.0)


def test_from_waypoints_refuses_bad_limits() -> None:
    with pytest.raises(ValidationError, match=r"max_speed\['b'\]=0: expected > 0"):
        Trajectory.from_waypoints({"a": [0, 1], "b": [0, 1]}, max_speed={"a": 1.0, "b": 0}, max_accel=1.0)


def _same(a: Trajectory, b: Trajectory) -> None:
    assert a.joints == b.joints
    for k in range(31):
        t = a.duration * k / 30
        assert a.sample(t).positions == pytest.approx(b.sample(t).positions, abs=1e-9)


@pytest.mark.parametrize("ext", [".csv", ".json", ".mcap"])
def test_file_round_trip(tmp_path: Path, ext: str) -> None:
    pytest.importorskip("mcap_ros2")
    tr = Trajectory.from_waypoints(
        {"shoulder": [0.0, 0.8, -0.3], "elbow": [0.0, -0.5, 0.4]}, max_speed=1.2, max_accel=3.0
    )
    path = tmp_path / f"path{ext}"
    tr.save(path)
    back = Trajectory.load(path)
    _same(tr, back)


def test_csv_with_positions_only(tmp_path: Path) -> None:
    path = tmp_path / "p.csv"
    path.write_text("t,a,b\n0,0,1\n0.5,0.2,1.1\n1.0,0.4,1.0\n")
    tr = Trajectory.load(path)
    assert tr.joints == ("a", "b") and tr.duration == 1.0
    bad = tmp_path / "bad.csv"
    bad.write_text("time,a\n0,0\n1,1\n")
    with pytest.raises(ValidationError, match="no 't' column"):
        Trajectory.load(bad)


def test_a_recorded_session_plays_back_as_a_trajectory(tmp_path: Path) -> None:
    """The /joint_states of a recording of a moving simulated motor read back as its path, at the joint."""
    pytest.importorskip("mcap_ros2")
    import drempower
    from drempower.client.engine.effects import sleep
    from drempower.records import Recorder

    path = tmp_path / "session.mcap"
    with drempower.open_bus("sim", motors=[1]) as bus, Recorder(path, names={1: "swing"}) as rec:
        rec.attach(bus)
        motor = bus.motor(1)
        seen = []
        for k in range(50):
            motor.set_angle(20.0 * math.sin(k / 10), 0.0, 50.0, 0)
            seen.append(motor.get_state().angle)
            bus.run(sleep(0.01))  # real time: the recording stamps frames on the host clock
    tr = Trajectory.load(path)
    assert tr.joints == ("swing",)
    assert 0.3 < tr.duration < 3.0
    lo, hi = min(seen), max(seen)
    peaks = tr.peaks(0.01)
    assert math.degrees(peaks.low[0]) == pytest.approx(lo, abs=0.5)
    assert math.degrees(peaks.high[0]) == pytest.approx(hi, abs=0.5)
