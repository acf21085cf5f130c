"""``drempower replay``: host frames of a log onto the (simulated) bus, paced, motors stopped at the end."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from drempower.protocol import FastRead, PositionQ, WriteParam, decode_command
from drempower.protocol.ids import Frame
from drempower.sim import SimBus

from ..cli.conftest import Cli


def _line(t: float, f: Frame, tx: bool = True) -> str:
    return f"({t:.6f}) can0 {f.arbitration_id:03X}#{f.data.hex().upper()}{' T' if tx else ''}\n"


def test_replay_sends_host_frames_at_the_recorded_pace(
    sim: SimBus, host_frames: list[Frame], tmp_path: Path, cli: Cli
) -> None:
    q = PositionQ(2, 90.0, 300.0, 300.0).encode()
    log = tmp_path / "run.log"
    log.write_text(
        _line(100.0, q)
        + "(100.000400) can0 043#0000B4420000E803\n"  # a state reply: not replayed
        + _line(101.0, FastRead(2).encode())
    )
    t = time.monotonic()
    r = cli("replay", str(log), "--speed", "4", "--sim", "2")
    took = time.monotonic() - t
    assert r.code == 0, r.err
    assert "2 frames replayed" in r.err
    assert 0.25 <= took < 5.0
    sent = [decode_command(*f[:2]) for f in host_frames]
    first = sent.index(decode_command(*q[:2]))  # after the check that motor 2 is in closed loop: reads only
    assert not any(isinstance(m, WriteParam) for m in sent[:first])
    sent = sent[first:]
    assert sent[:2] == [decode_command(*q[:2]), FastRead(2)]
    # the motor it commanded is put into IDLE when the replay ends
    assert isinstance(sent[2], WriteParam) and (sent[2].node, sent[2].address, sent[2].value) == (2, 30003, 1)
    assert abs(sim.motors[2].position - 90.0) < 1.0


def test_all_frames_and_rate(sim: SimBus, host_frames: list[Frame], tmp_path: Path, cli: Cli) -> None:
    log = tmp_path / "x.log"
    log.write_text("039#0000B4420000E803\n023#0000B9C2D204C8FF\n")  # no timestamps
    r = cli("replay", str(log), "--sim", "1")
    assert r.code == 1 and "no timestamps; give --rate" in r.err
    assert cli("replay", str(log), "--rate", "100", "--all-frames", "--leave-running", "--sim", "1").code == 0
    assert [f.arbitration_id for f in host_frames][-2:] == [0x039, 0x023]  # after the check's reads


def test_sigterm_ends_replay_and_reports(tmp_path: Path) -> None:
    log = tmp_path / "long.log"
    log.write_text("".join(_line(i * 0.5, PositionQ(1, float(i), 60.0, 300.0).encode()) for i in range(40)))
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "drempower", "replay", str(log)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    assert proc.stderr is not None
    assert "replaying onto simulated motors" in proc.stderr.readline()  # started: its signal handlers are in
    time.sleep(1.0)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 128 + signal.SIGTERM and "replay interrupted after" in err and "Traceback" not in err


def test_json_summary(sim: SimBus, tmp_path: Path, cli: Cli) -> None:
    log = tmp_path / "j.log"
    log.write_text(_line(1.0, FastRead(1).encode()) + "(1.000200) can0 023#0000000000000000\n")
    (rec,) = cli("replay", str(log), "--json", "--sim", "1").records()
    assert rec == {"file": str(log), "frames_sent": 1, "frames_in_log": 2}
