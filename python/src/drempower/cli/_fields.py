"""``monitor --fields``: chosen state channels and parameters, captured by polling, heartbeats or state replies."""

from __future__ import annotations

import argparse
import csv
import itertools
import queue
import sys
import time
from collections.abc import Callable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from typing import Any

from ..client import Bus, MotorState
from ..errors import DrEmpowerError
from ..naming import COLUMNS, TIME_COLUMN
from ..protocol import FastRead, ReadParam
from ..protocol.addresses import (
    AXIS0_ERROR,
    AXIS0_FET_THERMISTOR_TEMPERATURE,
    AXIS0_MOTOR_CONFIG_CURRENT_LIM,
    AXIS0_MOTOR_EFFECTIVE_CURRENT_LIM,
    AXIS0_MOTOR_THERMISTOR_TEMPERATURE,
    CAN_CONFIG_HEARTBEAT_MS,
)
from ..protocol.flags import decode_error_word
from ..protocol.parameters import Parameter, find_parameter
from ._output import LiveView, is_terminal, json_line, render_table

__all__ = ["COLUMNS", "HEALTH_FIELDS", "STATE_FIELDS", "SOURCES", "Field", "parse_fields", "run_fields"]

_HEARTBEAT = CAN_CONFIG_HEARTBEAT_MS

STATE_FIELDS: dict[str, tuple[str, Callable[[MotorState], object]]] = {
    "position": ("deg", lambda s: s.angle),
    "speed": ("rpm", lambda s: s.speed),
    "torque": ("Nm", lambda s: s.torque),
    "done": ("", lambda s: s.trajectory_done),
    "error": ("", lambda s: s.error),
}
"""The channels of a state frame: name -> (unit, value)."""

_ALIASES = {key: name for name, (key, _) in COLUMNS.items()} | {"vbus": "vbus_voltage"}
"""``position_deg`` -> ``position``, ``vbus_v`` and ``vbus`` -> ``vbus_voltage``: every name --fields accepts."""

SOURCES = ("poll", "heartbeat", "replies")
"""poll: fast reads at --rate; heartbeat: the motors send their state every 1/--rate s;
replies: only the states other programs' commands make the motors send (enable_reply_state)."""


def _derating(values: Sequence[float | None]) -> float | None:
    lim, base = values
    if lim is None or base is None:
        return None
    return round(min(1.0, max(0.0, 1.0 - lim / base)), 4) if base > 0 else 0.0


def _errors(values: Sequence[float | None]) -> str | None:
    (word,) = values
    return None if word is None else " ".join(decode_error_word("axis", int(word))) or "none"


HEALTH_FIELDS: dict[str, tuple[str, tuple[int, ...], Callable[[Sequence[float | None]], object]]] = {
    "motor_temp_c": ("", (AXIS0_MOTOR_THERMISTOR_TEMPERATURE,), lambda v: v[0]),
    "driver_temp_c": ("", (AXIS0_FET_THERMISTOR_TEMPERATURE,), lambda v: v[0]),
    "current_limit_a": ("", (AXIS0_MOTOR_EFFECTIVE_CURRENT_LIM,), lambda v: v[0]),
    "derating": ("", (AXIS0_MOTOR_EFFECTIVE_CURRENT_LIM, AXIS0_MOTOR_CONFIG_CURRENT_LIM), _derating),
    "errors": ("", (AXIS0_ERROR,), _errors),
}
"""The health keys (``drempower health``): name -> (unit, the parameters read, the value from them)."""


@dataclass(frozen=True)
class Field:
    """One column: a state channel, a parameter read at the poll rate, or a health key (``reads``)."""

    name: str
    unit: str
    parameter: Parameter | None = None
    reads: tuple[int, ...] = ()

    @property
    def is_state(self) -> bool:
        """A channel of the state frame (no parameter read)."""
        return self.parameter is None and not self.reads

    def addresses(self) -> tuple[int, ...]:
        """The parameters this field reads each sample."""
        return (self.parameter.address,) if self.parameter is not None else self.reads

    def value(self, got: Sequence[float | None]) -> object:
        """The column's value from the values read for it."""
        if self.parameter is not None:
            return got[0]
        return HEALTH_FIELDS[self.name][2](got)

    @property
    def key(self) -> str:
        """The JSON and CSV key: that of :data:`COLUMNS`, else the parameter's name."""
        return COLUMNS[self.name][0] if self.name in COLUMNS else self.name

    @property
    def header(self) -> str:
        if self.name in COLUMNS:
            return COLUMNS[self.name][1]
        return f"{self.name}/{self.unit}" if self.unit else self.name


def parse_fields(text: str) -> list[Field]:
    """``"position,speed,vbus_v"`` -> fields; an unknown name is an error naming the choices."""
    out: list[Field] = []
    for given in filter(None, (n.strip() for n in text.split(","))):
        name = _ALIASES.get(given, given)
        if name in STATE_FIELDS:
            out.append(Field(name, STATE_FIELDS[name][0]))
            continue
        if name in HEALTH_FIELDS:
            out.append(Field(name, HEALTH_FIELDS[name][0], None, HEALTH_FIELDS[name][1]))
            continue
        p = find_parameter(name)
        if p is None:
            raise argparse.ArgumentTypeError(
                f"field {given!r} is neither a state channel ({', '.join(STATE_FIELDS)}, or "
                f"{', '.join(COLUMNS[c][0] for c in STATE_FIELDS)}), a health key ({', '.join(HEALTH_FIELDS)}) "
                "nor a parameter name or address "
                "(see drempower params)"
            )
        out.append(Field(p.name, p.unit or "", p))
    if not out:
        raise argparse.ArgumentTypeError("--fields: give at least one field")
    return out


class _Capture:
    """Latest values per motor, and how many state samples each motor delivered."""

    def __init__(self, ids: Sequence[int], fields: Sequence[Field]) -> None:
        self.ids = list(ids)
        self.fields = list(fields)
        self.values: dict[int, dict[str, object]] = {i: {} for i in ids}
        self.samples = dict.fromkeys(ids, 0)
        self.events: queue.SimpleQueue[tuple[float, int]] = queue.SimpleQueue()

    def state(self, st: MotorState) -> None:
        if st.node not in self.values:
            return
        row = self.values[st.node]
        for f in self.fields:
            if f.is_state:
                row[f.name] = STATE_FIELDS[f.name][1](st)
        self.samples[st.node] += 1
        self.events.put((st.timestamp, st.node))


def run_fields(args: argparse.Namespace, bus: Bus, out: Any) -> int:
    """The ``--fields``/``--source`` mode of monitor: one record per sample, the achieved rate shown."""
    ids: list[int] = args.ids
    fields: list[Field] = args.fields
    params = [f for f in fields if not f.is_state]
    need_state = any(f.is_state for f in fields)
    cap = _Capture(ids, fields)
    live = LiveView(out) if is_terminal(out) and not args.json else None
    headers = [TIME_COLUMN[1], "id", *(f.header for f in fields)]
    keys = [TIME_COLUMN[0], "id", *(f.key for f in fields)]
    start = time.monotonic()
    deadline = None if args.duration is None else start + args.duration
    beating: list[int] = []
    k = 0
    printed_header = False
    with ExitStack() as stack:
        writer: csv.DictWriter[str] | None = None
        if args.csv:
            try:
                fh = stack.enter_context(open(args.csv, "w", newline="", encoding="utf-8"))
            except OSError as exc:
                raise DrEmpowerError(f"cannot write {args.csv}: {exc.strerror}") from None
            writer = csv.DictWriter(fh, keys)
            writer.writeheader()
        stack.enter_context(bus.subscribe(cap.state))
        try:
            if args.source == "heartbeat" and need_state:
                period = max(1, round(1000 / args.rate))
                for i in ids:
                    bus.motor(i).write_property(_HEARTBEAT, period)
                    beating.append(i)
            while True:
                now = time.monotonic()
                if deadline is not None and now >= deadline:
                    break
                reads = [ReadParam.of(i, a) for i in ids for f in params for a in f.addresses()]
                polls = [FastRead(i) for i in ids] if args.source == "poll" and need_state else []
                if reads or polls:
                    answers = iter(bus.request([*polls, *reads], missing_ok=True)[len(polls) :])
                    for i in ids:
                        for f in params:
                            got = [
                                None if a is None else a.value for a in itertools.islice(answers, len(f.addresses()))
                            ]
                            cap.values[i][f.name] = f.value(got)
                    if not need_state:
                        for i in ids:
                            cap.events.put((time.monotonic(), i))
                records = []
                while True:
                    try:
                        t, node = cap.events.get_nowait()
                    except queue.Empty:
                        break
                    values = cap.values[node]
                    records.append(
                        {TIME_COLUMN[0]: round(t - start, 4), "id": node, **{f.key: values.get(f.name) for f in fields}}
                    )
                if writer is not None:
                    writer.writerows(records)
                took = max(time.monotonic() - start, 1e-9)
                rates = {i: (cap.samples[i] if need_state else k + 1) / took for i in ids}
                if args.json:
                    out.write("".join(json_line(r) + "\n" for r in records))
                elif live is not None:
                    elapsed = round(time.monotonic() - start, 2)
                    rows = [[elapsed, i, *(cap.values[i].get(f.name) for f in fields)] for i in ids]
                    rate = ", ".join(f"{i}: {r:.0f} Hz" for i, r in rates.items())
                    live.draw([f"{args.source}: achieved {rate}", *render_table(headers, rows, digits=None)])
                else:
                    lines = render_table(headers, [[r.get(key) for key in keys] for r in records], digits=None)
                    out.write("\n".join(lines[0 if not printed_header else 1 :]) + ("\n" if records else ""))
                    printed_header = printed_header or bool(records)
                out.flush()
                k += 1
                due = start + k / (args.rate if args.source == "poll" or params else min(args.rate, 10.0))
                if deadline is not None:
                    due = min(due, deadline)
                time.sleep(max(0.0, due - time.monotonic()))
        except KeyboardInterrupt:
            pass
        finally:
            for i in beating:  # stop what this command started
                try:
                    bus.motor(i).write_property(_HEARTBEAT, 0)
                except DrEmpowerError as exc:
                    print(f"drempower: motor {i}: could not stop its heartbeat: {exc}", file=sys.stderr)
    took = max(time.monotonic() - start, 1e-9)
    rate = ", ".join(f"motor {i} {(cap.samples[i] if need_state else k) / took:.1f}" for i in ids)
    print(f"achieved samples/s ({args.source}): {rate}", file=sys.stderr)
    return 0
