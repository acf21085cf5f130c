"""``drempower record``: the file read back with rosbags; what it started is stopped."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest

from drempower.sim import SimBus

from ..cli.conftest import Cli

highlevel = pytest.importorskip("rosbags.highlevel")


def test_record_heartbeats_with_joint_names(sim: SimBus, tmp_path: Path, cli: Cli) -> None:
    out = tmp_path / "run.mcap"
    r = cli(
        "record", "1,2", "-o", str(out), "--heartbeat-ms", "10", "--duration", "0.5", "--names", "1=hip", "--sim", "1,2"
    )
    assert r.code == 0, r.err
    assert "0 frames lost" in r.err
    with highlevel.AnyReader([out]) as reader:
        names = Counter(
            reader.deserialize(raw, c.msgtype).name[0] for c, _, raw in reader.messages() if c.topic == "/joint_states"
        )
    # time runs 20x faster in these tests: 0.5 s wall is ~10 s simulated, ~1000 heartbeats each
    assert names["hip"] > 100 and names["motor_2"] > 100 and set(names) == {"hip", "motor_2"}
    assert [m.param(21004) for m in sim.motors.values()] == [0, 0, 0]  # heartbeats set back to 0


def test_record_polls_states(sim: SimBus, tmp_path: Path, cli: Cli) -> None:
    out = tmp_path / "poll.mcap"
    r = cli("record", "3", "-o", str(out), "--poll", "50", "--duration", "0.3", "--json", "--sim", "3")
    (summary,) = r.records()
    assert r.code == 0 and summary["frames_lost"] == 0 and summary["output"] == str(out)
    recs = cli("decode", "--json", str(out)).records()
    kinds = Counter((x["direction"], x["command"]) for x in recs)
    assert kinds[("host", "fast_read")] >= 5 and kinds[("motor", "state")] == kinds[("host", "fast_read")]
    assert summary["states"] == kinds[("motor", "state")] and summary["frames_written"] == len(recs)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["-o", "x.csv", "--sim", "1"], "must end in .mcap"),
        (["-o", "x.mcap", "--poll", "10", "--sim", "1"], "need the motor IDS"),
        (["1", "-o", "x.mcap", "--heartbeat-ms", "0", "--sim", "1"], "whole number >= 1"),
        (["1", "-o", "x.mcap", "--heartbeat-ms", "5000", "--sim", "1"], "allowed 1..1000"),
        (["-o", "x.mcap", "--names", "99=a", "--sim", "1"], "ID 1..63"),
    ],
)
def test_record_usage_errors(
    argv: list[str], message: str, tmp_path: Path, cli: Cli, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    r = cli("record", *argv)
    assert r.code == 2 and message in r.err and "Traceback" not in r.err
    assert not (tmp_path / "x.mcap").exists()


def test_record_serves_foxglove_on_a_free_port(sim: SimBus, tmp_path: Path, cli: Cli) -> None:
    pytest.importorskip("foxglove")
    r = cli(
        "record",
        "1",
        "-o",
        str(tmp_path / "f.mcap"),
        "--poll",
        "20",
        "--duration",
        "0.3",
        "--foxglove",
        "0",
        "--sim",
        "1",
    )
    assert r.code == 0, r.err
    port = int(r.err.split("ws://127.0.0.1:")[1].split()[0])
    assert 0 < port < 65536
    assert cli("record", "-o", str(tmp_path / "g.mcap"), "--foxglove", "70000", "--sim", "1").code == 2
