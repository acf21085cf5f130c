"""The ESTOP fence: a request issued before the latest ESTOP, whichever page or front end issued it, is
refused all but its stopping commands."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from ..errors import ValidationError

__all__ = ["Fence"]


class Fence:
    """The count of ESTOPs pressed, and the count each worker's request was issued with."""

    def __init__(self) -> None:
        self._estops = 0
        """ESTOPs pressed so far: a request issued before the latest is fenced (see :meth:`issued`)."""
        self._issued = threading.local()
        """The ESTOP count when the request the calling worker runs was issued (None: not a page's)."""

    def ticket(self) -> int:
        """What a request issued now carries (the count of ESTOPs pressed so far): take it when the
        request arrives, before it waits for a worker, and run it with :meth:`issued`."""
        return self._estops

    def fence(self) -> None:
        """An ESTOP was pressed: every request issued before it is fenced from now on, whichever page or
        front end issued it; those issued after (a clear, an enable) run as usual."""
        self._estops += 1

    def issued(self, ticket: int, fn: Callable[..., Any], *args: Any) -> Any:
        """Run ``fn(*args)`` in this worker as a request issued with ``ticket``: once an ESTOP came after
        it was issued, each of its commands but the stopping ones (stop, idle, estop) is refused."""
        self._issued.ticket = ticket
        try:
            return fn(*args)
        finally:
            self._issued.ticket = None

    def fenced(self) -> bool:
        """True when the request this worker runs was issued before the latest ESTOP."""
        ticket = getattr(self._issued, "ticket", None)
        return ticket is not None and ticket < self._estops

    def check(self) -> None:
        """Refuse the rest of a request issued before the latest ESTOP (nothing more is sent)."""
        if self.fenced():
            raise ValidationError("an ESTOP was pressed after this request was issued: it was not carried out")
