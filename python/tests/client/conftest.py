"""Fixtures of the client tests."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from drempower.client import Bus

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
