"""The one error tree: every public error derives from DrEmpowerError and lives in drempower.errors."""

from __future__ import annotations

import builtins
import importlib
import inspect
import pkgutil
import re

import pytest

import drempower
from drempower import errors


def _modules() -> list[str]:
    names = []
    for info in pkgutil.walk_packages(drempower.__path__, "drempower."):
        if info.name.endswith("__main__"):
            continue
        try:
            importlib.import_module(info.name)
        except ModuleNotFoundError as exc:  # a module of an optional extra that is not installed
            if exc.name is not None and exc.name.split(".")[0] != "drempower":
                continue
            raise
        names.append(info.name)
    return names


def test_every_public_exception_is_in_the_tree_and_defined_once() -> None:
    found = {}
    for name in _modules():
        module = importlib.import_module(name)
        for attr, value in vars(module).items():
            if attr.startswith("_") or not inspect.isclass(value) or not issubclass(value, Exception):
                continue
            if value.__module__.startswith("drempower"):
                found[f"{name}.{attr}"] = value
    assert len(found) >= 13
    for where, cls in found.items():
        assert issubclass(cls, errors.DrEmpowerError), where
        assert cls.__module__ == "drempower.errors", f"{where} is defined outside drempower.errors"


def test_the_docstring_draws_the_tree_as_it_is() -> None:
    drawn: dict[str, str | None] = {}
    also: dict[str, list[str]] = {}
    stack: list[str] = []
    for line in (errors.__doc__ or "").splitlines():
        m = re.match(r"^\s*((?:[│ ] {3})*)(?:[├└]── )?([A-Z]\w+Error)\b", line)
        if m is None or ("──" not in line and not line.strip().startswith("DrEmpowerError")):
            continue
        depth = len(m[1]) // 4 + (1 if "──" in line else 0)
        del stack[depth:]
        drawn[m[2]] = stack[-1] if stack else None
        also[m[2]] = re.findall(r"\(also an? (\w+Error)\)", line)
        stack.append(m[2])
    assert set(drawn) == {n for n in errors.__all__ if n.endswith("Error")}
    for name, parent in drawn.items():
        cls = getattr(errors, name)
        ours = [b.__name__ for b in cls.__bases__ if issubclass(b, errors.DrEmpowerError)]
        assert ours == ([parent] if parent else []) + also[name], (name, ours, parent)


@pytest.mark.parametrize(
    ("path", "name"),
    [
        ("drempower.client.errors", "TimeoutError"),
        ("drempower.client.errors", "BusClosedError"),
        ("drempower.client.errors", "MotorFaultError"),
        ("drempower.client.errors", "VerifyError"),
        ("drempower.client", "VerifyError"),
        ("drempower.client", "TimeoutError"),
        ("drempower.transports.errors", "TransportError"),
        ("drempower.transports", "TransportError"),
        ("drempower.cli._usage", "UsageError"),
        ("drempower", "TimeoutError"),
        ("drempower", "TransportError"),
        ("drempower", "ValidationError"),
    ],
)
def test_old_import_paths_name_the_same_class(path: str, name: str) -> None:
    assert getattr(importlib.import_module(path), name) is getattr(errors, name)


def test_builtins_callers_expect() -> None:
    assert issubclass(errors.TimeoutError, builtins.TimeoutError)
    assert issubclass(errors.TransportError, OSError)
    for cls in (errors.ValidationError, errors.FieldRangeError, errors.ProtocolError, errors.ConfigError):
        assert issubclass(cls, ValueError)
    assert issubclass(errors.IdTakenError, errors.VerifyError)
    assert issubclass(errors.NoMotorError, errors.VerifyError)
    assert not issubclass(errors.IdTakenError, errors.NoMotorError)
    assert not issubclass(errors.NoMotorError, errors.IdTakenError)


def test_simulator_and_transport_input_errors_are_the_projects() -> None:
    from drempower.sim import SimBus, SimRunner
    from drempower.sim.slcan import parse_frame
    from drempower.sim.socketcand import parse_send
    from drempower.transports.sim import SimTransport

    with pytest.raises(errors.ValidationError, match="ids="):
        SimBus(ids=[1, 1])
    with pytest.raises(errors.ValidationError, match="bitrate=-5"):
        SimBus(ids=[1], bitrate=-5)
    with pytest.raises(errors.ValidationError, match="time_scale=0"):
        SimRunner(SimBus(ids=[1]), 0)
    with pytest.raises(errors.ValidationError, match="time_scale=-1"):
        SimTransport([1], time_scale=-1)
    for bad in ("t12", "tXYZ1AA", "t1232AAZZ", "r1231AA"):
        with pytest.raises(errors.ProtocolError):
            parse_frame(bad)
    for bad in ("send", "send 123 x 11", "send 123 2 11", "send 12G 1 00"):
        with pytest.raises(errors.ProtocolError):
            parse_send(bad)
