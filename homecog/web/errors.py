"""Every error answer as ``{"detail": "<one message>"}`` (:class:`~homecog.web.models.ErrorOut`).

- 422: the request does not fit the contract. The message words it as the home's own parsing
  does (``activity: unknown value 'dance'; expected one of work, relax, sleep``), so a context
  refused by the server reads as one refused by a scenario file or ``--context``.
- 409: a valid request the server cannot carry out now (a context that comes from a simulator or
  a broker set by hand; a plan in a home without a floor plan).
- 503: the knowledge database cannot be used, or the home has not reported its state yet.
- 404 (``homecog serve`` only): no home of the name in the URL; the message names those there are.
- 405 lists in ``Allow`` every method of the path, not just those of the route that matched.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Iterator, Mapping
from typing import Any

import pydantic_core
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from homecog.errors import ContextError, HomecogError, PlanningError, StoreError
from homecog.home.model import Home
from homecog.home.states import parse_state
from homecog.web.models import CORRECTION_ERRORS, ErrorOut

log = logging.getLogger("homecog.web")
BODY_UNREADABLE = "There was an error parsing the body"  # FastAPI's 400
METHODS = ("GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS")


def responses(*codes: int, stream: bool = False) -> dict[int | str, dict[str, Any]]:
    """The documented error answers of an operation, each with the one error model (as JSON also
    where the operation's own answer is an event ``stream``)."""
    what = {
        401: "No token, or a wrong one: this server needs `Authorization: Bearer <token>`.",
        404: "No home of this name in the database (`homecog serve`); the message names those it holds.",
        409: "A valid request the server cannot carry out in its present state.",
        413: "A request body over the size limit (64 KiB).",
        422: "The request does not fit the contract; the message names what is wrong.",
        429: "The planner is busy with other plans: ask again after `Retry-After` seconds.",
        503: "The knowledge database cannot be used, or the home has not reported its state yet.",
    }
    if stream:
        error = {"application/json": {"schema": {"$ref": "#/components/schemas/ErrorOut"}}}
        return {code: {"description": what[code], "content": error} for code in codes}
    return {code: {"model": ErrorOut, "description": what[code]} for code in codes}


def install(app: FastAPI, home: Home) -> None:
    """Make every error of ``app`` an :class:`ErrorOut` with the right status."""

    @app.exception_handler(RequestValidationError)
    async def invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        return _error(422, validation_message(exc.errors(), home))

    @app.exception_handler(StoreError)
    async def store_error(request: Request, exc: StoreError) -> JSONResponse:
        log.warning("the knowledge database: %s", exc)
        return _error(503, f"the knowledge database cannot be used: {exc}")

    @app.exception_handler(PlanningError)
    async def planning_error(request: Request, exc: PlanningError) -> JSONResponse:
        return _error(409, str(exc))

    @app.exception_handler(HomecogError)
    async def homecog_error(request: Request, exc: HomecogError) -> JSONResponse:
        return _error(422, str(exc))

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        headers, detail, status = dict(exc.headers or {}), str(exc.detail), exc.status_code
        if status == 400 and detail == BODY_UNREADABLE:  # FastAPI's reader gave up: say why
            return _error(422, f"body: invalid JSON: {unreadable(await request.body())}")
        if status == 405:
            allowed = _allowed(app, request)
            headers["Allow"] = ", ".join(allowed)
            detail = f"{request.method} is not allowed here; allowed: {', '.join(allowed)}"
        return _error(status, detail, headers)

    @app.exception_handler(Exception)
    async def internal(request: Request, exc: Exception) -> JSONResponse:
        # Starlette logs the traceback after this answer; bad input never gets here
        return _error(500, f"internal error ({type(exc).__name__}); the server's log has the details")


def unreadable(body: bytes) -> str:
    """Why a body that FastAPI could not read as JSON is not JSON, in a few words.

    >>> unreadable(b"\\xff"), unreadable(b"[" * 1000 + b"]" * 1000)
    ('not UTF-8 text', 'nested deeper than 200 levels')
    """
    try:
        body.decode("utf-8")
    except UnicodeDecodeError:
        return "not UTF-8 text"
    try:
        pydantic_core.from_json(body)
    except ValueError as e:
        if str(e).startswith("recursion limit exceeded"):
            return "nested deeper than 200 levels"
        return str(e)
    return "cannot be read"


def _error(status: int, detail: str, headers: Mapping[str, str] | None = None) -> JSONResponse:
    return JSONResponse({"detail": detail}, status_code=status, headers=dict(headers or {}))


def _allowed(app: FastAPI, request: Request) -> list[str]:
    """Every method some route of the app takes on the request's path (Starlette's 405 names only
    the methods of the first route that matched the path: GET, where PUT was allowed too)."""
    methods: set[str] = set()
    for route in _routes(app.router.routes):
        regex = getattr(route, "path_regex", None)
        if regex is not None and regex.match(request.url.path):
            methods |= set(getattr(route, "methods", None) or ())
    return [m for m in METHODS if m in methods]


def _routes(routes: Iterable[Any]) -> Iterator[Any]:
    """The routes, those of included routers (which FastAPI keeps whole, unprefixed here) too."""
    for route in routes:
        inner = getattr(route, "original_router", None)
        if inner is not None:
            yield from _routes(inner.routes)
        else:
            yield route


# -- wording validation errors ------------------------------------------------------------------
def validation_message(errors: Any, home: Home) -> str:
    """The first problem of a refused request as one line, in the home's words where it is about
    the context."""
    if not errors:
        return "invalid request"
    e = errors[0]
    loc = [str(p) for p in e.get("loc", ())]
    kind = e.get("type", "")
    where = loc[1:] if loc and loc[0] in ("body", "query", "path", "header") else loc
    if kind == "json_invalid":
        at = f" at character {where[0]}" if where else ""
        return f"body: invalid JSON{at}: {(e.get('ctx') or {}).get('error', 'cannot be read')}"
    message = _context_message(e, where, home) or _services_message(e, where, home)
    if message is not None:
        return message
    if not where and kind in ("model_attributes_type", "dict_type", "model_type"):
        return "body: expected a JSON object"
    msg = str(e.get("msg", "invalid"))
    return f"{'.'.join(where) or 'body'}: {msg[:1].lower()}{msg[1:]}"


def _context_message(e: Any, where: list[str], home: Home) -> str | None:
    """The error ``e`` at ``where`` in the home's words, when it is about a context (or values);
    else None."""
    if not where or where[0] not in ("context", "values"):
        return None
    kind, names = e.get("type", ""), home.feature_names + home.device_names
    if len(where) >= 2 and where[1] in names:
        return (
            f"missing {where[1]}"
            if kind == "missing"
            else context_value_message(home, where[1], e.get("input"))
        )
    if len(where) == 2 and kind == "extra_forbidden":
        return f"unknown feature or device {where[1]!r}; expected {', '.join(names)}"
    if kind.endswith(("dict_type", "typed_dict_type")):
        which = "every feature and device" if where[0] == "context" else "features or devices"
        return f"{where[0]}: expected an object with {which} of the home"
    return None


def _services_message(e: Any, where: list[str], home: Home) -> str | None:
    """The error ``e`` at ``where`` in the home's words, when it is about services, a correction
    or a user; else None."""
    kind, given, known = e.get("type", ""), e.get("input"), ", ".join(home.service_names)
    if len(where) == 2 and where[0] in ("want", "services") and kind == "literal_error":
        # the words of parse_services and of the planner
        return f"unknown service {given!r}; " + (
            f"expected some of {known}" if where[0] == "want" else f"the home has {known}"
        )
    if kind in CORRECTION_ERRORS:  # a correction's own rules: their message says it all
        return str(e.get("msg", "invalid correction"))
    if kind == "user_name":
        return f"{'.'.join(where) or 'user'}: {e.get('msg')}"
    return _change_message(kind, given, where, known)


def _change_message(kind: str, given: object, where: list[str], known: str) -> str | None:
    """A ``change`` of a correction refused, in the home's words (``known``: its services)."""
    if len(where) == 2 and where[0] == "change" and kind == "extra_forbidden":
        return f"unknown service {where[1]!r}; expected some of {known}"
    if len(where) == 2 and where[0] == "change" and kind == "literal_error":
        return f'change: {where[1]}: expected "add" or "reject", not {given!r}'
    if where == ["change"] and kind.endswith(("dict_type", "typed_dict_type")):
        return 'change: expected an object of services, each "add" or "reject"'
    return None


def context_value_message(home: Home, name: str, given: object) -> str:
    """Why a value of a feature or device is refused: the home's own message where the home
    refuses it too, else what the contract asks for instead."""
    try:
        if name in home.device_names:
            parse_state(given, name)
            return f'{name}: write the state as "on" or "off", not {given!r}'
        feature = home.feature(name)
        if feature.kind == "categorical":
            return f"{name}: unknown value {given!r}; expected one of {', '.join(feature.values)}"
        feature.discretize(given)
    except ContextError as e:
        return str(e)
    if feature.kind == "clock":
        return f'{name}: {given!r} is not a time of day; write "HH:MM", "HH:MM:SS" or decimal hours'
    return f"{name}: write the reading as a JSON number, not {given!r}"
