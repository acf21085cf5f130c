"""Transports declare their abilities in one object, and other packages add transports by entry point."""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import pytest

import drempower
from drempower.client import Bus
from drempower.protocol.ids import Frame
from drempower.transports import Capabilities, Transport, TransportError, open_transport
from drempower.transports.base import QueuedTransport
from drempower.transports.factory import ENTRY_POINT_GROUP


def test_the_simulator_declares_what_it_can_do() -> None:
    instant = open_transport("sim", motors=[1, 2])
    timed = open_transport("sim", motors=[3], bitrate=1_000_000, clock="virtual")
    try:
        assert instant.capabilities == Capabilities(
            confirms_sent=True, answers_in_send=True, motor_ids=frozenset({1, 2}), tx_latency=instant.tx_latency
        )
        caps = timed.capabilities
        assert caps.virtual_clock and caps.confirms_sent and not caps.answers_in_send
        assert caps.wire_bitrate == 1_000_000 and caps.motor_ids == frozenset({3})
        assert timed.clock() is timed and instant.clock() is None
    finally:
        instant.close()
        timed.close()


class _Loop(QueuedTransport):
    """A transport that knows nothing: every frame sent comes back (no motor answers)."""

    def __init__(self, channel: object = None, bitrate: int | None = None, **options: object) -> None:
        super().__init__()
        self.channel, self.bitrate, self.options = channel, bitrate, options

    def send(self, frame: Frame) -> None:
        self._queue.put(frame)

    def close(self) -> None:
        self._closed = True
        self._wake()


def test_a_transport_that_declares_nothing_gets_the_defaults_and_the_client_asks_nothing_else() -> None:
    t = _Loop()
    assert t.capabilities == Capabilities()
    assert t.clock() is None and t.rest_time() == 0.0
    with pytest.raises(NotImplementedError):
        t.send_collect(Frame(0x21, b""))
    with Bus(t, timeout=0.05, stop_on_close=False) as bus, pytest.raises(drempower.TimeoutError):
        bus.motor(1).get_state()


def test_a_virtual_clock_declared_without_a_clock_is_refused_by_name() -> None:
    class Liar(_Loop):
        virtual_clock = True

    with pytest.raises(TypeError, match="Liar declares a virtual clock"):
        Bus(Liar(), stop_on_close=False)


def _plugin(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, target: str) -> None:
    """An installed distribution (its metadata on sys.path) registering ``looplink`` -> ``target``."""
    (tmp_path / "looplink_mod.py").write_text(
        textwrap.dedent(
            """
            from drempower.transports.base import QueuedTransport

            class LoopLink(QueuedTransport):
                def __init__(self, channel=None, bitrate=None, **options):
                    super().__init__()
                    self.channel, self.bitrate, self.options = channel, bitrate, options

                def send(self, frame):
                    self._queue.put(frame)

                def close(self):
                    self._closed = True
                    self._wake()

            def not_a_transport(**kwargs):
                return object()
            """
        )
    )
    info = tmp_path / "looplink-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: looplink\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[{ENTRY_POINT_GROUP}]\nlooplink = {target}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "looplink_mod", raising=False)


def test_a_transport_registered_by_entry_point_opens_by_its_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _plugin(tmp_path, monkeypatch, "looplink_mod:LoopLink")
    t = open_transport("looplink", "chan7", 500_000, speed="fast")
    try:
        assert isinstance(t, Transport) and type(t).__name__ == "LoopLink"
        assert (t.channel, t.bitrate, t.options) == ("chan7", 500_000, {"speed": "fast"})  # type: ignore[attr-defined]
    finally:
        t.close()
    with (
        drempower.open_bus("looplink", "c", timeout=0.05, stop_on_close=False) as bus,
        pytest.raises(drempower.TimeoutError),
    ):
        bus.motor(1).get_state()


def test_a_registered_transport_that_gives_no_transport_or_fails_to_load_is_named(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _plugin(tmp_path, monkeypatch, "looplink_mod:not_a_transport")
    with pytest.raises(TransportError, match=r"transport 'looplink' \(looplink_mod:not_a_transport\) gave a object"):
        open_transport("looplink")
    (tmp_path / "looplink-1.0.dist-info" / "entry_points.txt").write_text(
        f"[{ENTRY_POINT_GROUP}]\nlooplink = looplink_mod:missing\n"
    )
    with pytest.raises(TransportError, match=r"cannot load transport 'looplink' \(looplink_mod:missing\)"):
        open_transport("looplink")
