"""Who may talk to a trame server this package starts: the holder of a per-run token, from the server's own origin.

Listening on 127.0.0.1 does not protect a local server: any web page the user visits can open a
WebSocket to ``ws://127.0.0.1:PORT/ws``. trame's own defaults do not stop it (no Origin check, and
the wslink secret is the public ``"wslink-secret"``). Every server the package starts (the
standalone app and the notebook views) is therefore :func:`protect`-ed, the way Jupyter protects
itself:

1. **Host** (every HTTP request and WebSocket handshake): a loopback name or address, or, when the
   server listens on another interface, an IP address or this machine's name. A DNS-rebinding page
   (``evil.example`` re-pointed at 127.0.0.1) sends its own name and is refused.
2. **Origin** (sent by every browser on WebSocket handshakes and cross-origin requests): the same
   host and port as the Host header. A page from another site is refused with 403.
3. **Token**: wslink's hello secret is a fresh random token per server. The trame client reads it
   from the ``secret`` parameter of the page's URL (and then removes it from the address bar), so
   the URL the app prints, or the notebook's iframe ``src``, carries it; nobody else knows it.

Behind jupyter-server-proxy (Jupyter's ``<base_url>proxy/<port>/``) the browser talks to Jupyter,
which checks its own token, Host and Origin and forwards the request with the browser's Host and
Origin, those of Jupyter's page (same-origin with each other). Such a Host names *Jupyter's* port,
not the one the connection reached this server on: a page that reaches this server directly (a
DNS-rebinding page included) can only name the port it connected to, so a Host naming another port
came through a forwarder and is accepted, whatever its name (a remote Jupyter, a hub); the Origin
must still match it and the token is still required. Only the notebook views' server accepts such a
Host (``AccessPolicy(forwarded=True)``); the standalone app, reached directly, does not. With PyVista's
``pyvista.global_theme.trame.server_proxy_enabled`` (set by JupyterHub's environment) any Host is
accepted, under the same two conditions.

The page (``index.html``) carries the header :data:`SERVER_ID_HEADER`: a public fingerprint of the
token (:attr:`AccessPolicy.server_id`), by which the notebook's view checks that an address answers
with *this* server before it sends the token there (:mod:`.jupyter`). The reload cookie (see
:func:`_guard_middleware`) is scoped to the page's own folder as the browser sees it: through
Jupyter's proxy, ``<base_url>proxy/<port>/``, so it never travels to Jupyter's other pages or, on a
hub, to other users' servers.

The product registers no trigger that returns internal state: the tests' instrumentation
(``tests/editor_instrument.py``) is installed by test code only, never by a setting.
"""

from __future__ import annotations

import hashlib
import ipaddress
import secrets
import socket
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import parse_qsl, urlencode, urlsplit, urlunsplit

__all__ = [
    "SERVER_ID_HEADER",
    "TOKEN_PARAM",
    "AccessPolicy",
    "is_loopback",
    "new_token",
    "protect",
    "url_with_token",
]

TOKEN_PARAM = "secret"  # the URL parameter the trame client reads wslink's secret from
#: the response header naming the server that answered (:attr:`AccessPolicy.server_id`)
SERVER_ID_HEADER = "X-Ffd-Notebook-Server"
_DEFAULT_PORTS = {"http": 80, "https": 443, "ws": 80, "wss": 443}


def new_token() -> str:
    """A fresh random session token (256 bits, URL-safe).

    Examples
    --------
    >>> a, b = new_token(), new_token()
    >>> a != b and len(a) >= 40
    True
    """
    return secrets.token_urlsafe(32)


def url_with_token(url: str, token: str) -> str:
    """``url`` with ``secret=<token>`` added to its query (what the trame client reads).

    Examples
    --------
    >>> url_with_token("http://127.0.0.1:8080/index.html?ui=a&reconnect=auto", "T0K")
    'http://127.0.0.1:8080/index.html?ui=a&reconnect=auto&secret=T0K'
    >>> url_with_token("/proxy/9000/", "T0K")
    '/proxy/9000/?secret=T0K'
    """
    parts = urlsplit(url)
    query = [(k, v) for k, v in parse_qsl(parts.query, keep_blank_values=True) if k != TOKEN_PARAM]
    return urlunsplit(parts._replace(query=urlencode([*query, (TOKEN_PARAM, token)])))


def _split_host(netloc: str, scheme: str = "http") -> tuple[str, int | None]:
    """``("host", port)`` from ``host[:port]`` (IPv6 in brackets); the scheme's default port if none."""
    parsed = urlsplit(f"//{netloc}")
    try:
        port = parsed.port
    except ValueError:
        return "", None
    return (parsed.hostname or "").lower(), port if port is not None else _DEFAULT_PORTS.get(scheme)


def is_loopback(host: str) -> bool:
    """Whether ``host`` (a name or an IP address, as in a Host header or a ``--host`` option) is this machine's
    loopback: ``localhost`` and every name under ``.localhost``, or a loopback address.

    Names under ``.localhost`` are loopback by definition (RFC 6761, section 6.3): browsers resolve
    them to the loopback address themselves, without asking DNS, so a page cannot rebind them to
    another machine, and a Host header that carries one comes from a connection to this machine.
    An IPv4 address mapped into IPv6 (``::ffff:127.0.0.1``) is loopback when the IPv4 one is.

    Examples
    --------
    >>> [is_loopback(h) for h in ("localhost", "app.localhost", "LOCALHOST.", "127.8.0.1", "[::1]")]
    [True, True, True, True, True]
    >>> [is_loopback(h) for h in ("localhost.example", "mylocalhost", "10.0.0.1", "0.0.0.0", "")]
    [False, False, False, False, False]
    """
    name = host.strip().lower().rstrip(".")
    if name.startswith("[") and name.endswith("]"):
        name = name[1:-1]
    if name == "localhost" or name.endswith(".localhost"):
        return True
    try:
        address = ipaddress.ip_address(name)
    except ValueError:
        return False
    mapped = getattr(address, "ipv4_mapped", None)
    return bool(address.is_loopback or (mapped is not None and mapped.is_loopback))


def _is_ip(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


def _machine_names() -> set[str]:
    names = {socket.gethostname().lower()}
    try:
        names.add(socket.getfqdn().lower())
    except OSError:  # pragma: no cover - resolver trouble
        pass
    return names


@dataclass
class AccessPolicy:
    """The checks :func:`protect` applies (see the module docstring).

    Parameters
    ----------
    token : str
        The session token (wslink's hello secret).
    bind_host : str
        The address the server listens on; a non-loopback one also admits IP addresses and this
        machine's names as Host.
    behind_proxy : callable returning bool
        Asked per request: is the server reached through jupyter-server-proxy now? Then any Host is
        accepted (Jupyter has checked the request), still same-origin with the Origin.
    forwarded : bool
        Whether the server may be reached through a forwarder (Jupyter's proxy, for the notebook views):
        then a Host naming another port than the one the request's connection reached is accepted
        (only a forwarder sends one). The standalone app, reached directly, leaves it off.

    Examples
    --------
    >>> policy = AccessPolicy("t")
    >>> policy.allows({"Host": "127.0.0.1:8080", "Origin": "http://127.0.0.1:8080"})
    True
    >>> policy.allows({"Host": "127.0.0.1:8080", "Origin": "http://evil.example"})
    False
    >>> policy.allows({"Host": "evil.example:8080", "Origin": "http://evil.example:8080"})  # DNS rebinding
    False
    >>> policy.allows({"Host": "localhost:8080"})  # no Origin: not a browser; the token decides
    True

    A notebook view's server (``forwarded``): a request that reached port 8080 naming another port came
    through a forwarder (Jupyter's proxy); one naming 8080 itself came straight from the page that names it:

    >>> view = AccessPolicy("t", forwarded=True)
    >>> view.allows({"Host": "lab.example:8888", "Origin": "http://lab.example:8888"}, arrived_port=8080)
    True
    >>> view.allows({"Host": "evil.example:8080", "Origin": "http://evil.example:8080"}, arrived_port=8080)
    False
    >>> view.allows({"Host": "lab.example:8888", "Origin": "http://evil.example"}, arrived_port=8080)
    False
    >>> policy.allows({"Host": "lab.example:8888", "Origin": "http://lab.example:8888"}, arrived_port=8080)
    False
    """

    token: str
    bind_host: str = "127.0.0.1"
    behind_proxy: Callable[[], bool] = field(default=lambda: False)
    forwarded: bool = False

    @property
    def server_id(self) -> str:
        """A public name of the server: a fingerprint of its token, which it does not reveal.

        Examples
        --------
        >>> a = AccessPolicy("t")
        >>> a.server_id == AccessPolicy("t").server_id != AccessPolicy("u").server_id, len(a.server_id)
        (True, 16)
        """
        return hashlib.sha256(b"ffd_notebook server id:" + self.token.encode()).hexdigest()[:16]

    def host_allowed(self, host_header: str | None, arrived_port: int | None = None) -> bool:
        """Whether a request's Host header names this server (not a rebound foreign name), or a forwarder
        of it: another port than ``arrived_port``, the one the request's connection reached (see the
        module docstring)."""
        host, port = _split_host(host_header or "")
        if not host:
            return False
        if is_loopback(host) or self.behind_proxy():
            return True
        if self.forwarded and arrived_port is not None and port != arrived_port:
            return True  # named another port: a forwarder (Jupyter's proxy), which checked the Host itself
        if is_loopback(self.bind_host):
            return False
        return _is_ip(host) or host in _machine_names() or host == self.bind_host.lower()

    @staticmethod
    def origin_allowed(origin: str | None, host_header: str | None) -> bool:
        """Whether ``origin`` is the server's own (the same host and port as the Host header)."""
        if origin is None:
            return True  # browsers always send it on WebSocket handshakes; others need the token anyway
        parts = urlsplit(origin.strip())
        if parts.scheme not in ("http", "https") or not parts.netloc:
            return False  # includes "null" (sandboxed frames, file:// pages)
        return _split_host(parts.netloc, parts.scheme) == _split_host(host_header or "", parts.scheme)

    def allows(self, headers: Mapping[str, str], *, arrived_port: int | None = None) -> bool:
        """Host and Origin checks for one request's headers; ``arrived_port``: the port its connection reached."""
        host = headers.get("Host")
        return self.host_allowed(host, arrived_port) and self.origin_allowed(headers.get("Origin"), host)


def _cookie_name(token: str) -> str:
    return "ffd_notebook_" + hashlib.sha256(token.encode()).hexdigest()[:12]


def _guard_middleware(policy: AccessPolicy) -> Any:
    """Host/Origin checks on every request; and a reload of the page keeps working.

    The trame client removes the token from the address bar once it has read it, so a reload
    would lose it. The page loaded with the token therefore also sets an HttpOnly, SameSite=Strict
    cookie holding it, and a later request for the page with that cookie but no token is
    redirected to the address with the token. Another site's page cannot read either. The cookie
    has no ``Path``: the browser scopes it to the folder of the page's address as *it* sees it
    (``/`` directly, ``<base_url>proxy/<port>/`` through Jupyter), which this server cannot know.

    The page also names the server (:data:`SERVER_ID_HEADER`), for the notebook view's check of an
    address before it sends the token there.
    """
    from aiohttp import web

    cookie = _cookie_name(policy.token)

    @web.middleware
    async def guard(request: Any, handler: Any) -> Any:
        sockname = request.transport.get_extra_info("sockname") if request.transport is not None else None
        arrived_port = sockname[1] if isinstance(sockname, tuple) and len(sockname) >= 2 else None
        if not policy.allows(request.headers, arrived_port=arrived_port):
            return web.Response(status=403, text="403: this server only answers its own pages")
        if request.path.endswith("/index.html") and request.method in ("GET", "HEAD"):
            given = request.query.get(TOKEN_PARAM)
            if given is None and secrets.compare_digest(request.cookies.get(cookie, ""), policy.token):
                raise web.HTTPFound(url_with_token(str(request.rel_url), policy.token))
            response = await handler(request)
            response.headers[SERVER_ID_HEADER] = policy.server_id
            if given is not None and secrets.compare_digest(given, policy.token):
                # path "": no Path attribute (see above); aiohttp would write Path=/ by default
                response.set_cookie(cookie, policy.token, httponly=True, samesite="Strict", path="")
            return response
        return await handler(request)

    return guard


def protect(server: Any, policy: AccessPolicy) -> None:
    """Make a trame ``server`` (not started yet) require ``policy.token`` and check Host and Origin.

    The token replaces wslink's hello secret; the Host/Origin checks are an aiohttp middleware on
    every request (HTTP and WebSocket). Both are installed when trame binds its web server, before
    it listens. With trame's ``jupyter`` wslink backend (no aiohttp server: the WebSocket travels
    inside Jupyter's own authenticated connection) only the token applies.

    Raises
    ------
    RuntimeError
        If the server is already running (it would have run unprotected).
    """
    if server.running:
        raise RuntimeError("protect() must be called before the trame server starts")

    def install(ws_server: Any) -> None:
        server.protocol.updateSecret(policy.token)
        app = getattr(ws_server, "app", None)
        if app is not None and hasattr(app, "middlewares"):
            app.middlewares.append(_guard_middleware(policy))

    server.controller.on_server_bind.add(install)
