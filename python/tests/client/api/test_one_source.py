"""The threaded front end (Motor, Bus) is generated from the asyncio one (AsyncMotor, AsyncBus):
the generated file is fresh, and both have the same public methods, signatures, defaults and docstrings."""

from __future__ import annotations

import importlib.util
import inspect
import shutil
import subprocess
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from drempower.client import AsyncBus, AsyncMotor, Bus, Motor, VelocityMode
from drempower.client.api.busbase import BusBase
from drempower.client.api.motorbase import MotorBase
from drempower.robot import AsyncJoint, AsyncRobot, Joint, Robot

from ...conftest import REPO_ROOT

_TOOL = REPO_ROOT / "tools" / "gen_sync.py"
_CLIENT = Path("python/src/drempower/client")
_ROBOT = Path("python/src/drempower/robot")
_PAIRS = [(Motor, AsyncMotor, MotorBase), (Bus, AsyncBus, BusBase)]
_RENAMES = {"AsyncMotor": "Motor", "AsyncBus": "Bus", "AsyncJoint": "Joint", "AsyncRobot": "Robot"}


def _gen_sync() -> ModuleType:
    spec = importlib.util.spec_from_file_location("gen_sync", _TOOL)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_generated_front_end_is_fresh() -> None:
    r = subprocess.run([sys.executable, str(_TOOL), "--check"], capture_output=True, text=True, check=False)
    assert r.returncode == 0, r.stderr


def test_an_edit_of_either_side_alone_is_stale(tmp_path: Path) -> None:
    """On a copy: a hand edit of bus_sync.py, or an edit of bus_async.py not regenerated, fails the check."""
    parts = [
        Path("tools/gen_sync.py"),
        Path("python/pyproject.toml"),
        _CLIENT / "api" / "bus_async.py",
        _CLIENT / "api" / "bus_sync.py",
        _ROBOT / "robot_async.py",
        _ROBOT / "robot_sync.py",
        *(_ROBOT.parent / "motion" / f for f in ("follow_async.py", "follow_sync.py")),
        *(_ROBOT.parent / "motion" / f for f in ("routines_async.py", "routines_sync.py")),
        *(_CLIENT / "api" / f for f in ("moves_async.py", "moves_sync.py")),
    ]
    for rel in parts:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(REPO_ROOT / rel, tmp_path / rel)
    script = [sys.executable, str(tmp_path / "tools/gen_sync.py")]

    def check() -> subprocess.CompletedProcess[str]:
        return subprocess.run([*script, "--check"], capture_output=True, text=True, check=False)

    assert check().returncode == 0
    generated = tmp_path / parts[3]
    text = generated.read_text()
    generated.write_text(text.replace("mode: int = PositionMode.T", "mode: int = 0"))
    r = check()
    assert r.returncode == 1 and "bus_sync.py" in r.stderr
    generated.write_text(text)
    source = tmp_path / parts[2]
    source.write_text(source.read_text().replace("speed: float = 0.0", "speed: float = 20.0"))
    assert check().returncode == 1
    assert subprocess.run(script, capture_output=True, text=True, check=False).returncode == 0
    assert check().returncode == 0
    assert "speed: float = 20.0" in generated.read_text()
    robot = tmp_path / parts[5]
    robot.write_text(robot.read_text().replace("speed: float = 10.0", "speed: float = 11.0"))
    r = check()
    assert r.returncode == 1 and "robot_sync.py" in r.stderr


def test_the_twins_are_found_by_path(tmp_path: Path) -> None:
    """Every ``X_async.py`` of the package is a source with ``X_sync.py`` beside it; one the tool has no
    docstring for is refused by name, and so is a listed source that is gone."""
    gen = _gen_sync()
    pairs = gen.find_pairs()
    assert {(s.name, t.name) for s, t, _ in pairs} == {
        ("bus_async.py", "bus_sync.py"),
        ("moves_async.py", "moves_sync.py"),
        ("robot_async.py", "robot_sync.py"),
        ("follow_async.py", "follow_sync.py"),
        ("routines_async.py", "routines_sync.py"),
    }
    assert all(s.parent == t.parent and t.exists() for s, t, _ in pairs)
    package = tmp_path / "drempower"
    for source, _, _ in pairs:
        rel = source.relative_to(gen.PACKAGE)
        (package / rel).parent.mkdir(parents=True, exist_ok=True)
        (package / rel).write_text("")
    (package / "extra_async.py").write_text("")
    with pytest.raises(SystemExit, match=r"extra_async\.py has no docstring"):
        gen.find_pairs(package)
    (package / "extra_async.py").unlink()
    (package / "motion" / "follow_async.py").unlink()
    with pytest.raises(SystemExit, match=r"no such source: motion/follow_async\.py"):
        gen.find_pairs(package)


def test_the_transform() -> None:
    """async/await go, the asyncio names become the threaded ones, in code, strings and comments."""
    source = (
        '"""Module doc."""\n'
        "async def f(bus: AsyncBus) -> AsyncMotor:  # an AsyncBus\n"
        "    async with bus:\n"
        '        return await bus.motor(1)  # "await" in a comment stays\n'
        "async def __aexit__(self) -> None:\n"
        '    """See :class:`AsyncBusBase`; AsyncBuses is no name of the table."""\n'
        "    x = awaited = (await g())\n"
    )
    out = _gen_sync().unasync(source)
    assert out.splitlines()[-6:] == [
        "def f(bus: Bus) -> Motor:  # an Bus",
        "    with bus:",
        '        return bus.motor(1)  # "await" in a comment stays',
        "def __exit__(self) -> None:",
        '    """See :class:`SyncBusBase`; AsyncBuses is no name of the table."""',
        "    x = awaited = (g())",
    ]
    assert out.startswith('"""The threaded client')


def _public(cls: type) -> dict[str, Any]:
    return {name: inspect.getattr_static(cls, name) for name in dir(cls) if not name.startswith("_")}


def _unwrapped(member: Any) -> Any:
    return inspect.unwrap(member) if inspect.isfunction(member) else member


def _signature(fn: Any) -> list[tuple[str, Any, Any, str]]:
    """(name, kind, default, annotation) of each parameter, then the return annotation; asyncio names renamed."""

    def rename(annotation: Any) -> str:
        text = str(annotation)
        for old, new in _RENAMES.items():
            text = text.replace(old, new)
        return text

    sig = inspect.signature(fn)
    params = [(p.name, p.kind, p.default, rename(p.annotation)) for p in sig.parameters.values()]
    return [*params, ("return", None, None, rename(sig.return_annotation))]


@pytest.mark.parametrize(("sync", "aio", "base"), _PAIRS, ids=["Motor", "Bus"])
def test_both_front_ends_have_the_same_public_api(sync: type, aio: type, base: type) -> None:
    s, a = _public(sync), _public(aio)
    assert sorted(s) == sorted(a)
    io_methods = 0
    for name in s:
        sm, am = s[name], a[name]
        assert type(sm) is type(am), name
        if isinstance(sm, property):
            assert sm.fget is not None and am.fget is not None
            assert _signature(sm.fget) == _signature(am.fget), name
            continue
        if not inspect.isfunction(sm):
            continue
        assert _signature(sm) == _signature(am), name
        if name in vars(base) or any(name in vars(k) for k in base.__mro__):
            assert sm is am, f"{name}: shared (no I/O), the same function on both"
            assert not inspect.iscoroutinefunction(sm)
        else:
            assert inspect.iscoroutinefunction(am), f"{aio.__name__}.{name} is no coroutine function"
            assert not inspect.iscoroutinefunction(sm), f"{sync.__name__}.{name} is a coroutine function"
            io_methods += 1
    assert io_methods >= (33 if sync is Motor else 15), io_methods


def test_the_drifted_defaults_are_the_threaded_ones() -> None:
    """AsyncBus.set_speeds once defaulted mode=1 where Bus.set_speeds has VelocityMode.PASSTHROUGH."""
    for cls in (Bus, AsyncBus):
        assert inspect.signature(cls.set_speeds).parameters["mode"].default is VelocityMode.PASSTHROUGH
    assert inspect.signature(AsyncBus.set_angles).parameters["speed"].default == 10.0


@pytest.mark.parametrize(("sync", "aio"), [(Joint, AsyncJoint), (Robot, AsyncRobot)], ids=["Joint", "Robot"])
def test_both_robots_have_the_same_public_api(sync: type, aio: type) -> None:
    """The generated threaded robot and its asyncio source: same members, signatures and defaults."""
    s, a = _public(sync), _public(aio)
    assert sorted(s) == sorted(a)
    coroutines = 0
    for name in s:
        sm, am = s[name], a[name]
        assert type(sm) is type(am), name
        if isinstance(sm, property):
            continue
        if inspect.isfunction(sm):
            assert _signature(sm) == _signature(am), name
            assert not inspect.iscoroutinefunction(sm), name
            coroutines += inspect.iscoroutinefunction(am)
    assert coroutines >= (37 if sync is Joint else 8), coroutines


@pytest.mark.parametrize("cls", [Motor, AsyncMotor, Bus, AsyncBus, Joint, AsyncJoint, Robot, AsyncRobot])
def test_every_public_member_has_a_docstring(cls: type) -> None:
    undocumented = []
    for name, member in _public(cls).items():
        target = member.fget if isinstance(member, property) else _unwrapped(member)
        if not (inspect.isfunction(target) or isinstance(member, property)):
            continue
        if not (target.__doc__ or "").strip():
            undocumented.append(name)
    assert not undocumented, f"{cls.__name__}: {undocumented}"
    assert (cls.__doc__ or "").strip()
