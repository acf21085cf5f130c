"""A page's message whose JSON cannot be parsed gets its error reply with the request's number, when the
text has one, so the page can match it."""

from __future__ import annotations

import aiohttp

from drempower import open_bus

from .conftest import serve_in_thread


async def test_an_unparsable_message_is_answered_with_its_request_number() -> None:
    bus = open_bus("sim", motors=[1], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    try:
        async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
            await ws.receive_json(timeout=5)
            await ws.send_str('{"op": "control", "req": 41, "action": ')  # cut short
            await ws.send_str("not json at all")
            got = []
            while len(got) < 2:
                m = await ws.receive_json(timeout=5)
                if m.get("t") == "reply":
                    got.append(m)
            assert [(m["req"], m["ok"]) for m in got] == [(41, False), (None, False)]
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()
