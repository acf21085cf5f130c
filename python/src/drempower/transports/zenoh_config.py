"""Zenoh session configuration shared by the bridge and the remote bus (Zenoh objects are typed Any)."""

from __future__ import annotations

import json
import os
import re
from collections.abc import Sequence
from typing import Any

from .errors import TransportError

__all__ = ["DEFAULT_CONNECT", "LEASE", "check_endpoint", "open_config", "open_session", "session_config", "settings"]

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
    scout: bool | None = None,
    gossip: bool | None = None,
    lease: float = LEASE,
    config_file: str | os.PathLike[str] | None = None,
) -> Any:
    """A peer-mode config connecting to ``connect`` (default ``tcp/localhost:7447``) and listening on ``listen``.

    As rmw_zenoh's sessions: multicast scouting off unless ``scout``, gossip
    scouting (peers learnt through the router) on unless ``gossip=False``.
    ``lease`` (s) is how soon a silent peer counts as gone.

    With ``config_file`` (a Zenoh JSON5 file, as rmw_zenoh's
    ``ZENOH_SESSION_CONFIG_URI``) the file is the base: ``connect``, ``listen``,
    ``scout`` and ``gossip`` replace its settings only when given (not None, not
    empty); the mode and the two scoutings the file leaves unset are as above,
    and its lease is its own. ValueError naming the file when Zenoh refuses it.
    """
    import zenoh

    for field, endpoints in (("connect", connect or ()), ("listen", listen)):
        for e in endpoints:
            check_endpoint(e, field)
    if config_file is None:
        conf = zenoh.Config()
        conf.insert_json5("connect/endpoints", json.dumps(list(DEFAULT_CONNECT if connect is None else connect)))
        conf.insert_json5("listen/endpoints", json.dumps(list(listen)))
        conf.insert_json5("transport/link/tx/lease", json.dumps(int(lease * 1000)))
    else:
        try:
            conf = zenoh.Config.from_file(os.fspath(config_file))
        except Exception as exc:
            raise ValueError(f"Zenoh configuration {os.fspath(config_file)!r}: {_zenoh_message(exc)}") from None
        if connect is not None:
            conf.insert_json5("connect/endpoints", json.dumps(list(connect)))
        if listen:
            conf.insert_json5("listen/endpoints", json.dumps(list(listen)))
    defaults = (
        ("mode", "peer", None),
        ("scouting/multicast/enabled", False, scout),
        ("scouting/gossip/enabled", True, gossip),
    )
    for key, default, given in defaults:
        if given is not None:
            conf.insert_json5(key, json.dumps(given))
        elif json.loads(conf.get_json(key)) is None:
            conf.insert_json5(key, json.dumps(default))
    return conf


def settings(conf: Any) -> dict[str, Any]:
    """What a session of ``conf`` does: mode, connect and listen endpoints, multicast and gossip scouting."""
    get = conf.get_json
    return {
        "mode": json.loads(get("mode")),
        "connect": json.loads(get("connect/endpoints")),
        "listen": json.loads(get("listen/endpoints")),
        "multicast_scouting": json.loads(get("scouting/multicast/enabled")),
        "gossip_scouting": json.loads(get("scouting/gossip/enabled")),
    }


def open_session(
    connect: Sequence[str] | None = None,
    listen: Sequence[str] = (),
    *,
    scout: bool | None = None,
    gossip: bool | None = None,
    lease: float = LEASE,
    config_file: str | os.PathLike[str] | None = None,
) -> Any:
    """Open a Zenoh session (see :func:`session_config`); TransportError when Zenoh refuses (a port in use...)."""
    conf = session_config(connect, listen, scout=scout, gossip=gossip, lease=lease, config_file=config_file)
    return open_config(conf)


def open_config(conf: Any) -> Any:
    """Open a Zenoh session of ``conf``; TransportError naming its endpoints when Zenoh refuses (a port in use...)."""
    import zenoh

    try:
        return zenoh.open(conf)
    except Exception as exc:
        s = settings(conf)
        where = ", ".join([*_listed(s["connect"], s["mode"]), *_listed(s["listen"], s["mode"])]) or "no endpoints"
        raise TransportError(f"cannot open a Zenoh session ({where}): {_zenoh_message(exc)}") from exc


def _listed(endpoints: Any, mode: str) -> list[str]:
    """Endpoints as a list (Zenoh's defaults give one list per mode)."""
    if isinstance(endpoints, dict):
        endpoints = endpoints.get(mode, [])
    return [str(e) for e in endpoints or ()]
