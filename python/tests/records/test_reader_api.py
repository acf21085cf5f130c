"""The Python reader: decoded messages with timestamps from MCAP and python-can logs; the package stays light."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import can
import pytest

from drempower import open_bus
from drempower.protocol import FastRead, ParamValue, PositionQ, ReadParam, State
from drempower.records import Recorder, decode_log, read_log

pytest.importorskip("mcap_ros2")


def test_decode_log_of_a_recording(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    with open_bus("sim", motors=[4]) as bus, Recorder(path) as rec:
        rec.attach(bus)
        bus.motor(4).read_property("vbus_voltage")
        bus.motor(4).get_state()
    decoded = list(decode_log(path))
    assert [type(d.message) for d in decoded] == [ReadParam, ParamValue, FastRead, State]
    assert [d.direction for d in decoded] == ["host", "motor", "host", "motor"]
    assert [d.record.tx for d in decoded] == [True, False, True, False]
    times = [d.record.timestamp for d in decoded]
    assert all(t is not None and t > 1.6e9 for t in times) and times == sorted(times)  # type: ignore[operator]


def test_read_log_of_a_blf_keeps_direction_and_time(tmp_path: Path) -> None:
    path = tmp_path / "x.blf"
    f = PositionQ(3, 10.0, 5.0, 5.0).encode()
    with can.Logger(path) as log:
        log(
            can.Message(
                timestamp=1700000000.25, arbitration_id=f.arbitration_id, data=f.data, is_extended_id=False, is_rx=False
            )
        )
        log(can.Message(timestamp=1700000000.5, arbitration_id=0x63, data=bytes(8), is_extended_id=False))
    recs = list(read_log(path))
    assert [(r.frame.arbitration_id, r.tx) for r in recs] == [(f.arbitration_id, True), (0x63, None)]
    assert recs[0].timestamp == pytest.approx(1700000000.25, abs=1e-3)
    (cmd, state) = decode_log(path)
    assert cmd.message == PositionQ(3, 10.0, 5.0, 5.0) and isinstance(state.message, State)


def test_import_drempower_stays_light() -> None:
    code = (
        "import sys, drempower, drempower.cli as c; c.build_parser(); "
        "heavy = {'mcap', 'mcap_ros2', 'cantools', 'rosbags', 'foxglove'}; "
        "print(sorted({m.split('.')[0] for m in sys.modules} & heavy))"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.stdout.strip() == "[]", r.stderr
