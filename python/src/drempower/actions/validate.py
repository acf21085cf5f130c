"""Arguments checked and typed for a row, and a row carried out on a bus."""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any

from ..errors import ValidationError
from ..protocol.parameters import find_parameter
from .args import _REQUIRED, _either
from .table import Action, get


def validate(action: Action | str, args: Mapping[str, Any]) -> dict[str, Any]:
    """``args`` checked and typed for ``action`` (defaults filled in); the first bad one raises,
    naming the field, the value and its domain. Nothing is sent."""
    act = get(action) if isinstance(action, str) else action
    if not isinstance(args, Mapping):
        raise ValidationError(f"{act.name}: arguments are a mapping of names to values, got {args!r}")
    names = {a.name for a in act.args}
    unknown = [k for k in args if k not in names]
    if unknown:
        listed = ", ".join(a.name for a in act.args)
        raise ValidationError(f"{act.name}: no argument {unknown[0]!r}; its arguments are {listed}")
    out: dict[str, Any] = {}
    for a in act.args:
        if a.name in args and args[a.name] is not None:
            out[a.name] = a.check(args[a.name])
        elif a.required:
            raise ValidationError(f"{act.name}: {a.name} is missing ({a.help}, {a.domain_text()})")
        else:
            out[a.name] = a.default
    _modes(act, args, out)
    if "name" in out:
        key: str | int = int(out["name"]) if out["name"].isdigit() else out["name"]
        p = find_parameter(key)
        if p is None:
            raise ValidationError(f"name={out['name']!r}: no such parameter (see spec/parameters.csv)")
        out["name"] = p.name
        if "value" in out:
            given = args["value"]
            whole = isinstance(given, int) or (isinstance(given, str) and given.strip().lstrip("-").isdigit())
            value = int(out["value"]) if whole else out["value"]
            out["value"] = p.check(value, bool(out.get("force")))  # its own domain, named
    return out


def _modes(act: Action, args: Mapping[str, Any], out: dict[str, Any]) -> None:
    """Settle the row's ``mode`` (given; else its default, or the one mode the arguments given belong to)
    and its arguments: another mode's given is refused, its own missing takes its default (none: it is
    missing), the other modes' are None."""
    tagged = [a for a in act.args if a.modes]
    if not tagged:
        return
    choices = act.arg("mode")
    given = [a for a in tagged if args.get(a.name) is not None]
    if args.get("mode") is None:
        fits = [m for m in choices.choices if all(m in a.modes for a in given)]
        if not fits:
            named = ", ".join(f"{a.name} (mode {_either(a.modes)})" for a in given)
            raise ValidationError(f"{act.name}: {named}: the arguments of one mode only")
        out["mode"] = choices.default if choices.default in fits else fits[0]
    mode = out["mode"]
    for a in tagged:
        if mode not in a.modes:
            if a in given:
                raise ValidationError(f"{act.name}: {a.name} applies to mode {_either(a.modes)}, not {mode}")
            out[a.name] = None
        elif out[a.name] is _REQUIRED:
            raise ValidationError(f"{act.name}: {a.name} is missing ({a.help}, {a.domain_text()})")


def run(bus: Any, action: Action | str, args: Mapping[str, Any]) -> Any:
    """Validate ``args`` and carry ``action`` out on a threaded bus; returns what its operation returns."""
    act = get(action) if isinstance(action, str) else action
    return act.operation(bus, validate(act, args))


async def run_async(bus: Any, action: Action | str, args: Mapping[str, Any]) -> Any:
    """:func:`run` on an asyncio bus (or a threaded one: a result that is no awaitable is returned as is)."""
    act = get(action) if isinstance(action, str) else action
    result = act.operation(bus, validate(act, args))
    if inspect.isawaitable(result):
        return await result
    return result
