"""Transports when the device misbehaves or is missing: bounded sends, exclusive ports, paced reads, open errors."""

from __future__ import annotations

import os
import select
import socket
import threading
import time
import tty
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import can
import pytest

import drempower
from drempower.protocol import PositionT, State, encode_aa, encode_uart11
from drempower.protocol.framing import AADecoder, Uart11Decoder
from drempower.protocol.ids import Frame
from drempower.transports import TransportError, open_transport
from drempower.transports.serialport import SerialFrameTransport

pytestmark = pytest.mark.skipif(os.name != "posix", reason="pseudo-terminals")

LIMIT = 20.0
"""Loose upper bound (s) for anything that must end: a call still running after it is taken as a hang."""


def bounded(fn: Callable[[], Any], limit: float = LIMIT) -> tuple[Any, BaseException | None, float]:
    """Run ``fn`` in a daemon thread: (result, exception, seconds); fails the test if it does not end in ``limit``."""
    out: list[Any] = [None, None]

    def run() -> None:
        try:
            out[0] = fn()
        except BaseException as exc:
            out[1] = exc

    t0 = time.monotonic()
    th = threading.Thread(target=run, daemon=True)
    th.start()
    th.join(limit)
    assert not th.is_alive(), f"{fn} still blocked after {limit} s"
    return out[0], out[1], time.monotonic() - t0


@contextmanager
def raw_pty() -> Iterator[tuple[int, str]]:
    """A pseudo-terminal in raw mode: (master fd, slave path). Nothing reads the master unless the test does."""
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    try:
        yield master, os.ttyname(slave)
    finally:
        os.close(master)
        os.close(slave)


def drain(master: int, quiet: float = 0.3) -> bytes:
    """Everything the device side can read, until ``quiet`` s pass without more."""
    out = bytearray()
    while select.select([master], [], [], quiet)[0]:
        try:
            chunk = os.read(master, 65536)
        except OSError:
            break
        if not chunk:
            break
        out += chunk
    return bytes(out)


FRAME = PositionT(1, 10.0, bandwidth=10.0).encode()


def fill(send: Callable[[], None], limit: int = 100_000) -> tuple[int, BaseException]:
    """Send until a send fails; (frames reported sent, the error)."""
    for n in range(limit):
        try:
            send()
        except Exception as exc:
            return n, exc
    raise AssertionError(f"{limit} sends and no failure: the device side was supposed to stop reading")


# ------------------------------------------------------------------ python-can on a serial port: bounded sends


@pytest.mark.parametrize("interface", ["slcan", "python-can:serial"])
def test_python_can_serial_send_is_bounded_when_the_device_stops_reading(interface: str) -> None:
    with raw_pty() as (master, path):
        extra = {"sleep_after_open": 0} if interface == "slcan" else {}
        t = open_transport(interface, path, send_timeout=0.3, **extra)
        try:
            drain(master, 0.05)
            (_, err), exc, _ = bounded(lambda: fill(lambda: t.send(FRAME)))
            assert exc is None and isinstance(err, TransportError)
            assert path in str(err)  # names the bus
            # still bounded when retried
            _, again, _ = bounded(lambda: t.send(FRAME))
            assert isinstance(again, TransportError)
        finally:
            _, exc, _ = bounded(t.close)
        assert exc is None


def test_estop_and_close_return_when_an_slcan_device_stalls() -> None:
    """The device stops reading while a loop streams commands: the stream fails, estop fails fast, close returns."""
    with raw_pty() as (master, path):
        bus = drempower.open_bus("slcan", path, timeout=0.3, sleep_after_open=0, send_timeout=0.3, stop_on_close=True)
        drain(master, 0.05)
        motor = bus.motor(1)

        def stream() -> None:
            for i in range(100_000):
                motor.set_angle(float(i % 90), 10, 10, mode=0, enable=True)

        _, exc, _ = bounded(stream)
        assert isinstance(exc, drempower.TransportError)
        _, exc, _ = bounded(motor.estop)
        assert isinstance(exc, drempower.TransportError) and path in str(exc)
        _, exc, _ = bounded(bus.close)
        assert exc is None


# ------------------------------------------------------------------ opening what is not there


@pytest.mark.parametrize("interface", ["socketcand", "python-can:socketcand"])
def test_socketcand_to_a_closed_port_fails_at_once_naming_host_and_port(
    interface: str, caplog: pytest.LogCaptureFixture
) -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    # nothing listens on port now
    _, exc, took = bounded(lambda: open_transport(interface, "can0", host="127.0.0.1", port=port))
    assert isinstance(exc, TransportError)
    assert f"127.0.0.1:{port}" in str(exc) and "socketcand" in str(exc)
    assert took < 5  # python-can alone retries for 10 s
    assert not [r for r in caplog.records if r.levelname == "WARNING"]


@pytest.mark.parametrize("interface", ["socketcand", "python-can:socketcand"])
def test_socketcand_to_a_silent_server_fails_naming_host_and_port(
    interface: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Something listens but never greets: no hang in the handshake (drempower's or python-can's)."""
    from drempower.transports import pythoncan
    from drempower.transports import socketcand as own

    monkeypatch.setattr(pythoncan, "CONNECT_TIMEOUT", 0.3)  # short: the test waits it out
    monkeypatch.setattr(own, "CONNECT_TIMEOUT", 0.3)
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen(4)
        port = server.getsockname()[1]
        _, exc, _ = bounded(lambda: open_transport(interface, "can0", host="127.0.0.1", port=port))
    assert isinstance(exc, TransportError)
    assert f"127.0.0.1:{port}" in str(exc) and "hi" in str(exc)


def test_a_driver_failing_with_any_exception_is_a_transport_error(monkeypatch: pytest.MonkeyPatch) -> None:
    def broken_driver(*args: Any, **kwargs: Any) -> can.BusABC:
        raise NameError("name 'canGetNumberOfChannels' is not defined")

    monkeypatch.setattr(can, "Bus", broken_driver)
    with pytest.raises(TransportError) as info:
        open_transport("kvaser", 0, 500_000)
    text = str(info.value)
    assert "interface='kvaser'" in text and "channel=0" in text and "bitrate=500000" in text
    assert "NameError" in text and isinstance(info.value.__cause__, NameError)


def test_a_missing_kvaser_driver_is_a_transport_error() -> None:
    try:
        t = open_transport("kvaser", 0)
    except TransportError as exc:
        assert "kvaser" in str(exc)
    else:  # a Kvaser library (and channel) is present on this machine
        t.close()


@pytest.fixture
def no_can_config(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    """No CAN_* variables and an empty home, so that only what the test sets configures python-can."""
    for k in list(os.environ):
        if k.startswith("CAN_"):
            monkeypatch.delenv(k)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setattr(can, "rc", {})
    return tmp_path


def test_error_names_what_the_environment_configured(monkeypatch: pytest.MonkeyPatch, no_can_config: Path) -> None:
    monkeypatch.setenv("CAN_INTERFACE", "slcan")
    monkeypatch.setenv("CAN_CHANNEL", "/dev/drempower-no-such-port")
    monkeypatch.setenv("CAN_BITRATE", "500000")
    _, exc, _ = bounded(lambda: drempower.open_bus())
    assert isinstance(exc, TransportError)
    text = str(exc)
    for word in ("interface='slcan'", "channel='/dev/drempower-no-such-port'", "bitrate=500000", "configuration"):
        assert word in text


def test_error_names_what_the_config_file_configured(no_can_config: Path) -> None:
    (no_can_config / ".canrc").write_text(
        "[default]\ninterface = slcan\nchannel = /dev/drempower-no-such-port\nbitrate = 250000\n"
    )
    _, exc, _ = bounded(lambda: open_transport())
    assert isinstance(exc, TransportError)
    for word in ("interface='slcan'", "channel='/dev/drempower-no-such-port'", "bitrate=250000"):
        assert word in str(exc)
    # what is given wins over the file, and the error says which is which
    _, exc, _ = bounded(lambda: open_transport(channel="/dev/drempower-other-port"))
    assert isinstance(exc, TransportError)
    assert "channel='/dev/drempower-other-port'" in str(exc) and "interface='slcan'" in str(exc)


def test_no_interface_anywhere_says_so(no_can_config: Path) -> None:
    with pytest.raises(TransportError, match="no interface"):
        open_transport()


def test_an_unknown_configured_interface_is_named(monkeypatch: pytest.MonkeyPatch, no_can_config: Path) -> None:
    monkeypatch.setenv("CAN_INTERFACE", "drempower-nosuch")
    with pytest.raises(TransportError, match="configuration") as info:
        open_transport()
    assert "drempower-nosuch" in str(info.value)


# ------------------------------------------------------------------ one program per serial port


@pytest.mark.parametrize("kind", ["adapter", "uart"])
def test_a_serial_port_is_opened_exclusively(kind: str) -> None:
    with raw_pty() as (_, path):
        first = open_transport(kind, path)
        try:
            _, exc, took = bounded(lambda: open_transport(kind, path))
            assert isinstance(exc, TransportError)
            assert path in str(exc) and "another program" in str(exc)
            assert took < 5
        finally:
            first.close()
        open_transport(kind, path).close()  # free again once closed


# ------------------------------------------------------------------ writes: exact accounting, no half frames


def test_a_send_reported_failed_was_not_sent() -> None:
    """The device stops reading on a frame boundary: the failed send put nothing on the wire; later sends work."""
    with raw_pty() as (master, path):
        t = open_transport("adapter", path, write_timeout=0.3)  # short: the test waits it out
        try:
            (n, err), exc, _ = bounded(lambda: fill(lambda: t.send(FRAME)))
            assert exc is None and isinstance(err, TransportError)
            wire = drain(master)
            t.send(FRAME)  # the device reads again: the transport still works
            wire += drain(master)
        finally:
            t.close()
    d = AADecoder()
    assert d.feed(wire) == [FRAME] * (n + 1)  # what was reported sent, nothing else
    assert d.dropped == 0 and d.pending == 0
    assert "not sent" in str(err) and path in str(err)


BLOB = (bytes(range(256)) * 4)[:1000]
"""A 1000-byte 'frame': a pty takes small writes whole, so partial writes need a long frame."""


def blob_transport(path: str, blob: bytes = BLOB, **options: Any) -> SerialFrameTransport:
    """The serial transports' machinery with a framing whose frames are ``blob``."""
    return SerialFrameTransport(path, 115200, AADecoder(), lambda f: blob, "blob device", **options)


def test_a_frame_cut_off_breaks_the_transport_clearly() -> None:
    for blob in (BLOB, BLOB[:997], BLOB * 3, BLOB[:600]):  # a length the pty cuts on this kernel
        with raw_pty() as (master, path):
            t = blob_transport(path, blob, write_timeout=0.3)  # short: the test waits it out
            try:
                (n, err), exc, _ = bounded(lambda t=t: fill(lambda: t.send(FRAME)))
                assert exc is None and isinstance(err, TransportError)
                if "not sent" in str(err):
                    continue
                assert "cut off" in str(err) and path in str(err)
                wire = drain(master)
                with pytest.raises(TransportError, match="cut off"):  # later sends fail, saying why
                    t.send(FRAME)
                assert drain(master, 0.05) == b""
            finally:
                t.close()
        # the device saw exactly the frames reported sent, then part of one
        whole, part = divmod(len(wire), len(blob))
        assert whole == n and part > 0
        assert wire == blob * n + blob[:part]
        return
    pytest.skip("this kernel's pty never took part of a write")


def test_a_frame_started_is_finished_when_the_device_reads_again_in_time() -> None:
    with raw_pty() as (master, path):
        t = blob_transport(path, write_timeout=LIMIT)
        sent = [0]
        got = bytearray()

        def device() -> None:  # stalls until the sender is stuck, then reads everything
            last, since = -1, time.monotonic()
            while time.monotonic() - since < 0.3:
                if sent[0] != last:
                    last, since = sent[0], time.monotonic()
                time.sleep(0.02)
            got.extend(drain(master))

        th = threading.Thread(target=device, daemon=True)
        th.start()
        count = 100  # well over what the pty holds

        def sender() -> None:
            for _ in range(count):
                t.send(FRAME)
                sent[0] += 1

        try:
            _, exc, _ = bounded(sender, 2 * LIMIT)
            assert exc is None
            th.join(LIMIT)
            got.extend(drain(master))
        finally:
            t.close()
    assert bytes(got) == BLOB * count


def test_close_while_a_send_waits_returns() -> None:
    with raw_pty() as (_, path):
        t = open_transport("uart", path, write_timeout=LIMIT)
        box: list[BaseException | None] = [None]

        def sender() -> None:
            try:
                fill(lambda: t.send(FRAME))
            except BaseException as exc:
                box[0] = exc

        th = threading.Thread(target=sender, daemon=True)
        th.start()
        time.sleep(0.2)  # the pty fills quickly; the sender now waits on the device
        _, exc, _ = bounded(t.close, LIMIT / 2)
        assert exc is None
        th.join(LIMIT / 2)
        assert not th.is_alive()


# ------------------------------------------------------------------ reads: a frame at a time, not a byte at a time


def _paced_reads(kind: str, frames: list[Frame], pack: Callable[[Frame], bytes]) -> tuple[list[Frame], int]:
    """Frames written one byte at a time (0.1-0.3 ms apart) to a transport opened at 9600 Bd (1 ms a byte)."""
    with raw_pty() as (master, path):
        t = open_transport(kind, path, baudrate=9600)
        ser = t._ser  # type: ignore[attr-defined]
        orig = ser.read
        calls = [0]

        def counting_read(size: int = 1) -> bytes:
            data: bytes = orig(size)
            calls[0] += bool(data)
            return data

        ser.read = counting_read

        def device() -> None:
            for f in frames:
                for b in pack(f):
                    os.write(master, bytes((b,)))
                    time.sleep(0.0001)
                time.sleep(0.03)  # a gap between frames

        th = threading.Thread(target=device, daemon=True)
        got: list[Frame] = []
        try:
            th.start()
            while (f := t.recv(0.2)) is not None or th.is_alive():
                if f is not None:
                    got.append(f)
        finally:
            t.close()
    return got, calls[0]


@pytest.mark.parametrize(
    ("kind", "pack"),
    [("uart", lambda f: encode_uart11(f[0], f[1])), ("adapter", encode_aa)],
)
def test_a_byte_paced_line_is_read_a_frame_at_a_time(kind: str, pack: Callable[[Frame], bytes]) -> None:
    frames = [State(1, float(i), 0.0, 0.0, True, False).encode() for i in range(20)]
    got, calls = _paced_reads(kind, frames, pack)
    # a stall of the machine mid-frame may cost a frame (a quiet line drops a partial frame), nothing else
    assert len(got) >= len(frames) - 3 and set(got) <= set(frames)
    assert got == sorted(got, key=frames.index)
    # one read for the first byte(s), one for the rest; a read a byte would be 11 or 16 a frame
    assert calls / len(got) < 4, calls


def test_a_partial_frame_followed_by_silence_is_still_dropped() -> None:
    with raw_pty() as (master, path):
        t = open_transport("uart", path)
        try:
            good = State(2, 1.0, 0.0, 0.0, True, False).encode()
            os.write(master, encode_uart11(good[0], good[1])[:6])
            assert t.recv(0.3) is None
            os.write(master, encode_uart11(good[0], good[1]))
            assert t.recv(LIMIT) == good
            dec = t.decoder  # type: ignore[attr-defined]
            assert isinstance(dec, Uart11Decoder) and dec.dropped == 6
        finally:
            t.close()


# ------------------------------------------------------------------ the adapter's rates


def test_adapter_refuses_a_can_bitrate() -> None:
    with pytest.raises(TransportError, match="vendor") as info:
        open_transport("adapter", "loop://", bitrate=1_000_000)
    assert "baudrate" in str(info.value)
    with pytest.raises(TransportError, match="vendor"):
        drempower.open_bus("serial", "loop://", 500_000)


def test_adapter_takes_the_serial_rate_from_baudrate() -> None:
    t = open_transport("adapter", "loop://", baudrate=921600)
    try:
        assert t._ser.baudrate == 921600  # type: ignore[attr-defined]
        assert "921600" in t.description
    finally:
        t.close()
