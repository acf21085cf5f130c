"""The hand from outside over the simulator's socketcand port: a twin in another process can be pushed.

``drempower sim --robot FILE`` serves each bus of a robot with a model over socketcand; its server also
takes one command beyond socketcand's, on a connection of its own (no ``open`` or ``rawmode`` needed)::

    < push body NAME FX FY FZ TX TY TZ SECONDS >   force N and torque Nm (world frame) on a body
    < push joint NAME TORQUE SECONDS >             torque Nm on a joint (the robot's name or the model's)
    < push release >                               end every push now
    < push ready >                                 ``< ok >`` when a twin takes pushes here

answered ``< ok >`` or ``< error WHY >`` (the twin's own refusal). :class:`RemoteHand` is the client:
the dashboard pushes a twin it does not run through it.
"""

from __future__ import annotations

import math
import socket
from collections.abc import Callable, Sequence
from typing import Any

from ..errors import DrEmpowerError, ValidationError

__all__ = ["RemoteHand", "twin_hand"]

_TIMEOUT = 2.0
"""Longest wait (s) for the simulator's answer to a push."""
_MAX_REPLY = 1024
"""The longest answer (bytes) read back."""


def _num(word: str, what: str) -> float:
    try:
        v = float(word)
    except ValueError:
        raise ValidationError(f"{what}={word!r}: expected a number") from None
    if not math.isfinite(v):
        raise ValidationError(f"{what}={word!r}: expected a finite number")
    return v


def twin_hand(twin: Any) -> Callable[[Sequence[str]], None]:
    """The server's handler of ``< push ... >`` (the words after ``push``) on ``twin``; a bad command
    raises :class:`ValidationError` (its words go back to the client)."""

    def hand(words: Sequence[str]) -> None:
        kind, rest = (words[0], list(words[1:])) if words else ("", [])
        if kind == "ready" and not rest:
            return
        if kind == "release" and not rest:
            twin.release()
            return
        if kind == "body" and len(rest) == 8:
            v = [_num(w, k) for w, k in zip(rest[1:], ("fx", "fy", "fz", "tx", "ty", "tz", "duration"), strict=True)]
            twin.push(rest[0], force=v[0:3], torque=v[3:6], duration=v[6])
            return
        if kind == "joint" and len(rest) == 3:
            twin.push_joint(rest[0], _num(rest[1], "torque"), duration=_num(rest[2], "duration"))
            return
        raise ValidationError(
            "expected push body NAME FX FY FZ TX TY TZ SECONDS, push joint NAME TORQUE SECONDS, push release "
            "or push ready"
        )

    return hand


def _word(name: str) -> str:
    if not name or any(c.isspace() or c in "<>" for c in name):
        raise ValidationError(f"target={name!r}: a name without spaces or angle brackets")
    return name


class RemoteHand:
    """Pushes the twin of the simulator that serves socketcand at ``host``:``port`` (one short
    connection a push); the same calls as the twin's own hand."""

    def __init__(self, host: str, port: int, timeout: float = _TIMEOUT) -> None:
        self.host, self.port, self.timeout = host, port, timeout

    def __repr__(self) -> str:
        return f"RemoteHand({self.host}:{self.port})"

    def _ask(self, words: str) -> None:
        try:
            with socket.create_connection((self.host, self.port), timeout=self.timeout) as conn:
                conn.settimeout(self.timeout)
                got = b""
                conn.sendall(f"< push {words} >".encode())
                while got.count(b">") < 2 and len(got) < _MAX_REPLY:  # the greeting, then the answer
                    chunk = conn.recv(256)
                    if not chunk:
                        break
                    got += chunk
        except TimeoutError:
            raise DrEmpowerError(
                f"the simulator at {self.host}:{self.port} did not answer the push within {self.timeout:g} s"
            ) from None
        except OSError as exc:
            raise DrEmpowerError(f"the simulator at {self.host}:{self.port} cannot be reached: {exc}") from None
        answers = [m.strip() for m in got.decode(errors="replace").replace("<", "").split(">") if m.strip()]
        answer = answers[-1] if answers else ""
        if answer == "ok":
            return
        if answer.startswith("error "):
            raise DrEmpowerError(f"the simulator at {self.host}:{self.port}: {answer[6:]}")
        raise DrEmpowerError(f"the simulator at {self.host}:{self.port} gave no answer to the push ({answer!r})")

    def ready(self) -> bool:
        """True when a twin takes pushes there (a server without one, or none, says no)."""
        try:
            self._ask("ready")
        except DrEmpowerError:
            return False
        return True

    def push(
        self,
        body: str,
        force: Sequence[float] = (0.0, 0.0, 0.0),
        torque: Sequence[float] = (0.0, 0.0, 0.0),
        duration: float = 1.0,
    ) -> None:
        nums = " ".join(repr(float(x)) for x in (*force, *torque, duration))
        self._ask(f"body {_word(body)} {nums}")

    def push_joint(self, joint: str, torque: float, duration: float = 1.0) -> None:
        self._ask(f"joint {_word(joint)} {float(torque)!r} {float(duration)!r}")

    def release(self) -> None:
        self._ask("release")
