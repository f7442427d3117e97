"""``POST /api/session``: the token kept for this browser in a cookie no script can read.

The page asks for the token once and hands it here; the answer sets ``homecog_token``
(HttpOnly, SameSite=Strict, path ``/api``), which the browser then sends with every request to
the API, the event stream included. So neither the page's own scripts nor one that data smuggled
into it (a name with markup, were one ever shown as markup) can read the token.
"""

from __future__ import annotations

from fastapi import APIRouter, Response

from homecog.web.deps import COOKIE, SettingsDep

router = APIRouter(tags=["home"])


@router.post("/api/session", status_code=204, response_class=Response)
def session(settings: SettingsDep) -> Response:
    """Keep the token (given as ``Authorization: Bearer <token>``) in an HttpOnly cookie for this
    browser; a server without a token sets none."""
    answer = Response(status_code=204)
    if settings.token is not None:
        answer.set_cookie(COOKIE, settings.token, httponly=True, samesite="strict", path="/api")
    return answer
