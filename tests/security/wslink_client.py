"""A minimal wslink client (what trame's JavaScript client does), to attack servers over a real WebSocket.

Protocol (wslink 2, see ``wslink/protocol.py`` and ``wslink/chunking.py``): every message is a
msgpack map ``{"wslink": "1.0", "id": ..., "method": ..., "args": [...], "kwargs": {}}`` sent in
binary chunks with a 20-byte header; the first call must be ``wslink.hello`` with id
``system:c0:0`` and ``args=[{"secret": ...}]``; replies carry the same id with ``result`` or
``error``; ``publish:<topic>:0`` messages (state changes) arrive in between.
"""

from __future__ import annotations

import asyncio
import itertools
import json
import re
import time
import urllib.error
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import aiohttp
import msgpack
from wslink.chunking import UnChunker, generate_chunks

DEFAULT_SECRET = "wslink-secret"  # trame's public default
URL_RE = re.compile(r"running at (http://\S+)")


class Refused(Exception):
    """The server refused the WebSocket handshake (HTTP status in ``status``)."""

    def __init__(self, status: int) -> None:
        super().__init__(f"handshake refused with HTTP {status}")
        self.status = status


@dataclass
class Session:
    """An open wslink session; ``published`` collects the state updates the server pushed."""

    ws: Any
    http: aiohttp.ClientSession
    unchunker: UnChunker = field(default_factory=UnChunker)  # its size limit is raised per message below
    ids: Any = field(default_factory=lambda: itertools.count(1))
    client_id: str = "c0"
    published: list[dict[str, Any]] = field(default_factory=list)

    async def _send(self, message: dict[str, Any]) -> None:
        for chunk in generate_chunks(msgpack.packb(message), 4 * 1024 * 1024):
            await self.ws.send_bytes(chunk)

    async def _reply(self, rpc_id: str, timeout: float) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError(f"no reply to {rpc_id} within {timeout} s")
            msg = await self.ws.receive(timeout=remaining)
            if msg.type != aiohttp.WSMsgType.BINARY:
                raise ConnectionError(f"connection ended: {msg.type!r} {msg.data!r}")
            self.unchunker.set_max_message_size(1 << 30)
            full = self.unchunker.process_chunk(msg.data)
            if full is None:
                continue
            if full.get("id") == rpc_id:
                return full
            if str(full.get("id", "")).startswith("publish:trame.state.topic"):
                self.published.append(full.get("result") or {})

    async def hello(self, secret: str, timeout: float = 30) -> dict[str, Any]:
        """Authenticate; returns the reply (``result`` on success, ``error`` otherwise)."""
        await self._send({"wslink": "1.0", "id": "system:c0:0", "method": "wslink.hello",
                          "args": [{"secret": secret}], "kwargs": {}})  # fmt: skip
        reply = await self._reply("system:c0:0", timeout)
        if "result" in reply:
            self.client_id = reply["result"]["clientID"]
        return reply

    async def call(self, method: str, *args: Any, timeout: float = 60) -> dict[str, Any]:
        """Call an RPC method; the raw reply."""
        rpc_id = f"rpc:{self.client_id}:{next(self.ids)}"
        await self._send({"wslink": "1.0", "id": rpc_id, "method": method, "args": list(args), "kwargs": {}})
        return await self._reply(rpc_id, timeout)

    async def trigger(self, name: str, *args: Any, timeout: float = 60) -> dict[str, Any]:
        """Call a trame trigger (what a button's ``trigger('name', [...])`` does)."""
        return await self.call("trame.trigger", name, list(args), {}, timeout=timeout)

    async def set_state(self, **values: Any) -> dict[str, Any]:
        """Change state variables (what a text field or a file input does)."""
        return await self.call("trame.state.update", [{"key": k, "value": v} for k, v in values.items()])

    async def state(self) -> dict[str, Any]:
        """The server's whole state (``trame.state.get``)."""
        return (await self.call("trame.state.get"))["result"]["state"]

    async def wait_for_state(self, predicate: Any, timeout: float) -> dict[str, Any]:
        """Poll the state until ``predicate(state)`` holds (raises TimeoutError)."""
        deadline = time.monotonic() + timeout
        while True:
            state = await self.state()
            if predicate(state):
                return state
            if time.monotonic() > deadline:
                raise TimeoutError(f"state never satisfied the condition; last messages: {state.get('messages')}")
            await asyncio.sleep(0.2)


class connect:
    """``async with connect(ws_url, origin=..., host=...) as session``; raises :class:`Refused` on a 4xx/5xx."""

    def __init__(self, ws_url: str, origin: str | None = None, host: str | None = None) -> None:
        self.ws_url, self.origin, self.host = ws_url, origin, host

    async def __aenter__(self) -> Session:
        self.http = aiohttp.ClientSession()
        headers = {"Host": self.host} if self.host else {}
        try:
            ws = await self.http.ws_connect(self.ws_url, origin=self.origin, headers=headers, max_msg_size=0)
        except aiohttp.WSServerHandshakeError as exc:
            await self.http.close()
            raise Refused(exc.status) from None
        self.session = Session(ws, self.http)
        return self.session

    async def __aexit__(self, *exc: Any) -> None:
        await self.session.ws.close()
        await self.http.close()


def messages(state: dict[str, Any]) -> list[str]:
    """The page's message texts, newest first."""
    return [m["text"] for m in state.get("messages", [])]


def http_status(url: str, headers: dict[str, str] | None = None, timeout: float = 30) -> int:
    """The HTTP status of a GET (403 and other errors included; 0 if nothing listens)."""
    request = urllib.request.Request(url, headers=headers or {})
    try:
        with urllib.request.urlopen(request, timeout=timeout) as response:
            return response.status
    except urllib.error.HTTPError as exc:
        return exc.code
    except urllib.error.URLError:
        return 0


def printed_url(log: Path) -> str | None:
    """The URL (with its token) the app printed, once it has."""
    found = URL_RE.search(log.read_text())
    return found.group(1) if found else None


def dump(obj: Any) -> str:
    return json.dumps(obj, default=str)[:2000]
