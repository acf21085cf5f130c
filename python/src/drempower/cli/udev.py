"""``drempower udev``: udev rules for the vendor's USB-CAN adapter (Linux).

Two hardware generations exist: an older one with a CH340 USB-serial chip
(``/dev/ttyUSB*``) and a newer USB CDC one (``/dev/ttyACM*``). The rules give
either a stable name, ``/dev/drempower-usbcan`` (and one per USB port,
``/dev/drempower-usbcan-<port>``, for several adapters), and let the user at the
seat (``uaccess``) and the ``dialout`` group open it without sudo; ModemManager
is told to leave the CDC adapter alone.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

from ..errors import DrEmpowerError
from ._output import report
from ._usb import CDC, CH340

GROUP = "logs and tools"
"""Where ``drempower --help`` lists this module's subcommands."""

RULES_PATH = Path("/etc/udev/rules.d/70-drempower-usbcan.rules")
"""Where ``--install`` writes: numbered below 73 so that ``uaccess`` takes effect."""
SYMLINK = "drempower-usbcan"

_HEX4 = re.compile(r"^[0-9a-f]{4}$")


def usb_id(text: str) -> str:
    """An argument type: a USB vendor or product id, four hex digits (``0483``)."""
    t = text.strip().lower().removeprefix("0x")
    if not _HEX4.match(t):
        raise argparse.ArgumentTypeError(f"expected four hex digits such as 0483, got {text!r}")
    return t


def rules(cdc: tuple[str, str] = CDC, ch340: tuple[str, str] = CH340) -> str:
    """The rules file for the adapters with these USB (vendor, product) ids."""
    access = 'MODE="0660", GROUP="dialout", TAG+="uaccess"'
    return f"""\
# udev rules for the DrEmpower USB-CAN adapter, written by `drempower udev`.
# Install: drempower udev --install   (or copy to {RULES_PATH} and run
#   sudo udevadm control --reload-rules && sudo udevadm trigger --subsystem-match=tty)
# Then: drempower scan --serial /dev/{SYMLINK}

# CH340 generation (/dev/ttyUSB*); the CH340 chip is also used by other devices
SUBSYSTEM=="tty", ATTRS{{idVendor}}=="{ch340[0]}", ATTRS{{idProduct}}=="{ch340[1]}", {access}, \
SYMLINK+="{SYMLINK}", ENV{{DREMPOWER_USBCAN}}="1"

# USB CDC generation (/dev/ttyACM*); ModemManager must not probe it
SUBSYSTEM=="tty", ATTRS{{idVendor}}=="{cdc[0]}", ATTRS{{idProduct}}=="{cdc[1]}", {access}, \
SYMLINK+="{SYMLINK}", ENV{{ID_MM_DEVICE_IGNORE}}="1", ENV{{DREMPOWER_USBCAN}}="1"

# one name per USB port as well, for several adapters: /dev/{SYMLINK}-<port>
ENV{{DREMPOWER_USBCAN}}=="1", ENV{{ID_PATH_TAG}}=="?*", SYMLINK+="{SYMLINK}-$env{{ID_PATH_TAG}}"
"""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "udev",
        help="print (or --install) udev rules for the USB-CAN adapter: a stable /dev name, no sudo",
        description=(
            "Print udev rules for the vendor's USB-CAN adapter (CH340 ttyUSB and CDC ttyACM generations): "
            f"/dev/{SYMLINK} (and /dev/{SYMLINK}-<port> per USB port), opened without sudo by the user at the "
            f"seat and the dialout group. --install writes them to {RULES_PATH} and reloads udev (needs root). "
            "`lsusb` shows an adapter's ids if they differ: --cdc-id / --ch340-id."
        ),
    )
    p.add_argument("--install", action="store_true", help=f"write the rules to {RULES_PATH} and reload udev")
    p.add_argument("--path", type=Path, default=RULES_PATH, help=argparse.SUPPRESS)
    p.add_argument(
        "--cdc-id",
        nargs=2,
        type=usb_id,
        default=list(CDC),
        metavar=("VID", "PID"),
        help=f"USB ids of the CDC generation (default {CDC[0]} {CDC[1]})",
    )
    p.add_argument(
        "--ch340-id",
        nargs=2,
        type=usb_id,
        default=list(CH340),
        metavar=("VID", "PID"),
        help=f"USB ids of the CH340 generation (default {CH340[0]} {CH340[1]})",
    )
    p.add_argument("--json", action="store_true", help='print {"path": ..., "rules": ..., "installed": ...}')
    p.set_defaults(func=run)


def _reload() -> bool:
    """Ask udev to reload its rules and apply them to tty devices; False when udevadm is not there."""
    udevadm = shutil.which("udevadm")
    if udevadm is None:
        return False
    for argv in ([udevadm, "control", "--reload-rules"], [udevadm, "trigger", "--subsystem-match=tty"]):
        done = subprocess.run(argv, capture_output=True, text=True, timeout=30)
        if done.returncode != 0:
            raise DrEmpowerError(f"{' '.join(argv[1:])} failed: {done.stderr.strip() or done.returncode}")
    return True


def run(args: argparse.Namespace) -> int:
    text = rules((args.cdc_id[0], args.cdc_id[1]), (args.ch340_id[0], args.ch340_id[1]))
    record: dict[str, Any] = {"path": str(args.path), "rules": text, "installed": False, "reloaded": False}
    if not args.install:
        if args.json:
            report(args, "", [record])
        else:
            sys.stdout.write(text)
        return 0
    try:
        args.path.parent.mkdir(parents=True, exist_ok=True)
        args.path.write_text(text, encoding="utf-8")
    except OSError as exc:
        hint = " (run it with sudo)" if isinstance(exc, PermissionError) else ""
        raise DrEmpowerError(f"cannot write {args.path}: {exc.strerror}{hint}") from None
    record["installed"] = True
    record["reloaded"] = args.path.parent == RULES_PATH.parent and _reload()
    then = "udev reloaded; replug the adapter" if record["reloaded"] else "reload udev and replug the adapter"
    report(args, f"wrote {args.path}; {then}; it appears as /dev/{SYMLINK}", [record])
    return 0
