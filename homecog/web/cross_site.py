"""No other site can make a browser change anything here (cross-site request forgery).

A page on any site the household visits can make their browser send a form post to the robot on
``127.0.0.1`` (where it needs no token) or send it with the token's cookie: an undo, a
correction, a change of context. Every request that changes something (any method but GET,
HEAD and OPTIONS) is refused with 403 where the browser says it comes from elsewhere: a
``Sec-Fetch-Site`` of ``cross-site`` or ``same-site`` (another port or subdomain), or an
``Origin`` that is not this server's own. Clients that are not browsers (the robot, scripts,
``curl``) send neither and are not concerned; the HMI sends its own origin.

>>> own = [(b"host", b"robot:8000"), (b"origin", b"http://robot:8000"), (b"sec-fetch-site", b"same-origin")]
>>> from_elsewhere(own, "POST"), from_elsewhere([(b"origin", b"https://evil.example")], "POST")
(None, 'a request from https://evil.example may not change anything here')
>>> from_elsewhere([(b"sec-fetch-site", b"cross-site")], "GET") is None   # reading: not concerned
True
"""

from __future__ import annotations

import json
from typing import Any

SAFE = ("GET", "HEAD", "OPTIONS")


def from_elsewhere(headers: list[tuple[bytes, bytes]], method: str) -> str | None:
    """Why a request that changes something comes from another site (``None``: it does not)."""
    if method in SAFE:
        return None
    found = dict(headers)
    site = found.get(b"sec-fetch-site", b"").lower()
    if site in (b"cross-site", b"same-site"):
        return f"a {site.decode()} request may not change anything here"
    origin, host = found.get(b"origin"), found.get(b"host", b"")
    if origin is not None and origin not in (b"http://" + host, b"https://" + host):
        shown = origin.decode("latin-1")[:100].encode("ascii", "replace").decode()
        return f"a request from {shown} may not change anything here"
    return None


class CrossSiteGuard:
    """Pure ASGI middleware answering 403 to a request that changes something from another
    site (:func:`from_elsewhere`); everything else passes untouched."""

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] == "http":
            why = from_elsewhere(scope["headers"], scope["method"])
            if why is not None:
                body = json.dumps({"detail": why}).encode()
                headers = [
                    (b"content-type", b"application/json"),
                    (b"content-length", str(len(body)).encode()),
                ]
                await send({"type": "http.response.start", "status": 403, "headers": headers})
                await send({"type": "http.response.body", "body": body})
                return
        await self.app(scope, receive, send)
