"""Matching replies to requests (pure: no threads, no clock).

Every request that expects an answer is registered under a key before its
frame is sent: ``node << 16 | address`` for a parameter read and
``node << 16`` for a fast read (address 0), whose answer is the motor's next
state frame. A reply resolves the oldest request waiting on its key whose
echoed fields all match: a parameter read also names its data type, and a
reply of another data type answers nothing (it is an anomaly, counted by the
caller). A request to node 0 (broadcast) is answered by any node. Replies that
match nothing are left to the caller (state cache, unsolicited-frame hook).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from ...protocol.messages import FastRead, Message, ReadParam
from ...protocol.parameters import DataType

__all__ = ["Waiter", "Matcher", "MATCHED", "MISMATCHED", "UNMATCHED", "reply_key", "request_dtype", "request_key"]

UNMATCHED = 0
"""No request waits for a reply of this node and address."""
MATCHED = 1
"""The reply answered a request."""
MISMATCHED = 2
"""Requests wait for this node and address, but an echoed field (the data type) differs: an anomaly."""


def reply_key(node: int, address: int) -> int:
    """Key of a reply from ``node`` for parameter ``address`` (0 = state frame)."""
    return (node << 16) | address


def request_key(msg: Message) -> int:
    """Key under which the answer to ``msg`` (a read or fast read) is expected."""
    if isinstance(msg, ReadParam):
        return (msg.node << 16) | msg.address
    if isinstance(msg, FastRead):
        return msg.node << 16
    raise TypeError(f"{type(msg).__name__} has no reply to wait for")


def request_dtype(msg: Message) -> DataType | None:
    """The data type the reply to ``msg`` must echo (None when the reply has none: a fast read)."""
    return msg.dtype if isinstance(msg, ReadParam) else None


class Waiter:
    """The answers awaited by one exchange: ``results[i]`` answers ``keys[i]``.

    ``on_complete`` is called once, when the last answer arrived, and dropped before: the waiter no longer
    holds its owner (a bound method of it), so what a request made is freed as soon as it is answered.
    """

    __slots__ = ("dtypes", "keys", "on_complete", "remaining", "results")

    def __init__(
        self,
        keys: Sequence[int],
        on_complete: Callable[[], None] | None = None,
        dtypes: Sequence[DataType | None] | None = None,
    ) -> None:
        self.keys = keys
        self.dtypes = dtypes
        """The data type each reply must echo (None: any); None for the whole waiter: no check."""
        self.results: list[object | None] = [None] * len(keys)
        self.remaining = len(keys)
        self.on_complete = on_complete

    def missing(self) -> list[int]:
        """Indices of the keys still unanswered."""
        return [i for i, r in enumerate(self.results) if r is None]


class Matcher:
    """The table of outstanding requests (not thread-safe: its owner serialises access)."""

    __slots__ = ("_table",)

    def __init__(self) -> None:
        self._table: dict[int, list[tuple[Waiter, int]]] = {}

    def __len__(self) -> int:
        return sum(len(v) for v in self._table.values())

    def register(self, waiter: Waiter) -> None:
        """Expect the answers to ``waiter.keys`` (call before sending the requests)."""
        table = self._table
        for i, key in enumerate(waiter.keys):
            entry = (waiter, i)
            lst = table.get(key)
            if lst is None:
                table[key] = [entry]
            else:
                lst.append(entry)

    def resolve(self, node: int, address: int, value: object) -> bool:
        """Hand ``value`` to the oldest request waiting for it; False if none is (no data-type check)."""
        return self.resolve_reply(node, address, None, value) == MATCHED

    def resolve_reply(self, node: int, address: int, dtype: DataType | None, value: object) -> int:
        """Hand ``value`` to the oldest request waiting for it whose expected data type is ``dtype``.

        Returns :data:`MATCHED`, :data:`UNMATCHED` (nobody waits for this node
        and address) or :data:`MISMATCHED` (requests wait, but for another data
        type: they keep waiting). ``dtype`` None skips the check.
        """
        table = self._table
        key = (node << 16) | address
        lst = table.get(key)
        if lst is None:
            key = address  # a request sent to broadcast (node 0)
            lst = table.get(key)
            if lst is None:
                return UNMATCHED
        for j, (waiter, i) in enumerate(lst):  # noqa: B007 (j is used after the loop)
            want = None if dtype is None or waiter.dtypes is None else waiter.dtypes[i]
            if want is None or want == dtype:
                break
        else:
            return MISMATCHED
        del lst[j]
        if not lst:
            del table[key]
        waiter.results[i] = value
        waiter.remaining -= 1
        if waiter.remaining == 0 and (done := waiter.on_complete) is not None:
            waiter.on_complete = None  # called once (and no cycle through its owner is left for the collector)
            done()
        return MATCHED

    def resolve_state(self, node: int, value: object) -> bool:
        """:meth:`resolve` for a state frame of ``node`` (address 0), the commonest reply, in fewer steps."""
        table = self._table
        key = node << 16
        lst = table.get(key)
        if lst is None:
            key = 0  # a fast read sent to broadcast
            lst = table.get(0)
            if lst is None:
                return False
        waiter, i = lst.pop(0)
        if not lst:
            del table[key]
        waiter.results[i] = value
        waiter.remaining -= 1
        if waiter.remaining == 0 and (done := waiter.on_complete) is not None:
            waiter.on_complete = None  # called once (and no cycle through its owner is left for the collector)
            done()
        return True

    def waiting(self, node: int, address: int, dtype: DataType | None = None) -> bool:
        """True when a request waits for this reply (from ``node``, or sent to broadcast), of ``dtype`` if given."""
        table = self._table
        for key in ((node << 16) | address, address):
            for waiter, i in table.get(key, ()):
                if dtype is None or waiter.dtypes is None or waiter.dtypes[i] in (None, dtype):
                    return True
        return False

    def cancel(self, waiter: Waiter) -> None:
        """Stop waiting for the unanswered keys of ``waiter``."""
        table = self._table
        for i in waiter.missing():
            key = waiter.keys[i]
            lst = table.get(key)
            if lst is None:
                continue
            try:
                lst.remove((waiter, i))
            except ValueError:
                continue
            if not lst:
                del table[key]

    def drop(self, waiter: Waiter) -> None:
        """:meth:`cancel`, for good: ``waiter``'s ``on_complete`` is dropped too (it will not be answered)."""
        self.cancel(waiter)
        waiter.on_complete = None

    def clear(self) -> list[Waiter]:
        """Forget every outstanding request; returns their waiters."""
        waiters = list({id(w): w for lst in self._table.values() for w, _ in lst}.values())
        self._table.clear()
        return waiters
