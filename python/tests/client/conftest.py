"""Fixtures of the client tests."""

from __future__ import annotations

import signal
from collections.abc import Iterator

import pytest

from drempower.client import Bus
from drempower.client.driver import signals as sig

from .scripted import FakeMotors, ScriptedTransport


@pytest.fixture
def motors() -> FakeMotors:
    return FakeMotors([1, 2, 3])


@pytest.fixture
def scripted(motors: FakeMotors) -> ScriptedTransport:
    """The fake motors behind a transport on a scripted virtual clock: timeouts take no wall time."""
    return ScriptedTransport(motors, virtual=True)


@pytest.fixture
def bus(scripted: ScriptedTransport) -> Iterator[Bus]:
    with Bus(scripted, timeout=0.5, stop_on_close=False) as b:
        yield b


@pytest.fixture
def _restore_handlers() -> Iterator[None]:
    """Put back the signal handlers (and the chained ones) a test installed."""
    saved = {s: signal.getsignal(s) for s in sig.TERMINATING_SIGNALS}
    previous = dict(sig._previous)
    try:
        yield
    finally:
        for s, h in saved.items():
            signal.signal(s, h)
        sig._previous.clear()
        sig._previous.update(previous)
