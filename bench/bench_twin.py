#!/usr/bin/env python3
"""Robot twin speed: the 6-joint arm on MuJoCo at a 1 kHz physics step, beside the floor.

Run: ``python3 bench/bench_twin.py [--seconds S]``. Prints figures; asserts nothing.

Real-time factors are simulated seconds per CPU second (1.0: the simulation just
keeps real time on one core), so that other load on the machine does not count.

* floor: MuJoCo stepping ``examples/robots/arm6.xml`` alone (no motors, no protocol);
* in-process: the six simulated motors' controllers, each step, on the twin
  (a 1 Mbit/s bus, a host reading every joint's state every 10 ms, moves going on);
* ``drempower sim --robot``: the same robot served (socketcand, as ``sim`` writes it), a client
  moving it and reading its six joints at 100 Hz (the server process's CPU time);
* the shadow twin (``robot.shadow()``) beside the arm on its twin (virtual clock), a 200 Hz control
  loop (``robot.follow``) and states every 5 ms: the CPU time of the shadow's own work;
* client ``cycle`` of the six joints (T command, state reply) on the twin at
  1 Mbit/s, as a share of the bus limit (the bits one cycle puts on the wire).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python" / "src"))

from bench_client import FineClock, cycle_bits

import drempower
from drempower.client.engine.commands import PositionMode
from drempower.protocol import FastRead, PositionT
from drempower.robot import load_robot
from drempower.sim import SimBus
from drempower.sim.twin import couple_robot

ROOT = Path(__file__).resolve().parent.parent
ARM = ROOT / "examples" / "robots" / "arm6.toml"
BITRATE = 1_000_000
POSES = ((0.0, 0.6, 0.9, 0.0, 0.5, 0.0), (0.8, -0.4, 1.2, 1.0, -0.6, 1.5))
"""Joint angles (rad) the arm moves between."""


def floor(seconds: float) -> float:
    """Simulated seconds per CPU second of MuJoCo alone on the arm's model."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(ARM.parent / "arm6.xml"))
    model.opt.timestep = 0.001
    data = mujoco.MjData(model)
    steps = round(seconds / 0.001)
    t0 = time.process_time()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return seconds / (time.process_time() - t0)


def _angles(k: int) -> list[float]:
    spec = load_robot(ARM)
    return [math.degrees(a * j.gear) for a, j in zip(POSES[k % 2], spec.joints.values(), strict=True)]


def in_process(seconds: float) -> tuple[float, float]:
    """Simulated seconds per CPU second of the twin with its six motors, and the bus load."""
    spec = load_robot(ARM)
    sim = SimBus(range(1, 7), bitrate=BITRATE)
    couple_robot(spec, {"arm": sim})
    reads = [FastRead(i).encode() for i in range(1, 7)]
    t0 = time.process_time()
    for k in range(round(seconds / 0.01)):
        if k % 100 == 0:
            for i, angle in enumerate(_angles(k // 100), start=1):
                sim.send(PositionT(i, angle, 10.0).encode())
        for f in reads:
            sim.send(f)
        sim.advance(0.01)
    return seconds / (time.process_time() - t0), sim.stats.utilisation


def _cpu(pid: int) -> float:
    """CPU seconds (user + system) used so far by process ``pid`` (Linux)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def served(seconds: float) -> float | None:
    """Simulated seconds per CPU second of ``drempower sim --robot`` serving the arm (None off Linux)."""
    if not Path("/proc/self/stat").exists():
        return None
    cmd = [sys.executable, "-m", "drempower", "sim", "--robot", str(ARM), "--json"]
    env = {**os.environ, "PYTHONPATH": str(ROOT / "python" / "src")}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True, env=env)
    try:
        assert proc.stdout is not None
        path = ready = None
        for line in proc.stdout:
            record = json.loads(line)
            path = record.get("path", path)
            ready = record.get("robot_file", ready)
            if record.get("running"):
                break
        robot_file = Path(os.environ.get("TMPDIR", "/tmp")) / f"bench-twin-{os.getpid()}.toml"
        if path is None and ready is not None:  # a sim bus is served over socketcand: the file sim wrote
            robot_file.write_text(Path(ready).read_text())
        else:
            spec_text = ARM.read_text().replace('interface = "sim"', f'interface = "adapter"\nchannel = "{path}"')
            spec_text = spec_text.replace('file = "arm6.xml"', f'file = "{ARM.parent / "arm6.xml"}"')
            robot_file.write_text(spec_text.replace("bitrate = 1000000\n", ""))
        try:
            with drempower.open_robot(robot_file, timeout=1.0, stop_on_close=False) as robot:
                cpu0, t0 = _cpu(proc.pid), time.perf_counter()
                k = 0
                while time.perf_counter() - t0 < seconds:
                    if k % 100 == 0:
                        robot.set_angles(
                            dict(zip(robot.joints, _angles(k // 100), strict=True)), 0.0, 10.0, PositionMode.T
                        )
                    robot.get_states()
                    k += 1
                    time.sleep(max(0.0, t0 + k * 0.01 - time.perf_counter()))
                wall, cpu = time.perf_counter() - t0, _cpu(proc.pid) - cpu0
        finally:
            robot_file.unlink(missing_ok=True)
        return wall / cpu if cpu > 0 else math.inf
    finally:
        proc.terminate()
        proc.wait(10)


def cycle_rate(seconds: float, twin: bool) -> float:
    """Cycles per second of the six joints at 1 Mbit/s, on the twin or on the plain simulator."""
    sim = SimBus(range(1, 7), bitrate=BITRATE)
    if twin:
        couple_robot(load_robot(ARM), {"arm": sim})
    with FineClock(sim), drempower.open_bus("sim", bus=sim, time_scale=0, stop_on_close=False) as bus:
        motors = [bus.motor(i) for i in range(1, 7)]
        for m in motors:
            m.enable_reply_state(True)
        done = 0
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            angles = _angles(done // 500)
            bus.cycle([m.make_angle(a, 0, 10) for m, a in zip(motors, angles, strict=True)], reply_state=True)
            done += 1
        return done / (time.perf_counter() - t0)


def shadow_speed(seconds: float) -> tuple[float, float, int]:
    """The shadow twin beside the arm (its twin on the virtual clock) following an excitation at 200 Hz
    (``robot.follow``), the motors reporting every 5 ms: simulated seconds per CPU second of the shadow's
    own work (its six motors and MuJoCo at 1 kHz, every frame taken and compared), the simulated seconds,
    and the divergences it flagged (false alarms: the model is the robot's own)."""
    from drempower.motion.trajectory import Trajectory
    from drempower.robot.shadow import Shadow

    class Timed(Shadow):
        cpu = 0.0

        def _tap(self, bus: str, frame: Any, tx: bool) -> None:
            t0 = time.thread_time()
            try:
                super()._tap(bus, frame, tx)
            finally:
                self.cpu += time.thread_time() - t0

    with drempower.open_robot(ARM, sim={"clock": "virtual"}) as robot:
        bus = robot.buses["arm"]
        sim = bus.transport.bus  # type: ignore[attr-defined]
        for j in robot.spec.joints.values():
            bus.motor(j.id).write_property("can.config.heartbeat_ms", 5)
        with Timed(robot, clock=lambda: sim.now) as shadow:
            t0 = sim.now
            robot.follow(Trajectory.excitation(list(robot.spec.joints), seconds, amplitude=0.3))
            simulated = sim.now - t0
    return simulated / shadow.cpu, simulated, len(shadow.events)


def twin_fit(seconds: float) -> dict[str, object] | None:
    """Record the hidden-truth arm (tests/sim/twin/fit_support.py) for ``seconds`` s on the virtual clock, time one
    replay (CPU s per recorded s) and a fit of all six joints (wall s); the largest error against the truth."""
    try:
        import scipy  # noqa: F401

        sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python"))
        from tests.sim.twin.fit_support import TRUTH, record, truth_robot
    except ImportError:
        return None
    import tempfile

    from drempower.errors import ValidationError
    from drempower.sim.twin_fit import fit_twin
    from drempower.sim.twin_replay import Replay, load_recording

    arm = load_robot(str(Path(__file__).resolve().parent.parent / "examples" / "robots" / "arm6.toml"))
    with tempfile.TemporaryDirectory() as tmp:
        path = record(truth_robot(Path(tmp)), Path(tmp) / "fit.mcap", seconds, kd=0.05)  # the documented kd
        rec = load_recording(path, arm)
        replay = Replay(arm, rec)
        t0 = time.process_time()
        replay.run()
        per_s = (time.process_time() - t0) / rec.duration
        t0 = time.perf_counter()
        try:
            result = fit_twin(arm, [rec], max_rel_error=1.0)  # every value, with its uncertainty
        except ValidationError as exc:  # a parameter at its bound
            return {"replay_cpu_per_s": per_s, "refused": str(exc)}
        took = time.perf_counter() - t0
    worst = max(abs(result.joints[j][p] / v - 1.0) for j, values in TRUTH.items() for p, v in values.items())
    return {
        "replay_cpu_per_s": per_s,
        "fit_s": took,
        "worst": worst,
        "evaluations": result.evaluations,
        "seconds": rec.duration,
        "cpu_s": result.cpu_seconds,
        "errors": {j: {p: result.joints[j][p] / v - 1.0 for p, v in values.items()} for j, values in TRUTH.items()},
        "uncertainty": result.uncertainty,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="seconds per figure (default 5)")
    parser.add_argument(
        "--fit-seconds", type=float, default=20.0, help="the twin fit's recording (default 20 s; 0: no fit figure)"
    )
    args = parser.parse_args()
    try:
        import mujoco
    except ImportError:
        print("bench_twin: MuJoCo is not installed (pip install 'drempower[physics]'); nothing to measure")
        return
    print(f"Python {platform.python_version()}, MuJoCo {mujoco.__version__}, {os.cpu_count()} CPUs; 1 kHz physics step")
    base = floor(args.seconds)
    print(f"  {'floor: MuJoCo alone on arm6.xml':<46} {base:7.1f} x real time")
    rtf, load = in_process(args.seconds)
    what = "in-process: 6 motors' controllers + MuJoCo"
    print(f"  {what:<46} {rtf:7.1f} x real time (goal >= 1.0; floor {base:.1f}; bus load {load:.0%})")
    cpu_rtf = served(args.seconds)
    if cpu_rtf is not None:
        what = "drempower sim --robot, client at 100 Hz"
        print(f"  {what:<46} {cpu_rtf:7.1f} x real time (goal >= 1.0)")
    rtf, simulated, alarms = shadow_speed(max(args.seconds, 5.0))
    what = "shadow twin beside the arm, 200 Hz control loop"
    print(
        f"  {what:<46} {rtf:7.1f} x real time (goal >= 1.0; floor {base:.1f}); "
        f"{alarms} false alarm(s) in {simulated:.1f} s"
    )
    limit = BITRATE / cycle_bits(6, True)
    rates: dict[bool, list[float]] = {False: [], True: []}
    for _ in range(3):  # alternating, best of three: other load on the machine only slows a run down
        for twin in (False, True):
            rates[twin].append(cycle_rate(args.seconds / 3, twin))
    plain, rate = max(rates[False]), max(rates[True])
    what = "client cycle of 6 joints at 1 Mbit/s"
    print(f"  {what:<46} {rate:7.0f} /s, bus limit {limit:.0f} /s: {rate / limit:.1%} (goal >= 80 %)")
    what = "the same on the plain simulator (no physics)"
    print(f"  {what:<46} {plain:7.0f} /s: {plain / limit:.1%}")
    if args.fit_seconds > 0:
        fit = twin_fit(args.fit_seconds)
        if fit is None:
            print("  twin fit: needs scipy (pip install 'drempower[fit]') and the tests' folder")
            return
        what = "twin fit: one replay of a recording"
        print(f"  {what:<46} {fit['replay_cpu_per_s']:7.3f} CPU s per recorded s")
        if "refused" in fit:
            print(f"  twin fit of 6 joints: refused: {fit['refused']}")
            return
        what = f"twin fit of 6 joints, {fit['seconds']:.0f} s recording"
        print(
            f"  {what:<46} {fit['fit_s']:7.1f} s wall, {fit['evaluations']} replays (goal < 300 s); "
            f"worst parameter {fit['worst']:.1%} from the truth"
        )
        errors: dict[str, dict[str, float]] = fit["errors"]  # type: ignore[assignment]
        uncertain: dict[str, dict[str, float]] = fit["uncertainty"]  # type: ignore[assignment]
        for joint, row in errors.items():  # a value uncertain by more than 20 % twin fit refuses (--max-error)
            shown = ", ".join(f"{p} {e:+.1%} (±{uncertain[joint][p]:.0%})" for p, e in row.items())
            print(f"    {joint:<12} {shown}")


if __name__ == "__main__":
    main()
