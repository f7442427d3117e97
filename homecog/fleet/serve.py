"""``homecog serve``: the HTTP API of every home of a database, stateless.

``GET /api/homes`` lists the homes; under ``/api/homes/{home}/`` each home answers the
one-home API of ``homecog up`` — ``home``, ``cognize``, ``corrections``, ``plan``,
``history`` and ``openapi.json`` — with the same routes, models and contract
(:func:`homecog.web.main.create_app` with ``fleet``), the path rewritten to theirs. The
schemas (:mod:`homecog.fleet.schema`: ``/api/openapi.json`` for the list, each home's its
own) need no token, as ``homecog up``'s; everything else under ``/api`` does when the server
has one, and an unknown home is a 404 naming the homes there are only to who has it.

The server keeps nothing the database lacks. A home's tree is loaded on first use into a
bounded LRU cache (with its home, read from the home file stored with the build); every
request reads the home's version (a primary-key lookup, batched with the other requests
waiting at that moment: :class:`Versions`) and, when another server has written since (a
correction, a build), brings the tree up to the database before it answers: so several
servers behind any load balancer answer alike, and a correction through one is seen by the
next cognition through any other. A correction goes to the database in
its transaction (the store's), then the cache follows it.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
import time
from collections import OrderedDict
from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import Any

from sqlalchemy import select
from sqlalchemy.engine import Connection
from sqlalchemy.exc import DBAPIError, SQLAlchemyError
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import Response
from starlette.routing import Mount, Route, get_route_path
from starlette.types import Receive, Scope, Send

from homecog.errors import FleetError, HomecogError, StoreError, UnknownHomeError
from homecog.fleet.schema import FLEET_SCHEMA, HOME_SCHEMA, PREFIX, fleet_schema, prefixed
from homecog.home.validator import load_home_text
from homecog.knowledge import core
from homecog.knowledge.database import db_message, make_engine, migrate
from homecog.knowledge.schema import HomeRow
from homecog.knowledge.store import Store
from homecog.knowledge.store_log import stored_homes
from homecog.names import home_name_problem, shown
from homecog.robot.assemble import Wiring, assemble
from homecog.robot.runtime import Runtime
from homecog.web.deps import MISSING, authorized
from homecog.web.main import api, create_app
from homecog.web.planner import PLANNER
from homecog.web.settings import Settings

READ = ["GET", "HEAD"]  # the methods of the list of homes and of the schemas
#: What routing adds to a request's scope, left out of the one a home's own app is given.
ROUTING = ("app", "router", "route", "endpoint", "path_params", "app_root_path")


@dataclass
class Entry:
    """A home served from the cache: its store, runtime and app, and the version they hold."""

    name: str
    store: Store
    runtime: Runtime
    app: Any
    version: tuple[int, int] | None
    schema: dict[str, Any] | None = None


class Fleet:
    """The homes of one database, each loaded on demand, at most ``cache`` of them at once."""

    def __init__(self, url: str, settings: Settings | None = None, *, cache: int = 128) -> None:
        self.url = url
        self.settings = settings or Settings()
        self.cache = cache
        self.engine = make_engine(url)
        self._entries: OrderedDict[str, Entry] = OrderedDict()
        self._loading = threading.Lock()
        self._conn: Connection | None = None  # autocommit, the version reads' own (a server's)
        self._listed: tuple[float, list[str]] | None = None  # when, the homes (for a 404)
        try:
            migrate(self.engine)
        except (SQLAlchemyError, DBAPIError, OSError) as e:
            self.engine.dispose()
            raise StoreError(db_message(url, e)) from None

    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
        self.engine.dispose()

    # -- the homes ----------------------------------------------------------------------------------
    def names(self) -> list[str]:
        """The homes with a tree, by name."""
        try:
            with self.engine.connect() as conn:
                return [name for name, _, built in stored_homes(conn) if built]
        except (SQLAlchemyError, DBAPIError) as e:
            raise StoreError(db_message(self.url, e)) from None

    def unknown(self, name: str) -> str:
        """Why ``name`` is no home here: the homes the database holds (read at most once a
        second: a client asking for names the database lacks costs no query of its own)."""
        now = time.monotonic()
        if self._listed is None or now - self._listed[0] > 1.0:
            self._listed = (now, self.names())
        names = self._listed[1]
        return f"unknown home {shown(name)}; the database holds " + (
            ", ".join(repr(n) for n in names) if names else "no home yet (homecog fleet train)"
        )

    def entry(self, name: str) -> Entry:
        """The home's entry, from the cache or loaded (:class:`UnknownHomeError` naming the homes
        there are); not checked for staleness (:meth:`fresh`)."""
        entry = self.cached(name)
        if entry is not None:
            return entry
        with self._loading:  # one load of a home at a time, not one per waiting request
            entry = self._entries.get(name)
            if entry is None:
                entry = self._load(name)
                self._entries[name] = entry
                while len(self._entries) > self.cache:
                    self._entries.popitem(last=False)
            return entry

    def cached(self, name: str) -> Entry | None:
        """The home's entry if the cache holds it (now the most recently used), else None."""
        entry = self._entries.get(name)
        if entry is not None:
            with contextlib.suppress(KeyError):  # evicted by a load in another thread meanwhile
                self._entries.move_to_end(name)
        return entry

    def _load(self, name: str) -> Entry:
        try:
            with self.engine.connect() as conn:
                row = conn.execute(
                    select(HomeRow.name, HomeRow.source, HomeRow.built_at).where(HomeRow.name == name)
                ).first()
        except (SQLAlchemyError, DBAPIError) as e:
            raise StoreError(db_message(self.url, e)) from None
        if row is None or row.built_at is None or row.name != name:
            raise UnknownHomeError(self.unknown(name))
        if row.source is None:
            raise FleetError(
                f"home {name!r} was built without its home file; learn it with homecog fleet train"
            )
        home = load_home_text(row.source, f"{name} (stored)")
        store = Store.open(self.url, home, engine=self.engine, replace=True)
        version = store.home_version()  # before the tree: a write in between is seen next time
        runtime = assemble(Wiring(home, build=False), store=store).runtime  # context by hand
        app = create_app(runtime, self.settings, fleet=True)
        return Entry(name=name, store=store, runtime=runtime, app=app, version=version)

    def versions(self, names: list[str]) -> dict[str, tuple[int, int]]:
        """The homes' ``(version, build)`` in the database now (a home it lacks is left out): one
        query on the primary key, on a connection kept for it."""
        query = select(HomeRow.name, HomeRow.version, HomeRow.build).where(HomeRow.name.in_(names))
        if self.engine.dialect.name == "sqlite":
            try:
                with self.engine.connect() as conn:
                    rows = conn.execute(query).all()
            except (SQLAlchemyError, DBAPIError) as e:
                raise StoreError(db_message(self.url, e)) from None
        else:
            for attempt in (0, 1):  # a connection the server dropped: once more on a new one
                try:
                    if self._conn is None:
                        self._conn = self.engine.connect().execution_options(isolation_level="AUTOCOMMIT")
                    rows = self._conn.execute(query).all()
                    break
                except (SQLAlchemyError, DBAPIError) as e:
                    if self._conn is not None:
                        self._conn.invalidate()
                        self._conn = None
                    if attempt:
                        raise StoreError(db_message(self.url, e)) from None
        # keyed by the names as stored: another spelling the database matched is no home
        return {name: (version, build) for name, version, build in rows}

    def refresh(self, entry: Entry, version: tuple[int, int]) -> None:
        """Bring a cached home up to the database (the users' layers another server corrected,
        or the whole tree after another build)."""
        runtime = entry.runtime
        tree = core.refresh(entry.store, runtime.tree, runtime.lock)  # the lock only off the database
        with runtime.lock:
            runtime.tree = tree
            entry.version = version

    def forget(self, name: str) -> None:
        self._entries.pop(name, None)


class Versions:
    """The homes' versions for the requests, read in batches: every request waits for a read
    that started after it arrived (so it sees every write committed before it), and the
    requests that arrive while one read is under way share the next. Under load that is one
    round trip to the database for many requests, not one each."""

    def __init__(self, fleet: Fleet) -> None:
        self.fleet = fleet
        self._pending: dict[str, list[asyncio.Future[tuple[int, int] | None]]] = {}
        self._reading = False

    async def of(self, name: str) -> tuple[int, int] | None:
        future: asyncio.Future[tuple[int, int] | None] = asyncio.get_running_loop().create_future()
        self._pending.setdefault(name, []).append(future)
        if not self._reading:
            self._reading = True
            asyncio.get_running_loop().create_task(self._read())
        return await future

    async def _read(self) -> None:
        try:
            while self._pending:
                batch, self._pending = self._pending, {}
                try:
                    found = await asyncio.to_thread(self.fleet.versions, list(batch))
                except Exception as e:  # StoreError, or anything: every waiting request gets it
                    for futures in batch.values():
                        for f in futures:
                            if not f.done():
                                f.set_exception(e)
                    continue
                for name, futures in batch.items():
                    for f in futures:
                        if not f.done():
                            f.set_result(found.get(name))
        finally:
            self._reading = False


class FleetApp:
    """The ASGI application of :class:`Fleet`, routed by Starlette: the fleet's schema, the list
    of homes, and under ``PREFIX`` each home's own app (its schema, and every other path with
    its prefix taken off)."""

    def __init__(self, fleet: Fleet) -> None:
        self.fleet = fleet
        self.versions = Versions(fleet)
        self.token = fleet.settings.token
        self.schema = fleet_schema(token=self.token is not None)
        routes = [
            Route(FLEET_SCHEMA, self._fleet_schema, methods=READ),  # as homecog up's: no token
            Route(PREFIX, self._homes, methods=READ),
            Mount(PREFIX, app=self._home),
        ]
        handlers = {404: self._not_found, 405: self._not_allowed}
        self.app = Starlette(routes=routes, exception_handlers=handlers, lifespan=_lifespan)  # type: ignore[arg-type]
        self.app.router.redirect_slashes = False  # a path is answered as asked, never redirected

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        await self.app(scope, receive, send)

    def _refusal(self, request: Request, name: str | None = None, *, token: bool = True) -> Response | None:
        """401 for an ``/api`` path without the token (``token``: the path needs it), then 404
        for a ``name`` no home can take (one spelling per home, never a NUL byte for the
        database); None when neither."""
        if token and request.url.path.startswith("/api") and not self._authorized(request):
            return _json(401, {"detail": MISSING}, {"www-authenticate": "Bearer"})
        problem = None if name is None else home_name_problem(name)
        return None if problem is None else _json(404, {"detail": problem})

    def _authorized(self, request: Request) -> bool:
        return authorized(request.scope["headers"], self.token, request.method)

    async def _fleet_schema(self, request: Request) -> Response:
        return _json(200, self.schema)

    async def _homes(self, request: Request) -> Response:
        refusal = self._refusal(request)
        if refusal is not None:
            return refusal
        try:
            return _json(200, {"homes": await asyncio.to_thread(self.fleet.names)})
        except HomecogError as e:
            return _failure(e)

    async def _home(self, scope: Scope, receive: Receive, send: Send) -> None:
        """``PREFIX/{name}/{rest}``: the home's schema, or its app answering ``/api/{rest}``."""
        request = Request(scope)
        name, _, rest = get_route_path(scope)[1:].partition("/")  # the path is decoded already
        schema = rest == HOME_SCHEMA
        answer = self._refusal(request, name, token=not schema)
        if answer is None and schema and request.method not in READ:
            answer = _not_allowed(request.method)
        if answer is None:
            try:
                entry = await self._fresh(name)
            except HomecogError as e:
                answer = await self._unknown(e, name, request)
        if answer is not None:
            return await answer(scope, receive, send)
        if schema:
            if entry.schema is None:
                entry.schema = prefixed(api(entry.app).openapi(), f"{PREFIX}/{name}")
            return await _json(200, entry.schema)(scope, receive, send)
        inner = "/api/" + rest
        routed = {key: value for key, value in scope.items() if key not in ROUTING}
        routed |= {"path": inner, "raw_path": inner.encode(), "root_path": scope.get("app_root_path", "")}
        return await entry.app(routed, receive, send)

    async def _unknown(self, error: HomecogError, name: str, request: Request) -> Response:
        """The answer to a home that cannot be served: an unknown one names the homes there are,
        only to who has the token."""
        if not isinstance(error, UnknownHomeError):
            return _failure(error)
        detail = str(error)
        if self._authorized(request):
            with contextlib.suppress(HomecogError):
                detail = await asyncio.to_thread(self.fleet.unknown, name)
        return _json(404, {"detail": detail})

    async def _not_found(self, request: Request, exc: Exception) -> Response:
        refusal = self._refusal(request)
        detail = f"not found: the API is {PREFIX} and {PREFIX}/{{home}}/... ({FLEET_SCHEMA})"
        return refusal or _json(404, {"detail": detail})

    async def _not_allowed(self, request: Request, exc: Exception) -> Response:
        refusal = self._refusal(request, token=request.scope["route"].path != FLEET_SCHEMA)
        return refusal or _not_allowed(request.method)

    async def _fresh(self, name: str) -> Entry:
        """The home's entry, loaded if need be, and up to the database's version. Its version
        first: a name the database lacks (or holds under another spelling) costs one batched
        lookup, never a load."""
        fleet = self.fleet
        version = await self.versions.of(name)
        if version is None:
            fleet.forget(name)
            raise UnknownHomeError(f"unknown home {shown(name)}")
        entry = fleet.cached(name)
        if entry is None or entry.version is None or version[1] != entry.version[1]:
            # not loaded yet, or built again (perhaps from another home file): the home, its
            # models and its tree are read anew, after the version read
            fleet.forget(name)
            return await asyncio.to_thread(fleet.entry, name)
        if version != entry.version:
            await asyncio.to_thread(fleet.refresh, entry, version)
        return entry


def _json(status: int, body: object, headers: dict[str, str] | None = None) -> Response:
    return Response(json.dumps(body), status, headers, media_type="application/json")


def _failure(error: HomecogError) -> Response:
    """503 for a database that cannot be used, 409 for any other failure of a home."""
    if isinstance(error, StoreError):
        return _json(503, {"detail": f"the knowledge database cannot be used: {error}"})
    return _json(409, {"detail": str(error)})


def _not_allowed(method: str) -> Response:
    """405, with ``Allow`` as the one-home app words it (:mod:`homecog.web.errors`)."""
    allowed = ", ".join(READ)
    detail = f"{method} is not allowed here; allowed: {allowed}"
    return _json(405, {"detail": detail}, {"allow": allowed})


@contextlib.asynccontextmanager
async def _lifespan(app: Starlette) -> AsyncIterator[None]:
    yield
    PLANNER.close()
