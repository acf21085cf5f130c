"""Logs that cannot be read, a basic install without the records extra, and replay onto idle motors."""

from __future__ import annotations

import builtins
import random
from pathlib import Path
from typing import Any

import can
import pytest

from drempower.protocol.ids import StartKind
from drempower.protocol.messages import Preset, Start
from drempower.sim import SimBus

from .conftest import Cli


def _frames(target: float = 30.0, seconds: float = 1.0) -> list[can.Message]:
    preset = Preset(1, target, seconds, 10.0).encode()
    start = Start(0, StartKind.Q).encode()
    out = []
    for k in range(20):
        f = preset if k % 2 == 0 else start
        out.append(can.Message(timestamp=k * 0.01, arbitration_id=f[0], data=f[1], is_extended_id=False, is_rx=False))
    return out


def _blf(path: Path, frames: list[can.Message] | None = None) -> Path:
    with can.BLFWriter(str(path)) as w:
        for m in _frames() if frames is None else frames:
            w.on_message_received(m)
    return path


def _mcap(cli: Cli, path: Path) -> Path:
    r = cli("record", "1", "-w", str(path), "--poll", "50", "--duration", "0.3", "--sim", "1")
    assert r.code == 0, r.err
    return path


def _damaged(data: bytes, rng: random.Random) -> bytes:
    b = bytearray(data)
    if rng.random() < 0.4:
        return bytes(b[: rng.randrange(1, len(b))])  # truncated
    for _ in range(rng.randint(1, 8)):  # flipped bytes
        i = rng.randrange(len(b))
        b[i] ^= 1 << rng.randrange(8)
    return bytes(b)


@pytest.mark.parametrize("kind", ["blf", "mcap"])
def test_damaged_logs_are_one_line_never_a_traceback(cli: Cli, tmp_path: Path, kind: str) -> None:
    pytest.importorskip("mcap_ros2")
    good = _blf(tmp_path / "good.blf") if kind == "blf" else _mcap(cli, tmp_path / "good.mcap")
    data = good.read_bytes()
    rng = random.Random(11)
    refused = 0
    for k in range(30):
        bad = tmp_path / f"bad{k}.{kind}"
        bad.write_bytes(_damaged(data, rng))
        for command in ("decode", "replay"):
            argv = [command, str(bad)] + (["--rate", "10000", "--sim", "1"] if command == "replay" else [])
            r = cli(*argv)  # an exception other than SystemExit fails the test here
            assert r.code in (0, 1, 2) and "Traceback" not in r.err, r.err
            if r.code == 2:
                refused += 1
                assert len(r.err.strip().splitlines()) == 1 and str(bad) in r.err, r.err
    assert refused > 0  # some damage is noticed, and said in one line


def test_record_without_the_records_extra_is_one_line(
    cli: Cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real = builtins.__import__

    def no_mcap(name: str, *args: Any, **kwargs: Any) -> Any:
        if name.startswith(("mcap", "mcap_ros2")):
            raise ImportError(f"No module named {name!r}")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_mcap)
    r = cli("record", "-w", str(tmp_path / "x.mcap"), "--duration", "0.1", "--sim", "1")
    assert r.code == 2 and "Traceback" not in r.err and len(r.err.strip().splitlines()) == 1, r.err
    assert "pip install 'drempower[records]'" in r.err


def test_replay_onto_idle_motors_says_so_and_sends_nothing(cli: Cli, sim: SimBus, tmp_path: Path) -> None:
    log = _blf(tmp_path / "moves.blf")
    assert cli("idle", "1", "--sim", "1").code == 0
    r = cli("replay", str(log), "--rate", "1000", "--sim", "1")
    assert r.code == 1 and "motor 1 is idle (not in closed loop)" in r.err and "--enable" in r.err, r.err
    assert "replayed" not in r.err and sim.motors[1].param("axis0.controller.input_pos") == 0
    r = cli("replay", str(log), "--rate", "1000", "--enable", "--leave-running", "--sim", "1")
    assert r.code == 0 and "20 frames replayed" in r.err, r.err
    assert sim.motors[1].param("axis0.controller.input_pos") > 0.1  # on its way to 30 deg


@pytest.mark.parametrize("seconds", [0.0, 1.0])
def test_replay_of_a_tiny_preset_target_is_no_traceback(cli: Cli, sim: SimBus, tmp_path: Path, seconds: float) -> None:
    """A preset to 1e-20 deg (in 0 s or 1 s) replayed onto a simulated motor: it stays put, the replay ends
    normally and the simulator answers after it."""
    log = _blf(tmp_path / "tiny.blf", _frames(1e-20, seconds))
    r = cli("replay", str(log), "--rate", "1000", "--sim", "1")
    assert r.code == 0 and "Traceback" not in r.err and "20 frames replayed" in r.err, r.err
    assert abs(sim.motors[1].position) < 1e-6
    assert cli("state", "1", "--sim", "1").code == 0
