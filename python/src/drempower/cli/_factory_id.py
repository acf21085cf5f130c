"""``drempower doctor --factory-id``: measure the factory node id of a motor and put the motor back.

The factory id (PROTOCOL.md 3.8) shows only once the factory configuration is loaded, which
replaces the motor's own. The probe, on one motor at a time:

1. backs the configuration up (kept in a JSON file until the motor is verified);
2. sends ``init_config``, finds where the motor answers, saves the factory configuration there
   and reboots it (so the reading holds whether ``init_config`` changes the id at once or at the
   next boot), and finds where it answers after the boot: that id is the factory id;
3. restores the backup (its node id last) at that id, saves, reboots;
4. verifies that the motor answers at its own id with its configuration as backed up.

Any step that fails stops the probe: the steps done so far, the motor's state and how to
recover it are returned as findings, one per line.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from ..errors import DrEmpowerError
from ..protocol import ReadParam
from ..protocol.addresses import FW_VERSION
from ..protocol.ids import Frame
from ..protocol.limits import MAX_NODE, MIN_MOTOR
from ..protocol.parameters import DataType

WHAT = (
    "--factory-id: init_config on each motor, its factory configuration saved and the motor rebooted "
    "(it may answer at another id), then its own configuration (backed up first, node id included) "
    "restored, saved, the motor rebooted and verified at its own id"
)
"""What the probe does, listed before it runs."""

SECTION = "3.8"


@dataclass
class FactoryResult:
    """The factory id measured (None when not measured), the step lines, and whether all went well."""

    factory_id: int | None = None
    steps: list[str] = field(default_factory=list)
    ok: bool = True


class _Stop(Exception):
    """A step failed: ``state`` says where the motor is and how to recover it."""

    def __init__(self, state: str) -> None:
        super().__init__(state)
        self.state = state


def backup_path(node: int, directory: str = ".") -> str:
    """Where the probe keeps motor ``node``'s configuration until it is verified."""
    return os.path.join(directory, f"doctor-motor{node}-backup.json")


def probe_factory_id(
    bus: Any,
    node: int,
    mark: Callable[[], int],
    count_replies: Callable[[int, int], int],
    wait: Callable[[float], None],
    reboot_limit_s: float,
    directory: str = ".",
) -> FactoryResult:
    """Measure motor ``node``'s factory id and put it back; see the module's docstring.

    ``mark()`` marks the received frames, ``count_replies(id, since)`` counts the replies (not state
    frames) from ``id`` since mark ``since``, ``wait(s)`` lets time pass on the bus's clock.
    """
    res = FactoryResult()
    path = backup_path(node, directory)
    motor = bus.motor(node)
    timeout = bus.timeout

    def step(text: str) -> None:
        res.steps.append(text)

    def poll(ids: list[int]) -> list[int]:
        """The ids among ``ids`` that answer a read of the firmware version (one exchange)."""
        if not ids:
            return []
        got = bus.request([ReadParam(i, FW_VERSION, DataType.U32) for i in ids], missing_ok=True, timeout=timeout)
        return [i for i, r in zip(ids, got, strict=True) if r is not None]

    def locate(others: set[int], until_s: float) -> int:
        """Where the motor answers: ``node``, else an id no other motor held, polled until ``until_s`` s
        have passed; raises _Stop naming a shared id when it answers nowhere else."""
        free = [node] + [i for i in range(MIN_MOTOR, MAX_NODE + 1) if i != node and i not in others]
        t0 = bus.now()
        while True:
            found = poll(free)
            if found:
                return found[0]
            if bus.now() - t0 >= until_s:
                break
            wait(0.1)
        shared = []
        for other in sorted(others):
            since = mark()
            poll([other])
            wait(timeout)
            if count_replies(other, since) > 1:
                shared.append(other)
        if shared:
            raise _Stop(
                f"motor {node} answers at no free id; id {shared[0]} now answers twice, so it has most likely "
                f"taken the id of motor {shared[0]}; recover: disconnect motor {shared[0]} (or every other motor), "
                f"then `drempower restore {shared[0]} {path} --include-link --force --save` and "
                f"`drempower reboot {node}`"
            )
        raise _Stop(
            f"motor {node} answers at no id {MIN_MOTOR}-{MAX_NODE} (factory id 0, which only broadcast reaches, "
            f"or another bitrate?); recover: with it alone on the bus, find it (`drempower scan`, other bitrates), "
            f"then `drempower restore ID {path} --include-link --force --save` and `drempower reboot {node}`"
        )

    try:
        # 1. the backup, kept in a file until the end
        others = set(_present(bus)) - {node}
        try:
            cfg = motor.backup(path)
        except (DrEmpowerError, OSError) as exc:
            raise _Stop(f"motor {node} unchanged: its backup failed ({exc}); init_config was not sent") from None
        if cfg.failed:
            os.remove(path)
            raise _Stop(
                f"motor {node} unchanged: {len(cfg.failed)} parameters could not be read "
                f"({', '.join(cfg.failed[:3])}...); init_config was not sent"
            )
        step(f"backed up motor {node} ({len(cfg.parameters)} parameters) to {path}")

        # 2. the factory configuration
        motor.init_config()
        wait(timeout)
        at = locate(others, reboot_limit_s)
        step(f"init_config sent; the motor answers at id {at}")
        bus.motor(at).save_config()
        wait(timeout)
        bus.motor(at).reboot()
        step(f"factory configuration saved at id {at}, motor rebooted")
        wait(timeout)
        factory = locate(others, reboot_limit_s)
        res.factory_id = factory
        step(f"after the boot it answers at id {factory}: the factory id")

        # 3. its own configuration back, its id last
        try:
            report = bus.motor(factory).restore(cfg, include_link=True, save=True, force=True)
        except DrEmpowerError as exc:
            report = None
            why = str(exc)
        else:
            why = "; ".join(f"{n}: {r}" for n, r in report.failed[:3])
        if report is None or not report.ok or report.node != node:
            raise _Stop(
                f"motor {node} is at id {factory} with the factory configuration saved; the restore failed ({why}); "
                f"recover: `drempower restore {factory} {path} --include-link --force --save` and "
                f"`drempower reboot {node}`"
            )
        last = f", can_node_id {node} last" if factory != node else ""
        step(f"configuration restored at id {factory} ({len(report.written)} values written{last}), saved")
        motor.reboot()
        wait(timeout)
        back = locate(others, reboot_limit_s)
        if back != node:
            raise _Stop(
                f"motor {node} answers at id {back} after the restore and reboot; recover: "
                f"`drempower restore {back} {path} --include-link --force --save` and `drempower reboot {node}`"
            )

        # 4. verified as it was
        diff = motor.restore(cfg, include_link=True, dry_run=True)
        if diff.written or not diff.ok:
            names = [n for n, _, _ in diff.written] + [n for n, _ in diff.failed]
            raise _Stop(
                f"motor {node} answers at its id but its configuration differs from the backup "
                f"({', '.join(names[:3])}); recover: `drempower restore {node} {path} --save`"
            )
        step(f"rebooted: answers at id {node}, configuration as backed up ({len(diff.unchanged)} values compared)")
        os.remove(path)
    except _Stop as stop:
        res.ok = False
        step(f"FAILED: {stop.state}")
    except DrEmpowerError as exc:
        res.ok = False
        step(f"FAILED: {exc}; {_recover(node, path)}")
    except BaseException:  # interrupted (Ctrl-C...): no record will be printed, so say it here
        if os.path.exists(path):
            done = "; ".join(res.steps) or "nothing done"
            print(
                f"drempower: motor {node}: factory-id probe interrupted ({done}); {_recover(node, path)}",
                file=sys.stderr,
            )
        raise
    return res


def _recover(node: int, path: str) -> str:
    return (
        f"motor {node}'s configuration is in {path}; recover: find the motor (`drempower scan`), "
        f"then `drempower restore ID {path} --include-link --force --save` and `drempower reboot {node}`"
    )


def _present(bus: Any) -> list[int]:
    """Every id 1..63 that answers a read of the firmware version (one exchange)."""
    ids = list(range(MIN_MOTOR, MAX_NODE + 1))
    got = bus.request([ReadParam(i, FW_VERSION, DataType.U32) for i in ids], missing_ok=True)
    return [i for i, r in zip(ids, got, strict=True) if r is not None]


def count_replies(frames: list[Frame], node: int) -> int:
    """Frames from ``node`` that are not state frames (bit 0 clear)."""
    return sum(1 for f in frames if f.arbitration_id >> 5 == node and not f.arbitration_id & 1)
