"""The generated DBC, read by cantools: every golden vector decodes to our values."""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys
from enum import IntEnum
from pathlib import Path
from typing import Any

import pytest

from drempower.protocol.messages import (
    FastRead,
    ParamValue,
    Start,
    StartImpedance,
    State,
    SystemCommand,
    WriteParam,
    decode_command,
    decode_reply,
)

from ..cli.conftest import Cli
from ..conftest import REPO_ROOT

cantools = pytest.importorskip("cantools")

VECTOR_FILES = sorted(p for p in (REPO_ROOT / "spec" / "vectors").glob("*.json") if p.name != "invalid.json")
VECTORS = [(p.stem, v) for p in VECTOR_FILES for v in json.loads(p.read_text())["vectors"]]


@pytest.fixture(scope="module")
def db(tmp_path_factory: pytest.TempPathFactory) -> Any:
    path = tmp_path_factory.mktemp("dbc") / "drempower.dbc"
    from drempower.cli import main

    assert main(["dbc", "-o", str(path)]) == 0
    return cantools.database.load_file(str(path))


def _expected(msg: object) -> dict[str, float]:
    """Our decoded fields, by the name of the DBC signal that carries each."""
    fields = {f.name: getattr(msg, f.name) for f in dataclasses.fields(msg) if f.name != "node"}  # type: ignore[arg-type]
    if isinstance(msg, SystemCommand):
        return {"sys_num": int(fields["op"])}
    if isinstance(msg, Start):
        return {"sys_num": int(fields["kind"]), f"relative_{int(fields['kind']):02X}": int(fields["relative"])}
    if isinstance(msg, StartImpedance):
        return {"sys_num": 0x15, "kp": fields["kp"], "kd": fields["kd"]}
    if isinstance(msg, FastRead):
        return {"address": 0, "dtype": 0, "value_f32": 0.0}
    if isinstance(msg, (ParamValue, WriteParam)) or type(msg).__name__ == "ReadParam":
        out = {"address": fields["address"], "dtype": int(fields["dtype"])}
        # a read request carries value 0 in the value bytes
        out["value_" + fields["dtype"].name.lower()] = fields.get("value", 0)
        return out
    if isinstance(msg, State):
        fields.pop("trajectory_done"), fields.pop("error"), fields.pop("spare_bits")
    return {k: int(v) if isinstance(v, IntEnum) else v for k, v in fields.items()}


@pytest.mark.parametrize(("file", "vector"), VECTORS, ids=[f"{f}:{v['name']}" for f, v in VECTORS])
def test_cantools_decodes_every_vector_as_we_do(file: str, vector: dict[str, Any], db: Any) -> None:
    ident, data = vector["id"], bytes.fromhex(vector["data"])
    ours = decode_command(ident, data) if vector["direction"] == "host" else decode_reply(ident, data)
    if isinstance(ours, State) and ours.spare_bits == 3:
        # command fields 0x19/0x1B/0x1D/0x1F: the DBC describes the host commands on these ids
        assert db.get_message_by_frame_id(ident).senders == ["HOST"]
        return
    message = db.get_message_by_frame_id(ident)
    theirs = db.decode_message(ident, data, decode_choices=False)
    expected = _expected(ours)
    assert set(expected) == set(theirs), message.name
    for name, value in expected.items():
        got = theirs[name]
        if isinstance(value, float) and message.get_signal_by_name(name).is_float:
            assert got == value or (math.isnan(value) and math.isnan(got)), name  # f32: exactly
        else:
            assert got == pytest.approx(value, abs=1e-9), name
    if isinstance(ours, State):
        flags = message.name.split("_")[1:-1]
        assert ("T" in "".join(f for f in flags if not f.startswith("S"))) == ours.trajectory_done
        assert ("E" in "".join(f for f in flags if not f.startswith("S"))) == ours.error
        assert (f"S{ours.spare_bits}" in flags) == (ours.spare_bits != 0)


def test_dbc_has_every_node_and_float_types(db: Any) -> None:
    names = {m.name for m in db.messages}
    for n in (1, 63):
        for kind in (
            "SYSTEM",
            "PRESET",
            "POSITION_T",
            "POSITION_Q",
            "POSITION_P",
            "VELOCITY",
            "TORQUE",
            "READ",
            "WRITE",
            "STATE",
            "STATE_T",
            "STATE_E",
            "STATE_TE",
        ):
            assert f"{kind}_{n}" in names
    pos = db.get_message_by_name("POSITION_Q_5")
    assert pos.frame_id == 5 << 5 | 0x1A
    assert pos.get_signal_by_name("position").is_float and pos.get_signal_by_name("position").unit == "deg"
    assert pos.get_signal_by_name("speed").scale == 0.01
    rd = db.get_message_by_name("READ_7")
    assert rd.get_signal_by_name("dtype").is_multiplexer
    decoded = db.decode_message(rd.frame_id, bytes.fromhex("01000000CDCC4C41"))
    assert decoded["address"] == "vbus_voltage" and decoded["dtype"] == "f32"


def test_cantools_decode_command_on_a_candump_log(tmp_path: Path, cli: Cli) -> None:
    dbc = tmp_path / "d.dbc"
    assert cli("dbc", "--nodes", "1-6", "-o", str(dbc)).code == 0
    log = "(1700000000.000000) can0 03A#0000B4420000E803\n(1700000000.001000) can0 023#0000B9C2D204C8FF\n"
    r = subprocess.run(
        [sys.executable, "-m", "cantools", "decode", "--single-line", str(dbc)],
        input=log,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert "POSITION_Q_1(position: 90.0 deg, speed: 0.0 r/min, accel: 10.0 (r/min)/s)" in lines[0]
    assert "STATE_T_1(position: -92.5 deg, speed: 12.34 r/min, torque: -0.56 Nm)" in lines[1]


def test_nodes_option(cli: Cli, tmp_path: Path) -> None:
    out = cli("dbc", "--nodes", "2").out
    assert "BO_ 94 READ_2: 8 HOST" in out and "_1:" not in out
    r = cli("dbc", "--nodes", "1-64")
    assert r.code == 2 and "allowed 0..63" in r.err


def test_json_summary(cli: Cli, tmp_path: Path) -> None:
    (rec,) = cli("dbc", "--nodes", "1,2", "-o", str(tmp_path / "x.dbc"), "--json").records()
    assert rec == {"output": str(tmp_path / "x.dbc"), "messages": 2 * 21, "nodes": [1, 2]}
    assert cli("dbc", "--json").code == 2


_FLOAT32_EXTREMES = [
    3.4028234663852886e38,  # the largest finite float32
    -3.4028234663852886e38,
    1.401298464324817e-45,  # the smallest subnormal
    -0.0,
    math.inf,
    -math.inf,
    math.nan,
]


@pytest.mark.parametrize("value", _FLOAT32_EXTREMES, ids=repr)
def test_strict_encoding_takes_every_float32_value(db: Any, value: float) -> None:
    floats = 0
    for message in db.messages:
        if message.is_multiplexed():
            continue  # parameter frames: one value signal per data type
        for signal in message.signals:
            if not signal.is_float:
                continue
            floats += 1
            fields = {s.name: value if s is signal else (s.minimum or 0) for s in message.signals}
            data = message.encode(fields, strict=True)
            got = db.decode_message(message.frame_id, data, decode_choices=False)[signal.name]
            assert got == value or (math.isnan(value) and math.isnan(got)), (message.name, signal.name)
    assert floats > 64 * 6
    write = db.get_message_by_name("WRITE_1")
    data = write.encode({"address": 1, "dtype": 0, "value_f32": value}, strict=True)
    got = db.decode_message(write.frame_id, data, decode_choices=False)["value_f32"]
    assert got == value or (math.isnan(value) and math.isnan(got))
