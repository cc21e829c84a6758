"""The page's server: static files over HTTP and one WebSocket per page, on an asyncio loop.

`websockets` serves both (its handshake hook answers plain GETs), so there is no web framework and
no front-end build: the page is three files in services/ui/static. Down the socket go JSON texts
(hello, view, reply, error) and binary camera frames (FRAME_HEADER then the JPEG), each page
getting the newest frame only, so a slow phone never queues seconds of video. Up come checked
requests (services/ui/protocol.py). On an address other than loopback, the socket needs the token
printed at start, and the page is served over HTTPS; a socket opened from another site's page (its Origin
not this server) is refused.
"""
from __future__ import annotations

import asyncio
import collections
import errno
import hmac
import json
import logging
import mimetypes
import ssl
import threading
import time
from http import HTTPStatus
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

from websockets.asyncio.server import ServerConnection, serve
from websockets.datastructures import Headers
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response

from services.ui.protocol import BadMessage, parse

STATIC = Path(__file__).parent / "static"
PAGES = {"/": "index.html", "/index.html": "index.html", "/app.js": "app.js", "/style.css": "style.css"}
MAX_PAGES = 16  # pages open at once
MAX_REQUESTS_PER_S = 60  # per page: a held key refreshes 10 times a second
SOCKET_MAX_BYTES = 64 * 1024  # larger closes the socket (1009); up to it, protocol.py explains the refusal
VIEWS_QUEUED = 20
PORT_TRIES = 10


class Page:
    """One open page: what is waiting to be sent to it."""

    def __init__(self, ws: ServerConnection):
        self.ws, self.frame, self.texts = ws, None, collections.deque(maxlen=VIEWS_QUEUED)
        self.ready = asyncio.Event()
        self.allowance, self.checked = float(MAX_REQUESTS_PER_S), time.monotonic()
        self.holding: set[str] = set()  # teachers this page holds on (press-and-hold), let go when it closes

    def send_text(self, obj: dict) -> None:
        self.texts.append(json.dumps(obj, separators=(",", ":")))
        self.ready.set()

    def allowed(self) -> bool:
        now = time.monotonic()
        self.allowance = min(MAX_REQUESTS_PER_S, self.allowance + (now - self.checked) * MAX_REQUESTS_PER_S)
        self.checked = now
        if self.allowance < 1.0:
            return False
        self.allowance -= 1.0
        return True


class UiServer:
    def __init__(self, bridge, hello: dict, host: str, port: int, token: str | None, log: logging.Logger,
                 tls: ssl.SSLContext | None = None):
        self.bridge, self.hello, self.host, self.port, self.token, self.log = bridge, hello, host, port, token, log
        self.tls = tls  # HTTPS and wss when given (services/ui/tls.py)
        self.pages: set[Page] = set()
        self.n_outputs = len(hello["outputs"]["names"])
        self.loop: asyncio.AbstractEventLoop | None = None
        self.rejected = collections.Counter()

    def counts(self) -> dict:
        """For the status (read on the bus thread: a racy read of two small ints is fine)."""
        return {"pages": len(self.pages), **{f"refused_{k}": v for k, v in self.rejected.items()}}

    # --- from the bus thread ---------------------------------------------------------------------
    def emit(self, kind: str, payload) -> None:
        """Called by the bridge on its own thread: hands over to the event loop, never blocks."""
        loop = self.loop
        if loop is not None:
            try:
                loop.call_soon_threadsafe(self._fan_out, kind, payload)
            except RuntimeError:  # the loop closed since: the server stopped, no page is left to tell
                pass

    def _fan_out(self, kind: str, payload) -> None:
        for page in self.pages:
            if kind == "frame":
                page.frame = payload  # the newest only
                page.ready.set()
            else:
                page.send_text(payload)

    # --- HTTP ------------------------------------------------------------------------------------
    def process_request(self, connection: ServerConnection, request: Request) -> Response | None:
        url = urlsplit(request.path)
        if url.path == "/ws":
            return self._refuse_socket(request, url)
        name = PAGES.get(url.path)
        if name is None:
            return _response(HTTPStatus.NOT_FOUND, b"not found\n", "text/plain")
        body = (STATIC / name).read_bytes()
        return _response(HTTPStatus.OK, body, mimetypes.guess_type(name)[0] or "text/plain")

    def _refuse_socket(self, request: Request, url) -> Response | None:
        origin = request.headers.get("Origin")
        host = request.headers.get("Host", "")
        if origin is not None and urlsplit(origin).netloc != host:
            self.rejected["origin"] += 1
            self.log.warning("refused a socket from another site's page (Origin %s, Host %s)", origin[:100], host[:100])
            return _response(HTTPStatus.FORBIDDEN, b"this page's socket is for pages this server serves\n",
                             "text/plain")
        if self.token is not None:
            given = parse_qs(url.query).get("token", [""])[0]
            if not hmac.compare_digest(given.encode(), self.token.encode()):
                self.rejected["token"] += 1
                return _response(HTTPStatus.UNAUTHORIZED, b"open the address with ?token=... as printed at start\n",
                                 "text/plain")
        if len(self.pages) >= MAX_PAGES:
            return _response(HTTPStatus.SERVICE_UNAVAILABLE, f"{MAX_PAGES} pages open already\n".encode(),
                             "text/plain")
        return None

    # --- one page --------------------------------------------------------------------------------
    async def handle(self, ws: ServerConnection) -> None:
        page = Page(ws)
        self.pages.add(page)
        page.send_text(dict(self.hello, type="hello"))
        sender = asyncio.create_task(self._send(page))
        try:
            async for raw in ws:
                self._on_message(page, raw)
        except ConnectionClosed:
            pass
        finally:
            self.pages.discard(page)
            sender.cancel()
            for teacher in page.holding:  # a page closed mid-press lets go of what it held
                self.bridge.request("teach", {"teacher": teacher, "on": False}, lambda *_: None)

    def _on_message(self, page: Page, raw) -> None:
        if not page.allowed():
            self._refuse(page, f"more than {MAX_REQUESTS_PER_S} requests a second: dropped")
            return
        try:
            msg = parse(raw, self.n_outputs)
        except BadMessage as err:
            self._refuse(page, str(err))
            return
        if msg.op == "ping":
            page.send_text({"type": "pong", "sent": msg.fields.get("sent", 0.0), "server": time.time() * 1000})
            return
        if msg.op == "teach":
            held = msg.fields.pop("hold", False)
            (page.holding.add if held and msg.fields["on"] else page.holding.discard)(msg.fields["teacher"])
        loop = self.loop

        def reply(text: str, ok: bool) -> None:  # on the bus thread
            loop.call_soon_threadsafe(page.send_text, {"type": "reply", "op": msg.op, "ok": ok, "text": text})
        self.bridge.request(msg.op, msg.fields, reply)

    def _refuse(self, page: Page, reason: str) -> None:
        self.rejected["message"] += 1
        self.log.warning("rejected a page message: %s", reason)
        page.send_text({"type": "error", "text": reason})

    async def _send(self, page: Page) -> None:
        try:
            while True:
                await page.ready.wait()
                page.ready.clear()
                while page.texts:
                    await page.ws.send(page.texts.popleft())
                if page.frame is not None:
                    frame, page.frame = page.frame, None
                    await page.ws.send(frame)
        except ConnectionClosed:
            pass

    # --- life ------------------------------------------------------------------------------------
    async def serve(self, stop: threading.Event, on_listening) -> None:
        """Serves until `stop`; a busy port gives way to the next of PORT_TRIES (a second page server on
        the same machine, or another program on 8080): `on_listening(port)` says which one it got."""
        self.loop = asyncio.get_running_loop()
        for port in range(self.port, self.port + (PORT_TRIES if self.port else 1)):
            try:
                server = await serve(self.handle, self.host, port, process_request=self.process_request,
                                     max_size=SOCKET_MAX_BYTES, ping_interval=5, ping_timeout=10, ssl=self.tls)
            except OSError as err:
                if err.errno != errno.EADDRINUSE or port == self.port + PORT_TRIES - 1:
                    raise
                self.log.warning("port %d is taken: trying %d", port, port + 1)
                continue
            break
        try:
            async with server:
                self.port = server.sockets[0].getsockname()[1]
                on_listening(self.port)
                while not stop.is_set():
                    await asyncio.sleep(0.1)
        finally:
            self.loop = None  # before the loop closes: the bus thread stops handing over


def _response(status: HTTPStatus, body: bytes, content_type: str) -> Response:
    headers = Headers([("Content-Type", f"{content_type}; charset=utf-8"),  # (every file served is text)
                       ("Content-Length", str(len(body))), ("Cache-Control", "no-store"),
                       ("X-Content-Type-Options", "nosniff")])
    return Response(status.value, status.phrase, headers, body)

