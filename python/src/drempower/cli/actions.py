"""``drempower actions``: the table of actions (:mod:`drempower.actions`), and a command for each row.

``drempower actions`` lists the table (name, safety class, arguments with units
and domains, help; ``--json``). ``drempower actions NAME ARGS`` runs any row by
its table name, and a row whose name no hand-written command takes is also
``drempower NAME ARGS`` (:func:`register_rows`, called once every module has
registered its commands): a row added with :func:`drempower.actions.register`
before the parser is built is a command with no further change. Arguments are
validated by the table, so a refusal words the field, the value and its domain
as the API, the dashboard and the bridge do.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping, Sequence
from typing import Any

from .. import actions as table
from ..errors import FieldRangeError, ValidationError
from ..robot.config import JOINT_NAME
from ._connect import add_connection_args, open_from_args
from ._motion import driving
from ._output import add_json_arg, clean, emit, fmt, json_line, motors_text
from ._usage import options_named

GROUP = "motion"
"""Where ``drempower --help`` lists ``actions`` (generated commands: see :data:`GROUP_OF_SAFETY`)."""
GROUP_OF_SAFETY = {"read": "bus", "configure": "parameters", "motion": "motion", "stop": "motion"}
"""The ``--help`` heading of a generated command, by its row's safety class."""
HANDWRITTEN = {
    "state": "state",
    "errors": "errors",
    "health": "health",
    "get": "get",
    "set": "set",
    "move": "move",
    "speed": "speed",
    "torque": "torque",
    "impedance": "impedance",
    "estop": "stop",
    "idle": "idle",
    "enable": "enable",
    "clear": "clear",
    "zero": "zero",
    "save": "save",
    "reboot": "reboot",
}
"""Rows that a hand-written command carries out (with more options), by the command's name.
``drempower stop`` is the emergency stop (row ``estop``); row ``stop`` (speed 0, holding) is
``drempower actions stop``."""
GENERATED: set[str] = set()
"""The rows :func:`register_rows` made a command of (by the last parser built)."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "actions",
        help="list the table of actions (arguments, units, safety class), or run one: actions NAME ARGS",
        description=(
            "Without NAME: the table of what can be done to motors, the same in Python, the CLI and the "
            "dashboard. With NAME: run that action, e.g. drempower actions stop 1 --sim 1."
        ),
    )
    add_json_arg(p)
    rows = p.add_subparsers(dest="action_name", metavar="NAME", title="actions")
    for action in table.table():
        add_row(rows, action, action.name)
    p.set_defaults(func=run_list)


def register_rows(sub: Any) -> dict[str, str]:
    """A command for every row of the table whose name is still free; returns their ``--help`` groups."""
    from ._index import ACTION_ROWS, COMMANDS

    # the names the modules' commands take, whether or not their parsers were built this time
    taken = set(sub.choices) | {name for name, home in COMMANDS.items() if home != ACTION_ROWS}
    groups: dict[str, str] = {}
    GENERATED.clear()
    for action in table.table():
        if action.name in taken or action.name in HANDWRITTEN:
            continue
        add_row(sub, action, action.name)
        groups[action.name] = GROUP_OF_SAFETY[action.safety]
        GENERATED.add(action.name)
    return groups


def option(arg: table.Arg) -> str:
    """The command line's option of an optional argument: ``torque_ff`` -> ``--torque-ff``."""
    return "--" + arg.name.replace("_", "-")


def _arg_help(arg: table.Arg) -> str:
    text = f"{arg.help} ({arg.domain_text()})" if arg.kind in ("int", "float") or arg.choices else arg.help
    if not arg.required and arg.default is not None:
        text += f"; default {arg.default}"
    return text.replace("%", "%%")


def add_row(sub: Any, action: table.Action, name: str) -> argparse.ArgumentParser:
    """The parser of ``action``: its arguments (required ones positional, in table order), the connection."""
    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help=f"{action.help} ({action.safety})",
        description=f"{action.help[0].upper()}{action.help[1:]} (safety class: {action.safety}).",
    )
    for arg in action.args:
        dest = f"row_{arg.name}"
        if arg.name == "id":  # a motor id, or a joint's name with --robot (resolved before the command runs)
            help = _arg_help(arg) + ("; all: 0" if arg.low == 0 else "") + "; a joint's name with --robot"
            p.add_argument("ids", metavar="ID", type=_motor_word, help=help)
            p.set_defaults(robot_ids=True)
        elif arg.required:
            p.add_argument(dest, metavar=arg.name.upper(), help=_arg_help(arg))
        elif arg.kind == "bool":
            p.add_argument(
                option(arg), dest=dest, action=argparse.BooleanOptionalAction, default=None, help=_arg_help(arg)
            )
        else:
            metavar = (arg.unit or arg.name).upper().replace("%", "%%")
            p.add_argument(option(arg), dest=dest, metavar=metavar, help=_arg_help(arg))
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run_row, action_name=action.name)
    return p


def _given(args: argparse.Namespace, action: table.Action) -> dict[str, Any]:
    """The row's arguments the user gave: numbers where the text reads as one (as the dashboard sends
    them), else the text; the table types and checks them."""
    given: dict[str, Any] = {}
    for arg in action.args:
        value = args.ids[0] if arg.name == "id" else getattr(args, f"row_{arg.name}", None)
        if value is None:
            continue
        if isinstance(value, str) and arg.kind in ("int", "float"):
            value = _as_number(value)
        given[arg.name] = value
    return given


def _motor_word(text: str) -> list[Any]:
    """The ID word as ``--robot`` expects it: ``[0]`` for ``all``, ``[number]``, or ``[name]`` for a joint's
    name; other text is refused in the table's words (``id='1,2': expected a whole number``)."""
    if text.strip().lower() == "all":
        return [0]
    value = _as_number(text)
    if not isinstance(value, str):
        return [value]
    if JOINT_NAME.match(text):
        return [text]
    try:
        table.MOTOR.check(text)
    except ValidationError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return [text]  # pragma: no cover - text that is no number is always refused above


def _as_number(text: str) -> Any:
    """``"64"`` -> 64, ``"2.5"`` -> 2.5; text that is no number stays text (refused by the table)."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def check_row(
    name: str,
    ids: Sequence[int],
    each: Mapping[str, Sequence[Any]],
    shared: Mapping[str, Any],
    options: Mapping[str, str],
) -> None:
    """Check a hand-written command's values by row ``name`` of the table, for every motor of ``ids``:
    ``each`` maps a field to one value per motor, ``shared`` the fields all take (None: the row's
    default). A refusal is the table's (field range and unit), naming the option the user typed
    (``options``: field -> option, e.g. ``speed`` -> ``RPM``) and, for ``each``, the motor."""
    with options_named(options):
        for k, node in enumerate(ids):
            values = {"id": node, **shared, **{field: v[k] for field, v in each.items()}}
            try:
                table.validate(name, values)
            except FieldRangeError as exc:
                if exc.field not in each:
                    raise
                unit = table.get(name).arg(exc.field).unit
                raise FieldRangeError(f"{exc.field} (motor {node})", exc.value, exc.low, exc.high, unit) from None


def run_row(args: argparse.Namespace) -> int:
    """Row ``args.action_name`` through the command service (:class:`~drempower.actions.Service`): validated
    before the bus is opened, gated (an idle motor refused in the library's words), carried out, an enable
    or a clear confirmed, worded as every front end words it."""
    action = table.get(args.action_name)
    values = table.validate(action, _given(args, action))  # refused here: nothing is opened, nothing sent
    node = int(values["id"])
    if action.safety == "motion":  # on Ctrl-C or a failure the motor goes idle, as with move or speed
        args.ids, args.stop_on_exit = [node], True
        with driving(args) as bus:
            out = table.Service(table.OneBus(bus)).run("command line", action, values)
    else:
        with open_from_args(args) as bus:
            out = table.Service(table.OneBus(bus)).run("command line", action, values)
    show(args, node, out)
    return 0


def show(args: argparse.Namespace, node: int, out: table.Outcome) -> None:
    """What a row came to for motor ``node``: a JSON line with ``--json`` (with the unit of a number the row
    names), else the service's words (:attr:`~drempower.actions.Outcome.said`), a field a line for a record."""
    action, result, said = out.checked.action, out.plain, out.said
    name = action.name
    spec, bus = getattr(args, "robot_spec", None), getattr(args, "robot_bus", None)
    joints = {j.id: j.name for j in spec.joints_on(bus)} if spec is not None and bus is not None else {}
    if getattr(args, "json", False):
        joint = {"joint": joints[node]} if node in joints else {}
        unit = {"unit": action.result_unit} if action.result_unit and result is not None else {}
        sys.stdout.write(json_line({"id": node, **joint, "action": name, "result": result, **unit}) + "\n")
        return
    who = f"joint {joints[node]}" if node in joints else motors_text([node])
    if said is not None:
        lines = [f"{who}: {said}"]
    elif isinstance(result, dict):
        width = max((len(k) for k in result), default=0)
        lines = [f"{who}: {name}", *(f"  {k:<{width}}  {_value(v)}" for k, v in result.items())]
    else:
        lines = [f"{who}: {name}: {_value(result)}"]
    for line in lines:
        sys.stdout.write(clean(line) + "\n")


def _value(value: Any) -> str:
    if isinstance(value, list):
        return ", ".join(_value(v) for v in value)
    if isinstance(value, float):
        return fmt(value, None)
    return str(value)


def _arg_text(arg: dict[str, Any]) -> str:
    shown = arg["name"] if arg["required"] else f"[{arg['name']}]"
    return f"{shown} {arg['domain']}" if arg["kind"] in ("int", "float") or arg["choices"] else shown


def _command(name: str) -> str:
    """How the command line runs row ``name``."""
    if name in HANDWRITTEN:
        return HANDWRITTEN[name]
    if name in GENERATED:
        return name
    from ._index import ACTION_ROWS, COMMANDS

    # without a parser of every command (drempower COMMAND builds its own alone): the index says whether a
    # module's command took the name; a row registered since the index was made is a command if the name is free
    return name if COMMANDS.get(name, ACTION_ROWS) == ACTION_ROWS else f"actions {name}"


def run_list(args: argparse.Namespace) -> int:
    if args.action_name is not None:  # pragma: no cover - a row's parser sets its own func
        return run_row(args)
    rows = [table.describe(a) for a in table.table()]
    if args.json:
        emit(args, (), rows)
        return 0
    records = [
        {
            "name": r["name"],
            "safety": r["safety"],
            "command": f"drempower {_command(r['name'])}",
            "arguments": "; ".join(_arg_text(a) for a in r["args"]),
            "help": r["help"],
        }
        for r in rows
    ]
    emit(args, ("name", "safety", "command", "arguments", "help"), records)
    return 0
