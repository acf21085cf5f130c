"""The shared client-behaviour vectors (spec/vectors/client/*.json) against :class:`BusSession`.

Each vector is a script on integer milliseconds (see spec/vectors/README.md,
"Client behaviour vectors"). Time is the script's: the session is given every
deadline it asks for up to each step's time, as a driver would, and never
sleeps. The C library runs the same files (c/tests/test_client_vectors.c).
"""

from __future__ import annotations

import json
from collections.abc import Generator
from pathlib import Path
from typing import Any

import pytest

from drempower.client.engine import ops
from drempower.client.engine.effects import Batch, Op, read_states, request
from drempower.client.engine.session import BusSession, Operation
from drempower.errors import MoveError, MoveFaultError, TimeoutError
from drempower.protocol import StartKind
from drempower.protocol.ids import Frame
from drempower.protocol.messages import ReadParam, Start
from drempower.protocol.parameters import DataType

from ...conftest import REPO_ROOT
from ...protocol.vectors import build

CLIENT_DIR = REPO_ROOT / "spec" / "vectors" / "client"
EPS = 1e-9
"""Every duration given to the session is 1 ns short of its whole milliseconds, so that
binary rounding of ms / 1000 never moves a deadline past the millisecond it falls on."""


def _load() -> list[tuple[str, dict[str, Any]]]:
    out = []
    for path in sorted(CLIENT_DIR.glob("*.json")):
        for vec in json.loads(path.read_text(encoding="utf-8"))["vectors"]:
            if "python" in vec.get("implementations", ["python", "c"]):
                out.append((path.name, vec))
    return out


VECTORS = _load()


def _s(ms: int) -> float:
    """A duration of ``ms`` milliseconds in seconds (see :data:`EPS`)."""
    return ms / 1000 - EPS


def _frame(f: dict[str, Any]) -> Frame:
    return Frame(f["id"], bytes.fromhex(f["data"]))


def _read(node: int, address: int, dtype: str) -> Op[Any]:
    (reply,) = yield from request([ReadParam(node, address, DataType[dtype.upper()])])
    return reply.value


def _get_state(node: int) -> Op[Any]:
    (st,) = yield from read_states([node])
    return st


def _preset_start(step: dict[str, Any]) -> Op[Any]:
    """A batch as ``move_angles`` yields it: each absolute position move's target is its preset's
    position, and a Q preset's time is the planned move time."""
    presets = [build(p["message"], p["node"], p["fields"]) for p in step["presets"]]
    kind = StartKind[step["start"]["kind"].upper()]
    relative = step["start"]["relative"]
    start = Start(0, kind, relative)
    position = kind in (StartKind.T, StartKind.Q, StartKind.P)
    targets = [p["fields"]["position"] for p in step["presets"]] if position and not relative else None
    times = [p["fields"]["time"] for p in step["presets"] if p["message"] == "preset_q"]
    where: Any = yield Batch(presets, start, targets, times[0] if times else None)
    return where


def _operation(session: BusSession, step: dict[str, Any]) -> Generator[Any, Any, Any]:
    do = step["do"]
    if do == "read":
        return _read(step["node"], step["address"], step["dtype"])
    if do == "get_state":
        return _get_state(step["node"])
    if do == "preset_start":
        return _preset_start(step)
    if do == "wait_done":
        return ops.wait_done(session, step["nodes"], _s(step["timeout_ms"]), _s(step["poll_ms"]))
    raise AssertionError(f"unknown action {do!r}")


def _status(opn: Operation[Any]) -> str:
    if not opn.done:
        return "pending"
    err = opn.error
    if err is None:
        return "ok"
    if isinstance(err, MoveFaultError):
        return "fault"
    if isinstance(err, TimeoutError):
        return "timeout"
    if isinstance(err, MoveError):
        return "move_error"
    raise AssertionError(f"unexpected error {err!r}")


def _check(opn: Operation[Any], want: dict[str, Any], where: str) -> None:
    assert _status(opn) == want["status"], f"{where}: {opn.error!r}"
    if want["status"] != "ok":
        return
    value = opn.result()
    if isinstance(value, dict) and len(value) == 1:  # a one-motor wait_done: {node: state}
        (value,) = value.values()
    if "value" in want:
        assert value == want["value"], where
    if "position" in want:
        assert value.angle == pytest.approx(want["position"], abs=1e-4), where
    if "trajectory_done" in want:
        assert value.trajectory_done is want["trajectory_done"], where


def _motors(item: object) -> set[int]:
    """Every motor a vector names: its bus's motors (so a move of all of them may start by broadcast)."""
    found: set[int] = set()
    if isinstance(item, dict):
        for key, value in item.items():
            if key == "node" and isinstance(value, int) and value > 0:
                found.add(value)
            elif key == "nodes" and isinstance(value, list):
                found.update(n for n in value if isinstance(n, int) and n > 0)
            else:
                found |= _motors(value)
    elif isinstance(item, list):
        for value in item:
            found |= _motors(value)
    return found


def run_vector(vec: dict[str, Any]) -> None:
    """Run one vector against a fresh session; AssertionError names the step that differs."""
    cfg = vec["config"]
    session = BusSession(
        timeout=_s(cfg["timeout_ms"]),
        retries=cfg.get("retries", 0),
        tx=cfg.get("tx", "in_order"),
        zero_reply_grace=_s(10),
        motor_ids=_motors(vec),
        now=0.0,
    )
    written: list[Frame] = []
    ops_by_name: dict[str, Operation[Any]] = {}

    def pump() -> None:
        written.extend(session.data_to_send())

    def run_until(now: float) -> None:
        # every deadline on the way, in order, as a driver's loop would
        while (due := session.next_deadline()) is not None and due <= now:
            session.advance(due)
            pump()
        session.advance(now)
        pump()

    for i, step in enumerate(vec["steps"]):
        where = f"step {i} at {step['at']} ms"
        now = step["at"] / 1000
        run_until(now)
        if "do" in step:
            if step["do"] == "send":
                session.send([build(m["message"], m["node"], m["fields"]) for m in step["messages"]])
            else:
                ops_by_name[step["req"]] = session.submit(_operation(session, step))
            pump()
        elif "rx" in step:
            session.receive(_frame(step["rx"]), now)
            pump()
        elif "tx_done" in step:
            session.transmitted(now, True)
            pump()
        elif "tx" in step:
            want = [_frame(f) for f in step["tx"]]
            assert written == want, f"{where}: frames written"
            written.clear()
        elif "expect" in step:
            for name, outcome in step["expect"].items():
                _check(ops_by_name[name], outcome, f"{where}, {name}")
            counts = step.get("counts", {})
            if "unmatched" in counts:
                assert session.unmatched == counts["unmatched"], f"{where}: unmatched"
            if "anomalies" in counts:
                assert session.anomalies == counts["anomalies"], f"{where}: anomalies"
        else:
            raise AssertionError(f"{where}: unknown step {step}")


def test_every_category_has_vectors() -> None:
    files = {f for f, _ in VECTORS}
    assert {"matching.json", "timeouts.json", "presets.json", "done.json", "grace.json"} <= files


@pytest.mark.parametrize(("file", "vec"), VECTORS, ids=[f"{f}:{v['name']}" for f, v in VECTORS])
def test_client_vector(file: str, vec: dict[str, Any]) -> None:
    run_vector(vec)


def test_a_changed_expectation_fails() -> None:
    """The runner is not blind: the first vector with an answered read, its value changed, fails."""
    _, vec = next((f, v) for f, v in VECTORS if f == "matching.json")
    broken = json.loads(json.dumps(vec))
    for step in broken["steps"]:
        for outcome in step.get("expect", {}).values():
            if "value" in outcome:
                outcome["value"] += 1
    with pytest.raises(AssertionError):
        run_vector(broken)


def test_vectors_dir_holds_only_json() -> None:
    assert all(p.suffix == ".json" for p in Path(CLIENT_DIR).iterdir())
