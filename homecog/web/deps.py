"""What the routes depend on (``Depends``): the running robot, its store, the settings, and the
token check.

With a token (always, off 127.0.0.1) every ``/api`` endpoint needs it, reads included: where the
user is and whether they sleep is nobody else's business. It comes as
``Authorization: Bearer <token>``; ``GET /api/events`` also takes it as the query parameter
``access_token`` (RFC 6750 §2.3), because a browser's ``EventSource`` cannot send headers. The
server logs no URLs, and the page opens the stream on its own origin.
"""

from __future__ import annotations

import hmac
from typing import Annotated

from fastapi import Depends, HTTPException, Request, Security
from fastapi.security import APIKeyQuery, HTTPAuthorizationCredentials, HTTPBearer

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
MISSING = "this server needs its token: Authorization: Bearer <token>"


def get_runtime(request: Request) -> Runtime:
    return request.app.state.runtime


def get_settings(request: Request) -> Settings:
    return request.app.state.settings


RuntimeDep = Annotated[Runtime, Depends(get_runtime)]
SettingsDep = Annotated[Settings, Depends(get_settings)]


def get_store(runtime: RuntimeDep) -> Store:
    return runtime.store


StoreDep = Annotated[Store, Depends(get_store)]


def matches(given: str | None, token: str) -> bool:
    """Whether ``given`` is the token, in constant time (bytes: headers may hold any character).

    >>> matches("s3cret-token", "s3cret-token"), matches("s3cret-tokeN", "s3cret-token"), matches("é", "x")
    (True, False, False)
    """
    return given is not None and hmac.compare_digest(given.encode(), token.encode())


def require_token(
    settings: SettingsDep, credentials: Annotated[HTTPAuthorizationCredentials | None, Security(bearer)]
) -> None:
    """401 unless the request carries the server's token."""
    if settings.token is not None and not matches(credentials and credentials.credentials, settings.token):
        raise HTTPException(401, detail=MISSING, headers={"WWW-Authenticate": "Bearer"})


def require_token_or_query(
    settings: SettingsDep,
    credentials: Annotated[HTTPAuthorizationCredentials | None, Security(bearer)],
    access_token: Annotated[str | None, Security(in_query)],
) -> None:
    """As :func:`require_token`, the token also taken from ``?access_token=``."""
    if settings.token is None:
        return
    if not (
        matches(credentials and credentials.credentials, settings.token)
        or matches(access_token, settings.token)
    ):
        raise HTTPException(
            401, detail=f"{MISSING} (or ?access_token=<token>)", headers={"WWW-Authenticate": "Bearer"}
        )
