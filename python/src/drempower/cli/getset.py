"""``drempower get`` and ``drempower set``: parameters by name or address, with units."""

from __future__ import annotations

import argparse
import difflib
from typing import Any

from ..client.errors import TimeoutError
from ..errors import ValidationError
from ..protocol import DataType, Parameter, find_parameter, parameter, parameters
from ..protocol.addresses import AXIS0_CONFIG_CAN_NODE_ID, CAN_CONFIG_BAUD_RATE, CONFIG_UART_BAUDRATE
from ._connect import add_connection_args, add_ids_arg, ascii_float, ascii_int, open_from_args
from ._output import add_json_arg, emit, motors_text, no_answer, report, sent, significant
from ._usage import UsageError

GROUP = "parameters"
"""Where ``drempower --help`` lists this module's subcommands."""

_ELSEWHERE = {
    AXIS0_CONFIG_CAN_NODE_ID: "drempower set-id",
    CAN_CONFIG_BAUD_RATE: "drempower set-bitrate",
    CONFIG_UART_BAUDRATE: "drempower set-bitrate --link uart",
}
"""Parameters that change how the motor is reached, and the command that changes them safely."""
_TRUE = ("1", "true", "on", "yes")
_FALSE = ("0", "false", "off", "no")


def register(sub: Any) -> None:
    g = sub.add_parser(
        "get",
        help="read parameters by name or address (units shown)",
        description=(
            "Read parameters; `drempower params` lists them. Names complete with `drempower completion`. "
            "A prefix of names (axis0.controller.config) reads the whole subtree."
        ),
    )
    add_ids_arg(g, many=False)
    g.add_argument(
        "names",
        nargs="+",
        metavar="NAME",
        help="parameter name (or its unique end) or address, e.g. vbus_voltage or 1; a prefix such as "
        "axis0.controller.config reads every parameter under it",
    )
    add_json_arg(g)
    add_connection_args(g)
    g.set_defaults(func=run_get)

    s = sub.add_parser(
        "set",
        help="write parameters by name or address (read back to verify)",
        description=(
            "Write parameters in RAM, then read them back; --save stores them in flash. Values take the "
            "parameter's type: whole numbers (0x.. allowed) for integers, on/off or 1/0 for flags."
        ),
    )
    add_ids_arg(s, many=False)
    s.add_argument("items", nargs="+", metavar="NAME VALUE", help="parameter name (or address) and value, repeated")
    s.add_argument("--save", action="store_true", help="store the configuration in flash afterwards")
    s.add_argument(
        "--force",
        action="store_true",
        help="also write parameters not meant for users to change, and values outside a soft domain",
    )
    add_json_arg(s)
    add_connection_args(s)
    s.set_defaults(func=run_set)


def lookup_many(name: str) -> list[Parameter]:
    """:func:`lookup`, or every parameter under a prefix of names (``axis0.controller.config``), in table order."""
    prefix = name.strip().rstrip(".")
    if find_parameter(name) is None and prefix:
        under = [q for q in parameters() if q.name.startswith(prefix + ".")]
        if under:
            return under
    return [lookup(name)]


def lookup(name: str) -> Parameter:
    """A parameter by name, address, or the unique end of its name (``stall_current_limit``).

    An unknown or ambiguous name is a :class:`UsageError` (exit 2) naming the closest parameters.
    """
    p = find_parameter(name)
    if p is not None:
        return p
    suffix = "." + name.strip()
    matches = [q.name for q in parameters() if q.name.endswith(suffix)]
    if len(matches) > 1:
        raise UsageError(f"parameter {name!r} could be any of {', '.join(matches)}")
    if matches:
        return parameter(matches[0])
    close = suggestions(name)
    hint = f"; did you mean {' or '.join(close)}?" if close else ""
    raise UsageError(f"unknown parameter {name!r}{hint} (`drempower params WORD` searches the table)")


def suggestions(name: str, n: int = 3) -> list[str]:
    """The parameter names (full, or their last part) closest to ``name``, best first."""
    key = name.strip().lower()
    names = [q.name for q in parameters()]
    by_short: dict[str, str] = {}
    for full in names:
        by_short.setdefault(full.rsplit(".", 1)[-1], full)
    out = difflib.get_close_matches(key, names, n=n, cutoff=0.6)
    for short in difflib.get_close_matches(key, list(by_short), n=n, cutoff=0.6):
        if by_short[short] not in out:
            out.append(by_short[short])
    # a word of a name, e.g. "gain" -> pos_gain, vel_gain...
    out += [full for full in names if key and key in full.rsplit(".", 1)[-1].split("_") and full not in out]
    return out[:n]


def parse_value(p: Parameter, text: str) -> int | float:
    """``text`` as a value of parameter ``p`` (flags accept on/off, true/false, yes/no)."""
    t = text.strip().lower()
    if p.is_bool:
        if t in _TRUE or t in _FALSE:
            return int(t in _TRUE)
        raise ValidationError(f"{p.name} is a flag: give 1/0, on/off, true/false or yes/no, not {text!r}")
    try:
        return ascii_float(t) if p.dtype is DataType.F32 else ascii_int(t, 0)
    except ValueError:
        kind = "a number" if p.dtype is DataType.F32 else f"a whole number ({p.dtype.name.lower()})"
        raise ValidationError(f"{p.name} takes {kind}, not {text!r}") from None


def _writable(p: Parameter, force: bool) -> None:
    if not p.writable:
        raise ValidationError(f"{p.name} is read-only")
    if p.address in _ELSEWHERE:
        raise ValidationError(f"{p.name} changes how the motor is reached: use `{_ELSEWHERE[p.address]}`")
    if not (p.user_settable or force):
        raise ValidationError(f"{p.name} is not meant to be changed by users (add --force to write it anyway)")


def run_get(args: argparse.Namespace) -> int:
    params = [p for n in args.names for p in lookup_many(n)]
    records = []
    silent: list[int] = []
    with open_from_args(args) as bus:
        for node in args.ids:
            motor = bus.motor(node)
            for p in params:
                value: int | float | str = "no answer"
                if node not in silent:  # a silent motor costs one timeout, not one per parameter
                    try:
                        value = significant(motor.read_property(p.address))
                    except TimeoutError:
                        # one silent motor does not hide the others: a row says so, the exit status too
                        silent.append(node)
                records.append({"id": node, "name": p.name, "address": p.address, "value": value, "unit": p.unit})
    emit(args, ("id", "name", "address", "value", "unit"), records, digits=None)
    return no_answer(silent)


def run_set(args: argparse.Namespace) -> int:
    if len(args.items) % 2:
        raise UsageError("give NAME VALUE pairs; the last name has no value")
    wanted = []
    for name, text in zip(args.items[::2], args.items[1::2], strict=True):
        p = lookup(name)
        _writable(p, args.force)
        value = parse_value(p, text)
        try:
            wanted.append((p, p.check(value, args.force)))
        except ValidationError as exc:  # outside the domain or the type's range, NaN: a usage error, nothing sent
            raise UsageError(f"argument NAME VALUE: {exc}") from None
    records = []
    with open_from_args(args) as bus:
        for node in args.ids:
            motor = bus.motor(node)
            for p, value in wanted:
                was = significant(motor.read_property(p.address))
                motor.write_property(p.address, value, verify=True, force=args.force)
                records.append({"id": node, "name": p.name, "was": was, "value": significant(value), "unit": p.unit})
            if args.save:
                motor.save_config()
    emit(args, ("id", "name", "was", "value", "unit"), records, digits=None)
    if args.save:
        report(args, f"{motors_text(args.ids)}: save sent", sent(args.ids, "save"))
    return 0
