"""Who may use a dashboard: the Host a request names, the token of its URL, a WebSocket's origin.

With no token (the default loopback bind) every request must name the loopback host with the bound
port (a DNS-rebinding page names its own); with a token (a bind beyond 127.0.0.1) every request must
carry it, in the query (``token=``) or the cookie the index page sets.
"""

from __future__ import annotations

import hmac
from collections.abc import Awaitable, Callable
from urllib.parse import urlsplit

from aiohttp import web

from .logline import log

__all__ = ["COOKIE", "Access"]

COOKIE = "drempower_dash_token"
"""The cookie that carries the token once the index page was loaded with it."""
_LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")


class Access:
    """The checks of one dashboard: its ``token`` (None on a loopback bind) and, once serving, its ``port``."""

    __slots__ = ("port", "token")

    def __init__(self, token: str | None) -> None:
        self.token = token
        self.port: int | None = None

    def token_ok(self, request: web.Request) -> bool:
        """No token needed, or the request carries it (query or cookie), compared in constant time."""
        if self.token is None:
            return True
        given = request.query.get("token") or request.cookies.get(COOKIE) or ""
        return hmac.compare_digest(given.encode(), self.token.encode())

    def host_ok(self, request: web.Request) -> bool:
        """With a token, any Host; without, only a loopback name with the bound port."""
        if self.token is not None:
            return True
        host = (request.headers.get("Host") or "").lower()
        names = {f"{n}:{self.port}" for n in _LOOPBACK_NAMES}
        if self.port == 80:
            names.update(_LOOPBACK_NAMES)
        return host in names

    @staticmethod
    def origin_ok(request: web.Request) -> bool:
        """A WebSocket from a page this dashboard served (a non-browser sends no Origin)."""
        origin = request.headers.get("Origin")
        if origin is None:  # not a browser (browsers always send it on WebSockets)
            return True
        return urlsplit(origin).netloc == request.host

    def remember(self, response: web.Response) -> None:
        """Set the token's cookie on the index page, so its WebSocket and assets carry it."""
        if self.token is not None:
            response.set_cookie(COOKIE, self.token, httponly=True, samesite="Strict")

    @web.middleware
    async def middleware(
        self, request: web.Request, handler: Callable[[web.Request], Awaitable[web.StreamResponse]]
    ) -> web.StreamResponse:
        """Refuse (403, in words) a request for another Host or without the token."""
        if not self.host_ok(request):
            log(f"refused a request for Host {request.headers.get('Host')!r}")
            text = "forbidden: this dashboard answers only to 127.0.0.1, localhost and [::1]\n"
            return web.Response(status=403, text=text)
        if not self.token_ok(request):
            return web.Response(status=403, text="forbidden: this dashboard needs the token of its URL\n")
        return await handler(request)
