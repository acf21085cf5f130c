"""A recording keeps each received frame's own time (its transport's), not when the recording host read it."""

from __future__ import annotations

import itertools
import statistics
import time
from pathlib import Path

import pytest

from drempower import open_bus
from drempower.protocol.ids import Frame
from drempower.records.recorder import Recorder
from drempower.sim import SimBus, attach_socketcand
from drempower.sim.runner import SimRunner

mcap_reader = pytest.importorskip("mcap.reader")

BEAT = 0.005
"""The motor's heartbeat period (s)."""
FRAMES = 120


def _rx_times(path: Path) -> list[float]:
    with path.open("rb") as fh:
        reader = mcap_reader.make_reader(fh)
        return [m.log_time / 1e9 for _, _, m in reader.iter_messages(topics=["/can/rx"])]


def test_a_socketcand_recording_keeps_the_servers_time_stamps(tmp_path: Path) -> None:
    """The simulator in real time behind socketcand, a motor's heartbeat every 5 ms; the recording host
    stalls 30 ms on every 8th frame (a busy host), so it reads the frames in bursts. The recording keeps
    them 5 ms apart (the server's stamps), where the times the host read them scatter by the stalls;
    the server's clock is put on the host's by the quickest hop so far, which may shorten a few gaps."""
    sim = SimBus(ids=[3])
    path = tmp_path / "beats.mcap"
    received: list[tuple[Frame, float]] = []

    def busy(frame: Frame, tx: bool) -> None:
        if not tx and len(received) < FRAMES:
            received.append((frame, time.monotonic()))
            if len(received) % 8 == 0:
                time.sleep(0.03)

    with (
        SimRunner(sim, 1.0),
        attach_socketcand(sim) as server,
        open_bus("socketcand", host="127.0.0.1", port=server.port) as bus,
    ):
        bus.add_tap(busy)
        with Recorder(path) as rec:
            rec.attach(bus)
            sim.motors[3].set_param("can.config.heartbeat_ms", BEAT * 1000)
            deadline = time.monotonic() + 20.0
            while len(received) < FRAMES and time.monotonic() < deadline:
                time.sleep(0.05)
            rec.detach()
        sim.motors[3].set_param("can.config.heartbeat_ms", 0)
    assert len(received) == FRAMES
    read = [at for _, at in received]
    read_gaps = [b - a for a, b in itertools.pairwise(read)]
    assert max(read_gaps) > 0.02 and min(read_gaps) < 0.002  # the host read them in bursts
    times = _rx_times(path)[:FRAMES]
    gaps = [b - a for a, b in itertools.pairwise(times)]
    assert statistics.median(gaps) == pytest.approx(BEAT, abs=2e-6)
    # the only change of spacing: a shorter gap where a frame came quicker than any before (the offset falls)
    assert all(g < BEAT + 2e-6 for g in gaps), gaps
    assert sum(abs(g - BEAT) > 2e-6 for g in gaps) <= FRAMES // 10, gaps
    # the frames' own times as the bus keeps them: the same spacing, on this host's monotonic scale
    own = [f.time for f, _ in received]  # type: ignore[attr-defined]
    assert statistics.median(b - a for a, b in itertools.pairwise(own)) == pytest.approx(BEAT, abs=2e-6)
    assert all(t <= at for t, at in zip(own, read, strict=True))
