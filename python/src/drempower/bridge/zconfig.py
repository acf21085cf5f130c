"""Zenoh session configuration shared by the bridge and the remote bus (Zenoh objects are typed Any)."""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from typing import Any

from ..transports.errors import TransportError

__all__ = ["DEFAULT_CONNECT", "LEASE", "check_endpoint", "session_config", "open_session"]

DEFAULT_CONNECT = ("tcp/localhost:7447",)
"""Where rmw_zenoh's nodes find their router."""
LEASE = 1.0
"""Zenoh link lease (s) of drempower's sessions: a peer silent this long is gone (Zenoh's default is 10 s)."""


_ENDPOINT = re.compile(r"^[a-z][a-z0-9-]*/[^\s/][^\s]*$")


def check_endpoint(text: str, field: str = "endpoint") -> str:
    """``text`` if it has the form of a Zenoh endpoint (``tcp/192.168.1.10:7447``), else ValueError naming ``field``."""
    if not _ENDPOINT.match(text):
        raise ValueError(
            f"{field} {text!r}: a Zenoh endpoint is <protocol>/<address>, e.g. tcp/192.168.1.10:7447 or tcp/[::1]:7447"
        )
    return text


def _zenoh_message(exc: BaseException) -> str:
    """Zenoh's error text without the source locations it appends."""
    text = str(exc)
    match = re.search(r'msg: "(.*?)(?: at /[^"]*)?"', text)
    return match.group(1) if match else text.split(" at /", 1)[0]


def session_config(
    connect: Sequence[str] | None = None,
    listen: Sequence[str] = (),
    *,
    scout: bool = False,
    gossip: bool = True,
    lease: float = LEASE,
) -> Any:
    """A peer-mode config connecting to ``connect`` (default ``tcp/localhost:7447``) and listening on ``listen``.

    As rmw_zenoh's sessions: multicast scouting off unless ``scout``, gossip
    scouting (peers learnt through the router) on unless ``gossip=False``.
    ``lease`` (s) is how soon a silent peer counts as gone.
    """
    import zenoh

    for field, endpoints in (("connect", connect or ()), ("listen", listen)):
        for e in endpoints:
            check_endpoint(e, field)
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps(list(DEFAULT_CONNECT if connect is None else connect)))
    conf.insert_json5("listen/endpoints", json.dumps(list(listen)))
    conf.insert_json5("scouting/multicast/enabled", json.dumps(scout))
    conf.insert_json5("scouting/gossip/enabled", json.dumps(gossip))
    conf.insert_json5("transport/link/tx/lease", json.dumps(int(lease * 1000)))
    return conf


def open_session(
    connect: Sequence[str] | None = None,
    listen: Sequence[str] = (),
    *,
    scout: bool = False,
    gossip: bool = True,
    lease: float = LEASE,
) -> Any:
    """Open a Zenoh session (see :func:`session_config`); TransportError when Zenoh refuses (a port in use...)."""
    import zenoh

    config = session_config(connect, listen, scout=scout, gossip=gossip, lease=lease)
    try:
        return zenoh.open(config)
    except Exception as exc:
        where = ", ".join([*(connect or DEFAULT_CONNECT), *listen])
        raise TransportError(f"cannot open a Zenoh session ({where}): {_zenoh_message(exc)}") from exc
