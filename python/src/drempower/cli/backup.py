"""``drempower backup``, ``restore`` and ``diff``: a motor's configuration to a JSON file and back."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from ..client import ConfigBackup, RestoreReport
from ..errors import BackupFileError, DrEmpowerError, ValidationError
from ..protocol import find_parameter
from ._connect import add_connection_args, motor_id, open_from_args
from ._output import add_json_arg, clean, emit, report, significant
from ._usage import UsageError, cli_words

GROUP = "parameters"
"""Where ``drempower --help`` lists this module's subcommands."""


def register(sub: Any) -> None:
    b = sub.add_parser(
        "backup",
        help="read every parameter of a motor into a JSON file",
        description="Read every parameter of a motor and write them, with names, types and units, to FILE.",
    )
    b.add_argument("id", type=motor_id, metavar="ID", help="the motor's id")
    b.add_argument("file", metavar="FILE", help="JSON file to write; - writes it to stdout")
    add_json_arg(b)
    add_connection_args(b)
    b.set_defaults(func=run_backup)

    r = sub.add_parser(
        "restore",
        help="write a backup's configuration back to a motor (only what differs; verified)",
        description=(
            "Write the writable configuration of a backup to a motor: only values that differ are written, "
            "then read back. Live values and commands are never written; the id and bitrates only with "
            "--include-link."
        ),
    )
    d = sub.add_parser(
        "diff",
        help="show how a motor's configuration differs from a backup",
        description=(
            "Compare the writable configuration of a motor with a backup; nothing is written. "
            "Exit status (as diff(1)): 0 when they match, 1 when they differ, 2 on trouble."
        ),
    )
    for p in (r, d):
        p.add_argument("id", type=motor_id, metavar="ID", help="the motor's id")
        p.add_argument("file", metavar="FILE", help="backup file (written by `drempower backup`); - reads stdin")
        p.add_argument(
            "--include-link",
            action="store_true",
            help="also the id and bitrates: written last, after everything else is verified",
        )
        p.add_argument(
            "--force", action="store_true", help="accept a backup of another motor id or with duplicated records"
        )
        add_json_arg(p)
        add_connection_args(p)
    r.add_argument("--save", action="store_true", help="store the configuration in flash when all went well")
    r.set_defaults(func=run_restore)
    d.set_defaults(func=run_diff)


def run_backup(args: argparse.Namespace) -> int:
    with open_from_args(args) as bus:
        cfg = bus.motor(args.id).backup()
    to_stdout = args.file == "-"
    try:
        if to_stdout:
            sys.stdout.write(json.dumps(cfg.to_json(), indent=1) + "\n")
            sys.stdout.flush()
        else:
            cfg.save(args.file)
    except OSError as exc:
        raise ValidationError(f"cannot write {args.file}: {exc.strerror}") from None
    read = len(cfg.parameters) - len(cfg.failed)
    unread = f" ({len(cfg.failed)} unreadable: {', '.join(cfg.failed)})" if cfg.failed else ""
    where = "stdout" if to_stdout else args.file
    text = f"motor {args.id}: {read} parameters written to {where}{unread}"
    if to_stdout:  # stdout holds the backup: the summary goes to stderr
        print(text, file=sys.stderr)
    else:
        record = {"id": args.id, "file": args.file, "parameters": read, "unreadable": list(cfg.failed)}
        report(args, text, [record])
    if cfg.failed:  # the file is incomplete: the exit status says so
        hint = "" if getattr(args, "retries", 0) else "; on a lossy link, --retries N asks again"
        print(f"drempower: motor {args.id}: {len(cfg.failed)} parameters unread{hint}", file=sys.stderr)
        return 1
    return 0


def _unit(name: str) -> str:
    p = find_parameter(name)
    return p.unit if p is not None else ""


def _load(path: str) -> ConfigBackup:
    """The backup in ``path``, or on stdin for ``-``."""
    if path != "-":
        return ConfigBackup.load(path)
    try:
        doc = json.loads(sys.stdin.read())
    except (ValueError, RecursionError) as exc:
        raise BackupFileError(f"cannot read the backup on stdin: {exc}") from None
    return ConfigBackup.from_json(doc)


def _restore(args: argparse.Namespace, dry_run: bool) -> RestoreReport:
    cfg = _load(args.file)
    force = args.force or dry_run  # diff writes nothing: comparing a motor with another's backup is fine
    with open_from_args(args) as bus:
        return bus.motor(args.id).restore(
            cfg, include_link=args.include_link, save=getattr(args, "save", False), dry_run=dry_run, force=force
        )


def run_diff(args: argparse.Namespace) -> int:
    try:
        result = _restore(args, dry_run=True)
    except UsageError:
        raise
    except DrEmpowerError as exc:  # as diff(1): 2 is trouble, 1 means "they differ"
        print(clean(f"drempower: error: {cli_words(str(exc))}"), file=sys.stderr)
        return 2
    records = [
        {"name": n, "motor": significant(old), "backup": significant(new), "unit": _unit(n)}
        for n, old, new in result.written
    ]
    emit(args, ("name", "motor", "backup", "unit"), records, digits=None)
    if not records and not result.failed:
        same = {"id": args.id, "file": args.file, "matches": True}
        report(args, f"motor {args.id}: configuration matches {args.file}", [same])
    for name, why in result.failed:
        print(clean(f"{name}: not compared: {why}"), file=sys.stderr)
    if result.failed:  # as diff(1): trouble (2) outranks "they differ" (1)
        print(
            f"drempower: motor {args.id}: {len(result.failed)} parameters not compared"
            "; on a lossy link, --retries N asks again",
            file=sys.stderr,
        )
        return 2
    return 1 if records else 0


def run_restore(args: argparse.Namespace) -> int:
    result = _restore(args, dry_run=False)
    records = [
        {"name": n, "was": significant(old), "now": significant(new), "unit": _unit(n)}
        for n, old, new in result.written
    ]
    emit(args, ("name", "was", "now", "unit"), records, digits=None)
    written, unchanged = len(result.written), len(result.unchanged)
    summary = {"id": args.id, "file": args.file, "written": written, "unchanged": unchanged, "saved": result.saved}
    saved = ", saved" if result.saved else ""
    moved = f", now motor {result.node}" if result.node != args.id else ""
    if moved:
        summary["now_id"] = result.node
    report(args, f"motor {args.id}: {written} written, {unchanged} unchanged{saved}{moved}", [summary])
    if result.failed:
        raise DrEmpowerError(
            f"motor {args.id}: {len(result.failed)} not restored: "
            + "; ".join(f"{name}: {why}" for name, why in result.failed)
        )
    return 0
