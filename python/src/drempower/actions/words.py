"""How every front end words a row and what running it came to."""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Mapping
from typing import Any

from ..naming import number_text
from .args import _REQUIRED
from .table import Action, get


def describe(action: Action | str) -> dict[str, Any]:
    """A row as JSON-ready data (what ``drempower actions --json`` prints and the dashboard builds its
    Actions panel from): name, safety, help, what a number it returns means and its unit, and each
    argument's name, kind, unit, domain, default."""
    act = get(action) if isinstance(action, str) else action
    return {
        "name": act.name,
        "safety": act.safety,
        "help": act.help,
        "result": act.result,
        "result_unit": act.result_unit,
        "args": [
            {
                "name": a.name,
                "kind": a.kind,
                "unit": a.unit,
                "low": a.low,
                "high": a.high,
                "required": a.required,
                "default": None if a.default is _REQUIRED else a.default,
                "choices": list(a.choices),
                "modes": list(a.modes),
                "help": a.help,
                "domain": a.domain_text(),
            }
            for a in act.args
        ],
    }


def outcome(action: Action | str, result: Any) -> str | None:
    """What running ``action`` came to, as every front end words it after the row's name: a command
    is ``" sent"`` (it was sent, which is not "done": a motion command returns before the motor gets
    there), with the number it returned named in its unit, e.g. ``" sent (move time 1.42 s)"``; a read
    is ``": "`` and its value (numbers as :func:`~drempower.naming.number_text` shows them). None for
    a record or a list, which each front end shows in its own form (rows, JSON)."""
    act = get(action) if isinstance(action, str) else action
    if result is None:
        return " sent" if act.safety != "read" else ": none"
    if isinstance(result, (dict, list, tuple)) or hasattr(result, "_asdict") or dataclasses.is_dataclass(result):
        return None
    value = number_text(result, None) if isinstance(result, float) else str(plain(result))
    if act.result:
        value = f"{act.result} {value}"
    if act.result_unit:
        value = f"{value} {act.result_unit}"
    return f" sent ({value})" if act.safety != "read" else f": {value}"


def plain(result: Any) -> Any:
    """What an operation returned, as JSON-ready values: a record (named tuple, dataclass) a dict of
    its fields (and its ``flags`` if it has them), a tuple a list, an enum its name, numbers as they are."""
    if result is None or isinstance(result, (bool, int, float, str)):
        return result
    if isinstance(result, enum.Enum):
        return result.name.lower()
    if hasattr(result, "_asdict"):
        return {k: plain(v) for k, v in result._asdict().items()}
    if dataclasses.is_dataclass(result) and not isinstance(result, type):
        out = {f.name: plain(getattr(result, f.name)) for f in dataclasses.fields(result)}
        flags = getattr(result, "flags", None)
        if isinstance(flags, dict):
            out["flags"] = plain(flags)
        return out
    if isinstance(result, Mapping):
        return {str(k): plain(v) for k, v in result.items()}
    if isinstance(result, (list, tuple, set, frozenset)):
        return [plain(v) for v in result]
    return str(result)
