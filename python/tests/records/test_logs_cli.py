"""``sniff --log`` writes every python-can format and MCAP; ``decode`` reads each back with timestamps."""

from __future__ import annotations

import io
import json
import threading
from pathlib import Path

import can
import pytest

from drempower.cli import main

from ..cli.conftest import SLOW_LINK, Cli

highlevel = pytest.importorskip("rosbags.highlevel")


def _sniff_while_reading(channel: str, log: Path, capsys: pytest.CaptureFixture[str]) -> str:
    link = ["-i", "virtual", "-c", channel]
    codes: list[int] = []
    sniffer = threading.Thread(
        target=lambda: codes.append(main(["sniff", "--count", "6", "--duration", "5", "--log", str(log), *link]))
    )
    sniffer.start()
    while sniffer.is_alive():
        assert main(["get", "1", "vbus_voltage", "axis0.error", *link, *SLOW_LINK]) == 0
    sniffer.join()
    out, err = capsys.readouterr()
    assert codes == [0] and "6 frames" in err
    return out


def _independent_frames(log: Path) -> list[tuple[float, int, bytes]]:
    if log.suffix == ".mcap":
        with highlevel.AnyReader([log]) as reader:  # rosbags: nothing of drempower's code
            out = []
            for c, t, raw in reader.messages():
                if c.topic in ("/can/rx", "/can/tx"):
                    f = reader.deserialize(raw, c.msgtype)
                    out.append((t / 1e9, f.id, bytes(f.data)[: f.dlc]))
            return out
    return [(m.timestamp, m.arbitration_id, bytes(m.data)) for m in can.LogReader(log)]


@pytest.mark.parametrize("ext", [".log", ".asc", ".blf", ".trc", ".csv", ".mcap"])
def test_sniff_log_is_read_by_python_can_and_decode(
    ext: str, virtual_channel: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], cli: Cli
) -> None:
    log = tmp_path / f"sniff{ext}"
    _sniff_while_reading(virtual_channel, log, capsys)
    frames = _independent_frames(log)
    assert len(frames) == 6
    r = cli("decode", "--json", str(log))
    assert r.code == 0
    recs = r.records()
    assert [(int(x["id"], 16), bytes.fromhex(x["data"])) for x in recs] == [(f[1], f[2]) for f in frames]
    for x, f in zip(recs, frames, strict=True):
        # .asc and .trc keep times relative to the start of the file, with their own resolution
        assert x["timestamp"] == pytest.approx(f[0], abs=1e-4)
    assert ("host", "read_param", "vbus_voltage") in {(x["direction"], x["command"], x.get("parameter")) for x in recs}
    text = cli("decode", str(log)).out.splitlines()
    assert len(text) == 6 and all(line.startswith("(") for line in text)


def test_sniff_text_output_decodes_again(
    virtual_channel: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], cli: Cli, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = _sniff_while_reading(virtual_channel, tmp_path / "x.log", capsys)
    sniffed = [line for line in out.splitlines(keepends=True) if "  0x" in line]  # not get's own output
    assert len(sniffed) == 6
    monkeypatch.setattr("sys.stdin", io.StringIO("".join(sniffed[:4])))
    r = cli("decode", "--json")
    recs = r.records()
    assert r.code == 0 and len(recs) == 4 and not any("error" in x for x in recs)
    assert all(x["node"] == 1 for x in recs)
    # decode's own text output decodes again, timestamps kept
    again = cli("decode", str(tmp_path / "x.log")).out
    monkeypatch.setattr("sys.stdin", io.StringIO(again))
    round_trip = cli("decode", "--json").records()
    logged = cli("decode", "--json", str(tmp_path / "x.log")).records()
    assert [(x["data"], x["timestamp"]) for x in round_trip] == [(x["data"], round(x["timestamp"], 6)) for x in logged]
    assert [x["data"] for x in recs] == [x["data"] for x in logged[:4]]


def test_sent_frames_are_host_frames_in_mcap(tmp_path: Path, cli: Cli) -> None:
    from drempower import open_bus
    from drempower.records.recorder import Recorder

    path = tmp_path / "a.mcap"
    with open_bus("sim", motors=[1]) as bus, Recorder(path) as rec:
        rec.attach(bus)
        bus.motor(1).read_property("axis0.error")  # a reply of 0: the same bytes as the request
    recs = [json.loads(line) for line in cli("decode", "--json", str(path)).out.splitlines()]
    assert [(x["direction"], x["command"]) for x in recs] == [("host", "read_param"), ("motor", "param_value")]


def test_unknown_extension_and_missing_file_fail_cleanly(tmp_path: Path, cli: Cli) -> None:
    r = cli("decode", str(tmp_path / "none.blf"))
    assert r.code == 2 and "cannot read" in r.err and "Traceback" not in r.err
    r = cli("sniff", "--log", str(tmp_path / "x.weird"), "--sim", "1", "--duration", "0.1")
    assert r.code == 1 and "x.weird" in r.err
    try:
        import asammdf  # noqa: F401
    except ImportError:  # python-can's .mf4 needs asammdf: a clear error, not a traceback
        r = cli("sniff", "--log", str(tmp_path / "x.mf4"), "--sim", "1", "--duration", "0.1")
        assert r.code == 1 and "x.mf4" in r.err and "asammdf" in r.err and "Traceback" not in r.err
