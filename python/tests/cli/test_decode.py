"""``drempower decode`` on candump lines."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from drempower.cli import main
from drempower.errors import ProtocolError
from drempower.protocol.candump import parse_candump_line

LOG = """\
(1700000000.123456) can0 039#0000B4420000E803
03A#000016C3E803F401
  can0  068   [8]  06 00 00 00 00 00 00 00
(1700000000.2) can0 09E#7794000038F0B8C2
023#0000B4420000E803
not a frame at all
03A#0000
12345678#0102
039#R
"""


def test_parse_forms() -> None:
    a = parse_candump_line("(1700000000.123456) can0 039#0000B4420000E803")
    assert (a.timestamp, a.channel, a.arbitration_id, a.data.hex()) == (
        1700000000.123456,
        "can0",
        0x39,
        "0000b4420000e803",
    )
    b = parse_candump_line("039#0000B4420000E803")
    assert (b.timestamp, b.channel, b.arbitration_id) == (None, None, 0x39)
    c = parse_candump_line("  can0  068   [8]  06 00 00 00 00 00 00 00")
    assert (c.channel, c.arbitration_id, c.data[0]) == ("can0", 0x68, 6)
    assert parse_candump_line("12345678#01").is_extended
    assert parse_candump_line("039#R").is_remote
    assert parse_candump_line("039##1AABB").is_fd
    for bad in ("hello", "039#0", "FFF#00", "  can0  068   [2]  06"):
        with pytest.raises(ProtocolError):
            parse_candump_line(bad)


def test_decode_text(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "bus.log"
    log.write_text(LOG)
    assert main(["decode", str(log)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 9
    assert "node 1 position_t position=90 bandwidth=10" in lines[0]
    assert "node 1 position_q position=-150 speed=10 accel=5" in lines[1]
    assert "node 3 system op=estop" in lines[2]
    assert "param_value" in lines[3] and "-92.469" in lines[3] and "pos_estimate" in lines[3]
    assert "state" in lines[4] and "trajectory_done=True" in lines[4]
    assert "!!" in lines[5] and "!!" in lines[6] and "extended" in lines[7] and "remote" in lines[8]


def test_decode_json_stdin() -> None:
    r = subprocess.run(
        [sys.executable, "-m", "drempower", "decode", "--json"], input=LOG, capture_output=True, text=True, check=True
    )
    recs = [json.loads(x) for x in r.stdout.splitlines()]
    assert len(recs) == 9
    assert recs[0]["node"] == 1
    assert recs[0]["command"] == "position_t"
    assert recs[0]["fields"] == {"position": 90.0, "bandwidth": 10.0, "speed": 0.0}
    assert recs[3]["command"] == "param_value"
    assert recs[3]["parameter"] == "axis0.output_shaft.pos_estimate"
    assert recs[3]["fields"]["value"] == pytest.approx(-92.469, abs=1e-3)
    assert recs[4]["direction"] == "motor"
    assert recs[4]["fields"]["trajectory_done"] is True
    assert all("error" in r for r in recs[5:])
    assert "8 data bytes" in recs[6]["error"] or "has 2 data bytes" in recs[6]["error"]


def test_decode_direction_override(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    import io

    monkeypatch.setattr(sys, "stdin", io.StringIO("039#0000B4420000E803\n"))
    assert main(["decode", "--json", "--direction", "motor"]) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["command"] == "state"
    assert rec["fields"]["torque"] == 10.0


def test_decode_missing_file(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["decode", "/nonexistent/bus.log"]) == 2  # bad input: exit 2
    assert "cannot read" in capsys.readouterr().err


def test_decode_pairs_a_zero_reply_with_its_read(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Reading axis0.error (0x03E, address 30001, u32) and its reply of 0: the same 8 bytes twice."""
    import io

    capture = "(10.000000) can0 03E#3175030000000000\n(10.000400) can0 03E#3175030000000000\n"
    monkeypatch.setattr(sys, "stdin", io.StringIO(capture * 2))
    assert main(["decode", "--json"]) == 0
    recs = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [(r["direction"], r["command"]) for r in recs] == [("host", "read_param"), ("motor", "param_value")] * 2
    assert recs[1]["parameter"] == "axis0.error" and recs[1]["fields"]["value"] == 0


def test_decode_json_is_strict_json_for_nan_and_infinity(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A motor can report a NaN position; JSON has no NaN, so it is written as a string."""
    import io

    monkeypatch.setattr(sys, "stdin", io.StringIO("021#0000C07F00000000\n"))
    assert main(["decode", "--json"]) == 0
    rec = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"non-strict JSON: {c}"))
    assert rec["command"] == "state" and rec["fields"]["position"] == "nan"


def test_the_help_names_every_input_it_reads(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["--help"])
    (line,) = [ln for ln in capsys.readouterr().out.splitlines() if ln.strip().startswith("decode ")]
    assert "candump" in line and "MCAP" in line and "python-can logs" in line, line
