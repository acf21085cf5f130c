"""Find the motors on the bus, then back up each one's configuration to JSON.

Restore later with ``bus.motor(i).restore("motor-1.json")`` (read-only, live
and link parameters are skipped; differences and failures are reported).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from _common import open_bus, parser


def main() -> None:
    p = parser(__doc__ or "", ids="1,2,3")
    p.add_argument("--out", type=Path, help="directory for the JSON files (default: a temporary one)")
    args = p.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="drempower-backup-"))
    out.mkdir(parents=True, exist_ok=True)
    with open_bus(args, stop_on_close=False) as bus:
        found = bus.scan(versions=True)
        print(f"{len(found)} motor(s) found")
        for info in found:
            print(f"  id {info.id}: hw {info.hw_version}, fw {info.fw_version}, at {info.state.angle:.2f} deg")
            path = out / f"motor-{info.id}.json"
            backup = bus.motor(info.id).backup(path)
            print(f"    {len(backup.parameters)} parameters -> {path} ({len(backup.failed)} unreadable)")
            check = bus.motor(info.id).restore(path, dry_run=True)
            print(f"    restore would change {len(check.written)} parameter(s)")


if __name__ == "__main__":
    main()
