"""What the dashboard set moving: the targets plotted beside the samples, and who commanded each motor."""

from __future__ import annotations

from typing import Any

from .. import actions
from ..client.engine.stops import hold_frames
from ..errors import DrEmpowerError
from .keys import MotorKeys
from .logline import log

__all__ = ["Targets"]


class Targets:
    """Per motor key: its target (angle deg, speed r/min, torque Nm; None: none), whether this dashboard
    commanded it, and the page that last set it moving."""

    def __init__(self, keys: MotorKeys) -> None:
        self._keys = keys
        self.targets: dict[int, list[float | None]] = {}
        self.commanded: set[int] = set()
        self.commanders: dict[int, str] = {}
        """Per motor key, the page that last set it moving (see :meth:`idle_of`)."""

    def set(self, i: int, angle: float | None = None, speed: float | None = None, torque: float | None = None) -> None:
        """Motor ``i`` was commanded towards these targets."""
        self.targets[i] = [angle, speed, torque]
        self.commanded.add(i)

    def base(self, key: int) -> float:
        """Where a relative move starts from: the last target, else the last angle read."""
        base = self.targets.get(key, [None])[0]
        if base is None:
            st = self._keys.motor(key).state
            base = st.angle if st is not None else 0.0
        return base

    def track(self, who: str, act: actions.Action, key: int, typed: dict[str, Any], base: float) -> None:
        """Keep the targets and the motors commanded (and by whom) after row ``act`` ran."""
        keys = sorted(self.commanded | set(self.targets)) if key == 0 else [key]
        if act.name in ("idle", "estop"):
            for k in keys:
                self.commanded.discard(k)
                self.targets.pop(k, None)
        elif act.name == "stop":
            for k in keys:
                self.set(k, speed=0.0)
        elif act.safety == "motion":
            angle = {"move": typed.get("angle"), "step": base + typed.get("angle", 0.0), "impedance": typed.get("pos")}
            self.set(key, angle.get(act.name), typed.get("speed") if act.name == "speed" else None)
            if act.name == "torque":
                self.set(key, torque=typed["torque"])
        if act.safety == "motion":
            for k in sorted(self.commanded) if key == 0 else [key]:
                self.commanders[k] = who

    def idle_of(self, who: str, why: str) -> list[int]:
        """Put into IDLE the motors page ``who`` was the last to set moving (it went away: a page is a
        controller, and its motion ends with it); returns their keys."""
        keys = sorted(k for k, w in list(self.commanders.items()) if w == who and k in self.commanded)
        for k in keys:
            self.commanded.discard(k)
            self.commanders.pop(k, None)
            self.targets.pop(k, None)
            try:
                self._keys.motor(k).set_mode(1)
            except DrEmpowerError as exc:
                log(f"idling {self._keys.label(k)} failed: {exc}")
        if keys:
            log(f"{why}: idled {', '.join(map(self._keys.label, keys))}")
        return keys

    def idle_commanded(self, why: str) -> list[int]:
        """Put the motors this dashboard moved into IDLE (a robot file's joint that holds: speed 0, so an arm
        is not dropped); returns their keys."""
        ids = sorted(self.commanded)
        self.commanded.clear()  # a second caller meanwhile finds nothing to do
        held: list[int] = []
        label = self._keys.label
        for i in ids:
            bus, node = self._keys.where(i)
            try:
                if node in bus.held_on_close:
                    bus.send_frames(hold_frames([node]))
                    held.append(i)
                else:
                    self._keys.motor(i).set_mode(1)
            except DrEmpowerError as exc:
                log(f"stopping {label(i)} failed: {exc}")
        idled = [i for i in ids if i not in held]
        if idled:
            log(f"{why}: idled {', '.join(map(label, idled))}")
        if held:
            log(f"{why}: held {', '.join(map(label, held))} (speed 0: the robot file's on_timeout)")
        self.commanded.clear()
        self.targets.clear()
        return ids
