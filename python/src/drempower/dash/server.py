"""The dashboard's web server: static page, one WebSocket per browser, sample batches, stop rules.

aiohttp serves the page and its assets (shipped in the package, no network
needed) and a WebSocket at ``/ws``. Every 40 ms the samples that arrived are
sent to every browser in one message; none is dropped (the page decimates for
display only). Blocking bus work runs in worker threads; stopping and idling
have a thread of their own so that no other work queues ahead of them, and the
ESTOP frames are sent from the event loop itself (they await no reply).

With no token (the default loopback bind) every request must name the
dashboard by a loopback ``Host`` (``127.0.0.1``, ``localhost`` or ``[::1]`` with
the bound port), which keeps a web page from reaching it by DNS rebinding.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import re
import secrets
import signal
import socket
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from importlib import resources
from typing import Any, ClassVar

from aiohttp import WSMsgType, web

from .. import actions
from ..errors import DrEmpowerError
from .access import Access
from .hub import Hub, bandwidth_range, param_table
from .logline import log
from .model_view import ModelView, add_routes

__all__ = ["Dashboard", "format_url"]

FLUSH_S = 0.04
"""How often samples go to the browsers (s)."""
HEARTBEAT_LOST_S = 0.5
"""A browser silent this long no longer counts as watching (s)."""
STATUS_S = 0.5
CARDS_S = 1.0
_ANY_ADDRESS = ("0.0.0.0", "::", "")


def format_url(host: str, port: int, token: str | None) -> str:
    """``http://HOST:PORT/`` (IPv6 in brackets), with ``?token=...`` when a token is needed.

    A bind to every address (``0.0.0.0``, ``::``) is named by the machine's host name.
    """
    if host in _ANY_ADDRESS:
        host = socket.gethostname()
    h = f"[{host}]" if ":" in host else host
    return f"http://{h}:{port}/" + (f"?token={token}" if token else "")


SEND_BACKLOG_SAMPLES = 1 << 20
"""Bytes a browser may have waiting to be sent before sample batches to it are dropped."""
SEND_BACKLOG_DROP = 8 << 20
"""Bytes waiting for one browser beyond which it is disconnected (it stopped reading)."""
MAX_DEPTH = 32
"""Deepest nesting of lists and objects accepted in a WebSocket message."""
MAX_PATH = 255
"""Longest static path served (characters); longer ones are not found."""


@dataclass(eq=False)
class Client:
    """One browser: its socket, and what waits to be sent to it (sent by its own task, so a browser
    that stops reading holds up nothing but itself)."""

    ws: web.WebSocketResponse
    name: str
    transport: asyncio.Transport | None = None
    last_hb: float = field(default_factory=time.monotonic)
    backlog: int = 0
    dropped: int = 0
    queue: asyncio.Queue[str] = field(default_factory=asyncio.Queue)
    gone: bool = False

    def put(self, text: str, droppable: bool = False) -> bool:
        """Queue ``text`` for this browser without waiting; False when it was dropped instead.

        A droppable message (a sample batch) is dropped while more than SEND_BACKLOG_SAMPLES
        bytes wait; beyond SEND_BACKLOG_DROP bytes the browser is disconnected.
        """
        if self.gone:
            return False
        if droppable and self.backlog > SEND_BACKLOG_SAMPLES:
            if not self.dropped:
                log(f"{self.name} is not keeping up: sample batches to it are dropped")
            self.dropped += 1
            return False
        if self.backlog + len(text) > SEND_BACKLOG_DROP:
            self.drop(f"{self.backlog + len(text)} bytes waiting: it stopped reading")
            return False
        self.backlog += len(text)
        self.queue.put_nowait(text)
        return True

    def drop(self, why: str) -> None:
        """Disconnect at once (the socket is aborted, no closing handshake to wait on)."""
        if self.gone:
            return
        self.gone = True
        log(f"{self.name} dropped: {why}")
        if self.transport is not None:
            self.transport.abort()

    async def send_loop(self) -> None:
        """Send what is queued, in order, until the socket closes."""
        while not self.gone:
            text = await self.queue.get()
            try:
                await self.ws.send_str(text)
            except (ConnectionError, RuntimeError):
                self.gone = True
                return
            finally:
                self.backlog -= len(text)


def nesting(value: Any) -> int:
    """How deep lists and objects nest in ``value`` (a scalar: 0), counted without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, dict):
            v = list(v.values())
        if isinstance(v, list):
            deepest = max(deepest, d)
            stack.extend((x, d + 1) for x in v)
    return deepest


def parse_request(text: str) -> dict[str, Any]:
    """A WebSocket message as a request object; ValueError naming what is wrong."""
    try:
        req = json.loads(text)
    except RecursionError:
        raise ValueError(f"message refused: lists and objects nested deeper than {MAX_DEPTH} levels") from None
    if not isinstance(req, dict):
        raise ValueError("message refused: expected a JSON object")
    if nesting(req) > MAX_DEPTH:
        raise ValueError(f"message refused: lists and objects nested deeper than {MAX_DEPTH} levels")
    return req


_REQ = re.compile(r'"req"\s*:\s*(-?\d{1,15})\b')
"""A request's number in a message whose JSON cannot be parsed (its error reply carries it)."""


class Dashboard:
    """One dashboard server around a :class:`Hub`.

    ``token``: required from every request and WebSocket (query ``token=`` or
    the cookie the page sets) when not None; when None, only requests whose ``Host``
    is a loopback name with the bound port are served. ``keep_running``: do not idle the
    dashboard's motors when the last browser goes away. ``model``: the model file the 3D view draws
    (default: the one the robot file names). ``shadow``: a :class:`~drempower.robot.shadow.Shadow` run
    beside the robot: every FLUSH_S the page gets where its twin has the joints (``{"t": "shadow"}``,
    drawn as a second, translucent arm, and in the plots as each motor's twin angle), and each
    divergence as a message (``{"t": "divergence"}``), also written to the log.
    """

    def __init__(
        self,
        hub: Hub,
        *,
        token: str | None = None,
        keep_running: bool = False,
        model: str | None = None,
        shadow: Any = None,
    ) -> None:
        self.hub = hub
        self.shadow = shadow
        self._divergences = 0
        """The shadow's divergences sent so far."""
        self.token = token
        self.access = Access(token)
        self.keep_running = keep_running
        self.clients: set[Client] = set()
        self.stopping = asyncio.Event()
        self.sent_total = 0
        self._n = 0
        self.cards: dict[int, dict[str, Any]] = {}
        self._tasks: set[asyncio.Future[None]] = set()
        self.signal: int | None = None
        """The signal that stopped the dashboard (SIGINT, SIGTERM, SIGHUP), if one did."""
        self.scanned = asyncio.Event()
        """Set once the first scan (started when serving begins) ended."""
        self._scanning: asyncio.Future[list[dict[str, Any]]] | None = None
        self._stop_pool = ThreadPoolExecutor(1, thread_name_prefix="dash stop")
        """Idling runs here, never queued behind scans, steps or parameter reads."""
        self.port: int | None = None
        """The bound port, once serving."""
        self._static = resources.files("drempower.dash") / "static"
        self.app = web.Application(middlewares=[self.access.middleware])
        self.app.router.add_get("/", self._index)
        self.app.router.add_get("/ws", self._ws)
        self.app.router.add_get("/static/{path:.+}", self._asset)
        self.app.router.add_get("/favicon.ico", self._no_icon)
        self.view = ModelView(hub, model)
        add_routes(self.app, self.view)

    # ------------------------------------------------------------------ http

    async def _index(self, request: web.Request) -> web.StreamResponse:
        resp = web.Response(text=(self._static / "index.html").read_text("utf-8"), content_type="text/html")
        self.access.remember(resp)
        resp.headers["Cache-Control"] = "no-store"
        return resp

    async def _no_icon(self, request: web.Request) -> web.StreamResponse:
        return web.Response(status=204)

    _TYPES: ClassVar[dict[str, str]] = {
        ".js": "text/javascript",
        ".css": "text/css",
        ".png": "image/png",
        ".html": "text/html",
    }

    async def _asset(self, request: web.Request) -> web.StreamResponse:
        path = request.match_info["path"]
        parts = path.split("/")
        if len(path) > MAX_PATH or any(p in ("", ".", "..") for p in parts):
            raise web.HTTPNotFound()
        f = self._static.joinpath(*parts)
        try:
            if not f.is_file():
                raise web.HTTPNotFound()
        except OSError:  # a name the file system refuses (too long, bad bytes): not found either
            raise web.HTTPNotFound() from None
        ctype = self._TYPES.get("." + parts[-1].rsplit(".", 1)[-1], "application/octet-stream")
        return web.Response(body=f.read_bytes(), content_type=ctype)

    # ------------------------------------------------------------------ websocket

    async def _ws(self, request: web.Request) -> web.StreamResponse:
        if not self.access.origin_ok(request):
            log(f"refused a WebSocket from origin {request.headers.get('Origin')!r}")
            return web.Response(status=403, text="forbidden: cross-origin WebSocket\n")
        ws = web.WebSocketResponse(heartbeat=None, max_msg_size=8 * 1024 * 1024)
        await ws.prepare(request)
        self._n += 1
        client = Client(ws, f"browser {self._n} ({request.remote})", request.transport)
        sender = asyncio.ensure_future(client.send_loop())
        self.clients.add(client)
        log(f"{client.name} connected")
        hub = self.hub
        client.put(
            json.dumps(
                {
                    "t": "hello",
                    "name": client.name,
                    "read_only": hub.read_only,
                    "params": param_table(),
                    "bandwidth": list(bandwidth_range()),
                    "motors": sorted(hub.motors),
                    "heartbeat_ms": hub.heartbeat_ms,
                    "poll_hz": hub.poll_hz,
                    "watched": hub.watched(),
                    "bus": hub.description(),
                    "bitrate": hub.bitrate(),
                    "budget": hub.budget_text(),
                    "scanning": hub.scanning or not self.scanned.is_set(),
                    "names": hub.names(),
                    "columns": hub.columns(),
                    "actions": [actions.describe(a) for a in actions.table()],
                }
            )
        )
        if self.cards:
            client.put(json.dumps({"t": "cards", "cards": list(self.cards.values())}))
        try:
            async for msg in ws:
                if msg.type is not WSMsgType.TEXT:
                    continue
                try:
                    req = parse_request(msg.data)
                except ValueError as exc:  # the request's number, when it can be found, so the page can match it
                    found = _REQ.search(msg.data)
                    req_no = int(found.group(1)) if found else None
                    client.put(json.dumps({"t": "reply", "req": req_no, "op": None, "ok": False, "error": str(exc)}))
                    continue
                client.last_hb = time.monotonic()
                if req.get("op") == "hb":
                    continue
                if req.get("op") == "estop":
                    self.hub.fence()  # at once: what any page issued before it is fenced
                task = asyncio.ensure_future(self._handle(client, req, self.hub.ticket()))
                self._tasks.add(task)
                task.add_done_callback(self._tasks.discard)
        finally:
            client.gone = True
            sender.cancel()
            self.clients.discard(client)
            log(f"{client.name} disconnected")
            if not self.keep_running:  # a page is a controller: what it set moving stops with it
                await self._idle_page(client.name, f"{client.name} disconnected")
            await self._check_watchers(f"{client.name} disconnected")
        return ws

    async def _run(self, fn: Callable[..., Any], *args: Any, ticket: int | None = None) -> Any:
        """``fn(*args)`` in a worker; with ``ticket`` (:meth:`Hub.ticket` when the request arrived) as a
        request an ESTOP pressed after it fences (:meth:`Hub.issued`)."""
        if ticket is None:
            return await asyncio.get_running_loop().run_in_executor(None, fn, *args)
        return await asyncio.get_running_loop().run_in_executor(None, self.hub.issued, ticket, fn, *args)

    async def _idle(self, why: str) -> None:
        """Idle the dashboard's motors on the stop thread (nothing else queues there)."""
        await asyncio.get_running_loop().run_in_executor(self._stop_pool, self.hub.idle_commanded, why)

    async def _idle_page(self, who: str, why: str) -> None:
        """Idle the motors page ``who`` was the last to set moving, on the stop thread."""
        await asyncio.get_running_loop().run_in_executor(self._stop_pool, self.hub.idle_of, who, why)

    async def _handle(self, client: Client, req: dict[str, Any], ticket: int) -> None:
        """Answer one request of a page; ``ticket``: :meth:`Hub.ticket` when it arrived."""
        op, hub, who = req.get("op"), self.hub, client.name

        async def run(fn: Callable[..., Any], *args: Any) -> Any:
            return await self._run(fn, *args, ticket=ticket)

        reply: dict[str, Any] = {"t": "reply", "req": req.get("req"), "op": op}
        try:
            if op == "estop":
                hub.estop(who)  # frames only, no reply awaited: sent from the loop at once
                self.view.release()  # and on a twin, the hand from outside lets go
                result: Any = None
            elif op == "scan":
                result = await self._scan()
            elif op == "control":
                result = await run(hub.do_control, who, req)
            elif op == "action":
                result = await run(hub.do_row, who, req)
            elif op == "rate":
                result = await run(hub.do_rate, who, float(req.get("hz", 0)))
            elif op == "params":
                result = await run(hub.do_read_params, hub.key(req))
            elif op == "write":
                args = (who, hub.key(req), req.get("name"), req.get("value"), req.get("force") is True)
                result = await run(hub.do_write_param, *args)
            elif op == "save":
                result = await run(hub.do_save, who, hub.key(req))
            elif op == "backup":
                result = await run(hub.do_backup, hub.key(req))
            elif op == "restore":
                result = await run(hub.do_restore, who, hub.key(req), req.get("doc"), bool(req.get("dry_run")))
            elif op == "watch":
                hub.watch(hub.key(req), str(req.get("name")), float(req.get("hz", 0)))
                result = hub.watched()
                self._broadcast(json.dumps({"t": "watched", "watched": result}))
            elif op == "step":
                result = await run(hub.do_step, who, req)
            elif op in ("propose", "apply_gains"):
                result = await run(hub.do_propose if op == "propose" else hub.do_apply_gains, who, req)
            elif op == "push":
                result = await run(self.view.do_push, who, req)
            else:
                raise DrEmpowerError(f"op={op!r}: unknown request")
            reply.update(ok=True, result=result)
        except (DrEmpowerError, KeyError, TypeError, ValueError) as exc:
            key = req.get("id") if isinstance(req.get("id"), int) else None
            reply.update(ok=False, error=hub.words(str(exc) or type(exc).__name__, key))  # the joint by name
        except Exception as exc:  # a bug must still answer the page
            log(f"{who}: {op} failed: {exc!r}")
            reply.update(ok=False, error=f"internal error: {exc!r}")
        client.put(json.dumps(reply))

    async def _scan(self) -> list[dict[str, Any]]:
        """Scan every bus and send the progress, the names and the cards to every browser; one scan at a
        time: a caller during a scan gets that scan's result."""
        if self._scanning is None or self._scanning.done():
            self._scanning = asyncio.ensure_future(self._scan_now())
        return await asyncio.shield(self._scanning)

    async def _scan_now(self) -> list[dict[str, Any]]:
        loop = asyncio.get_running_loop()

        def progress(done: int, of: int, found: list[dict[str, Any]]) -> None:
            msg = json.dumps({"t": "scan", "done": done, "of": of, "found": found})
            loop.call_soon_threadsafe(self._broadcast, msg)

        try:
            found: list[dict[str, Any]] = await self._run(self.hub.do_scan, progress)
            self.cards = await self._run(self.hub.do_cards)
        finally:
            self.scanned.set()
        self._broadcast(json.dumps({"t": "names", "names": self.hub.names()}))
        self._broadcast(json.dumps({"t": "cards", "cards": list(self.cards.values())}))
        self._broadcast(json.dumps({"t": "scanned", "found": found}))
        return found

    async def _first_scan(self) -> None:
        try:
            await self._scan()
        except DrEmpowerError as exc:
            log(f"scan failed: {exc}")

    def _broadcast(self, text: str, droppable: bool = False) -> None:
        """Queue ``text`` for every browser (never waits on a socket)."""
        for c in list(self.clients):
            c.put(text, droppable)

    # ------------------------------------------------------------------ periodic work

    async def _check_watchers(self, why: str) -> None:
        """Idle the motors of each page whose heartbeat stopped, and every motor the dashboard moved when
        no browser with a live heartbeat remains."""
        hub = self.hub
        if self.keep_running or not hub.commanded:
            return
        now = time.monotonic()
        for c in list(self.clients):  # a page whose heartbeat stopped: its motion ends as if it had gone
            if now - c.last_hb >= HEARTBEAT_LOST_S and c.name in hub.commanders.values():
                await self._idle_page(c.name, f"{c.name}: no heartbeat for 0.5 s")
        if any(now - c.last_hb < HEARTBEAT_LOST_S for c in self.clients if not c.ws.closed):
            return
        why = why if not self.clients else "no browser heartbeat for 0.5 s"
        await self._idle(why)

    async def _watch_heartbeats(self) -> None:
        """Every FLUSH_S: idle the dashboard's motors when no browser's heartbeat is live (it waits on no
        socket, so a browser that stops reading cannot hold it up)."""
        while not self.stopping.is_set():
            await asyncio.sleep(FLUSH_S)
            await self._check_watchers("last browser gone")

    async def _pump(self) -> None:
        """Queue samples every FLUSH_S and the status every STATUS_S for every browser."""
        hub = self.hub
        next_status = next_cards = 0.0
        cards_task: asyncio.Future[Any] | None = None
        while not self.stopping.is_set():
            await asyncio.sleep(FLUSH_S)
            samples = hub.take_samples()
            if samples:
                self.sent_total += len(samples)
                self._broadcast(json.dumps({"t": "samples", "total": self.sent_total, "s": samples}), True)
            if self.shadow is not None:
                self._send_shadow()
            psamples = hub.take_param_samples()
            if psamples:
                self._broadcast(json.dumps({"t": "params", "s": psamples}), True)
            now = time.monotonic()
            if now >= next_status:
                next_status = now + STATUS_S
                hub.measure_load()
                status = {
                    "t": "status",
                    "load": hub.load,
                    "frame_rate": hub.frame_rate,
                    "clients": len(self.clients),
                    "sent_total": self.sent_total,
                    "commanded": sorted(hub.commanded),
                    "heartbeat_ms": hub.heartbeat_ms,
                }
                self._broadcast(json.dumps(status))
            if now >= next_cards and hub.motors and not hub.scanning and (cards_task is None or cards_task.done()):
                next_cards = now + CARDS_S
                cards_task = asyncio.ensure_future(self._send_cards())

    def _send_shadow(self) -> None:
        """Where the shadow's twin has the joints, and each new divergence (to the log too)."""
        shadow = self.shadow
        if shadow.residuals:  # the twin started where the robot is
            positions = shadow.twin_positions()
            q = {k: round(v, 5) for k, v in positions.items()}
            res = {k: [round(a, 5), round(b, 4)] for k, (a, b) in dict(shadow.residuals).items()}
            # the twin's angle at each motor (deg), for the plots beside the motor's own
            angles = {
                j["key"]: round(math.degrees((positions[j["joint"]] - j["offset"]) * j["gear"]), 4)
                for j in self.view.mapping()
                if j["joint"] in positions
            }
            at = round(time.monotonic() - self.hub.t0, 4)
            self._broadcast(json.dumps({"t": "shadow", "q": q, "res": res, "at": at, "a": angles}), True)
        events = shadow.events
        while self._divergences < len(events):
            e = events[self._divergences]
            self._divergences += 1
            text = f"shadow: {e}; {shadow.action(e.joint)}"
            log(text)
            self._broadcast(
                json.dumps({"t": "divergence", "joint": e.joint, "kind": e.kind, "residual": e.residual, "text": text})
            )

    async def _send_cards(self) -> None:
        with contextlib.suppress(DrEmpowerError):
            self.cards = await self._run(self.hub.do_cards)
            self._broadcast(json.dumps({"t": "cards", "cards": list(self.cards.values())}))

    # ------------------------------------------------------------------ lifetime

    async def serve(self, host: str, port: int, on_ready: Callable[[str], None]) -> None:
        """Serve until SIGINT/SIGTERM/SIGHUP (or :attr:`stopping` is set); then idle the dashboard's motors."""
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):
                loop.add_signal_handler(sig, self._on_signal, sig)
        runner = web.AppRunner(self.app, handle_signals=False, access_log=None)
        await runner.setup()
        try:
            site = web.TCPSite(runner, host, port)
            await site.start()
            self.port = self.access.port = int(runner.addresses[0][1])
            on_ready(format_url(host, self.port, self.token))
            periodic = [asyncio.ensure_future(self._pump()), asyncio.ensure_future(self._watch_heartbeats())]
            first_scan = asyncio.ensure_future(self._first_scan())  # what is on the bus, before any page asks
            self._tasks.add(first_scan)
            first_scan.add_done_callback(self._tasks.discard)
            await self.stopping.wait()
            self.hub.halt()  # step runs end early
            await self._idle("dashboard stopping")  # first, before waiting for anything
            for task in periodic:
                task.cancel()
            for task in periodic:
                with contextlib.suppress(asyncio.CancelledError):
                    await task
            if self._tasks:  # requests under way finish (their bus calls are bounded by timeouts)
                await asyncio.wait(self._tasks, timeout=5)
        finally:
            await self._idle("dashboard stopping")  # again: what a request under way commanded meanwhile
            for c in list(self.clients):  # a browser that stopped reading is not waited for
                if c.backlog:
                    c.drop("the dashboard is stopping")
                    continue
                with contextlib.suppress(Exception):
                    await asyncio.wait_for(c.ws.close(), 1.0)
            await runner.cleanup()
            self._stop_pool.shutdown(wait=False)

    def _on_signal(self, sig: int) -> None:
        if self.signal is None:
            self.signal = sig
        self.stopping.set()  # first: the log below never holds up the stop
        log(f"{signal.Signals(sig).name}: stopping")


def new_token() -> str:
    """A fresh random token for a dashboard bound beyond 127.0.0.1."""
    return secrets.token_urlsafe(18)
