"""``monitor --fields``: any state channel or parameter, captured by polling, heartbeats or state replies."""

from __future__ import annotations

import csv
import threading
from pathlib import Path
from typing import Any

import pytest

from drempower import open_bus
from drempower.client.api.busbase import BusBase
from drempower.protocol import FastRead
from drempower.sim import SimBus
from drempower.transports.sim import SimTransport

from ..cli.conftest import Cli


def test_poll_fields_with_a_parameter(sim: SimBus, cli: Cli, tmp_path: Path) -> None:
    out = tmp_path / "m.csv"
    r = cli(
        "monitor",
        "1,2",
        "--fields",
        "position,vbus_voltage,done",
        "--rate",
        "20",
        "--duration",
        "0.5",
        "--json",
        "--csv",
        str(out),
        "--sim",
        "1,2",
    )
    assert r.code == 0, r.err
    recs = r.records()
    assert {x["id"] for x in recs} == {1, 2} and len(recs) >= 10
    assert all(x["vbus_v"] == pytest.approx(sim.motors[1].param(1), rel=1e-6) for x in recs)
    assert all(set(x) == {"time_s", "id", "position_deg", "vbus_v", "done"} for x in recs)  # as state --json
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == len(recs) and list(rows[0]) == ["time_s", "id", "position_deg", "vbus_v", "done"]
    assert "achieved samples/s (poll): motor 1" in r.err


def test_heartbeat_source_reaches_the_rate_and_is_switched_off(sim: SimBus, cli: Cli) -> None:
    r = cli(
        "monitor",
        "3",
        "--fields",
        "position,speed",
        "--source",
        "heartbeat",
        "--rate",
        "100",
        "--duration",
        "0.5",
        "--json",
        "--sim",
        "3",
    )
    assert r.code == 0, r.err
    # simulated time runs 20x in these tests: 100 Hz heartbeats give ~2000 samples per wall second
    assert len(r.records()) > 200
    assert sim.motors[3].param(21004) == 0
    achieved = float(r.err.rsplit("motor 3 ", 1)[1].split()[0])
    assert achieved > 400


def test_replies_source_only_listens(sim: SimBus, cli: Cli, monkeypatch: pytest.MonkeyPatch) -> None:
    subscribed = threading.Event()
    original = BusBase.subscribe

    def subscribe(self: BusBase, *args: Any, **kwargs: Any) -> Any:
        handle = original(self, *args, **kwargs)
        subscribed.set()  # the monitor listens from now on
        return handle

    monkeypatch.setattr(BusBase, "subscribe", subscribe)
    result: list[object] = []
    t = threading.Thread(
        target=lambda: result.append(
            cli(
                "monitor", "2", "--fields", "torque", "--source", "replies", "--duration", "1.0", "--json", "--sim", "2"
            )
        )
    )
    t.start()
    assert subscribed.wait(10)
    with open_bus(transport=SimTransport(bus=sim, time_scale=0)) as other:  # another program's traffic
        for _ in range(5):
            other.request([FastRead(2)])
    t.join()
    (r,) = result
    assert r.code == 0 and len(r.records()) == 5  # type: ignore[attr-defined]


def test_unknown_field_is_a_usage_error(cli: Cli) -> None:
    r = cli("monitor", "1", "--fields", "position,warp_factor", "--sim", "1")
    assert r.code == 2 and "'warp_factor' is neither a state channel" in r.err
