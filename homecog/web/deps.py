"""What the routes depend on (``Depends``): the running robot, its store, the settings, and the
token check.

With a token (always, off 127.0.0.1) every ``/api`` endpoint needs it, reads included: where the
user is and whether they sleep is nobody else's business. It comes as
``Authorization: Bearer <token>``, or as the cookie ``homecog_token`` that ``POST /api/session``
sets (HttpOnly, SameSite=Strict, path ``/api``): the page's way, so that no script in the page,
its own or one smuggled in by data, can read the token. ``GET /api/events`` also takes it as the
query parameter ``access_token`` (RFC 6750 §2.3), for clients that can send neither. The server
logs no URLs. Every check compares bytes in constant time, in one function (:func:`matches`); a
token is printable ASCII (:mod:`homecog.web.settings`), the same bytes in every header.
"""

from __future__ import annotations

import hmac
from typing import Annotated

from fastapi import Depends, HTTPException, Request, Security
from fastapi.security import APIKeyCookie, APIKeyQuery, HTTPAuthorizationCredentials, HTTPBearer

from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime
from homecog.web.settings import Settings

bearer = HTTPBearer(
    auto_error=False,
    scheme_name="token",
    description="The token `homecog up` printed (or was given): `Authorization: Bearer <token>`.",
)
in_query = APIKeyQuery(
    name="access_token",
    auto_error=False,
    scheme_name="token_in_query",
    description="The same token as a query parameter, for EventSource (GET /api/events only).",
)
in_cookie = APIKeyCookie(
    name="homecog_token",
    auto_error=False,
    scheme_name="token_in_cookie",
    description="The same token as an HttpOnly cookie, set by POST /api/session (the HMI's way).",
)
COOKIE = "homecog_token"
MISSING = "this server needs its token: Authorization: Bearer <token>"


def matches(given: bytes | str | None, token: str) -> bool:
    """Whether ``given`` is the token, compared as bytes in constant time: the one comparison
    of every check (a header, the cookie, the query parameter). A header may hold any byte; a
    token is printable ASCII (:mod:`homecog.web.settings`), the same bytes in every header.

    >>> matches("s3cret-token", "s3cret-token"), matches(b"s3cret-tokeN", "s3cret-token"), matches("é", "x")
    (True, False, False)
    """
    if given is None:
        return False
    return hmac.compare_digest(given.encode() if isinstance(given, str) else given, token.encode())


def authorized(headers: list[tuple[bytes, bytes]], token: str | None, method: str = "GET") -> bool:
    """Whether raw ASGI ``headers`` carry ``token``: as a bearer, or in the cookie. The cookie
    opens a request that changes something (any method but GET and HEAD) only from the page's
    own origin (``Origin`` is the server's), so that no other page a browser shows (another
    site, or another server on this machine) can make the browser act with it.

    >>> authorized([(b"authorization", b"Bearer s3cret-token")], "s3cret-token")
    True
    >>> authorized([(b"authorization", b"Bearer s3cret-tokeN")], "s3cret-token")
    False
    >>> cookie = (b"cookie", b"a=1; homecog_token=s3cret-token")
    >>> authorized([cookie], "s3cret-token"), authorized([cookie], "s3cret-token", "POST")
    (True, False)
    >>> own = [cookie, (b"host", b"robot:8000"), (b"origin", b"http://robot:8000")]
    >>> authorized(own, "s3cret-token", "POST")
    True
    """
    if token is None:
        return True
    found = dict(headers)
    scheme, _, given = found.get(b"authorization", b"").partition(b" ")
    if scheme.lower() == b"bearer" and matches(given.strip(), token):
        return True
    for part in found.get(b"cookie", b"").split(b";"):
        key, _, given = part.strip().partition(b"=")
        if key == COOKIE.encode() and matches(given, token):
            origin, host = found.get(b"origin"), found.get(b"host", b"")
            return method in ("GET", "HEAD") or origin in (b"http://" + host, b"https://" + host)
    return False


def get_runtime(request: Request) -> Runtime:
    return request.app.state.runtime


def get_settings(request: Request) -> Settings:
    return request.app.state.settings


RuntimeDep = Annotated[Runtime, Depends(get_runtime)]
SettingsDep = Annotated[Settings, Depends(get_settings)]


def get_store(runtime: RuntimeDep) -> Store:
    return runtime.store


StoreDep = Annotated[Store, Depends(get_store)]


def require_token(
    request: Request,
    settings: SettingsDep,
    credentials: Annotated[HTTPAuthorizationCredentials | None, Security(bearer)],
    cookie: Annotated[str | None, Security(in_cookie)],
) -> None:
    """401 unless the request carries the server's token (a bearer, or the cookie:
    :func:`authorized`)."""
    if not authorized(request.scope["headers"], settings.token, request.method):
        raise HTTPException(401, detail=MISSING, headers={"WWW-Authenticate": "Bearer"})


def require_token_or_query(
    request: Request,
    settings: SettingsDep,
    credentials: Annotated[HTTPAuthorizationCredentials | None, Security(bearer)],
    cookie: Annotated[str | None, Security(in_cookie)],
    access_token: Annotated[str | None, Security(in_query)],
) -> None:
    """As :func:`require_token`, the token also taken from ``?access_token=``."""
    if settings.token is None or matches(access_token, settings.token):
        return
    if not authorized(request.scope["headers"], settings.token, request.method):
        raise HTTPException(
            401, detail=f"{MISSING} (or ?access_token=<token>)", headers={"WWW-Authenticate": "Bearer"}
        )
