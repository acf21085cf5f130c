"""Zenoh session configuration shared by the bridge and the remote bus (Zenoh objects are typed Any)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

__all__ = ["DEFAULT_CONNECT", "LEASE", "session_config", "open_session"]

DEFAULT_CONNECT = ("tcp/localhost:7447",)
"""Where rmw_zenoh's nodes find their router."""
LEASE = 1.0
"""Zenoh link lease (s) of drempower's sessions: a peer silent this long is gone (Zenoh's default is 10 s)."""


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
    """Open a Zenoh session (see :func:`session_config`)."""
    import zenoh

    return zenoh.open(session_config(connect, listen, scout=scout, gossip=gossip, lease=lease))
