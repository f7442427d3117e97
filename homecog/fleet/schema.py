"""The OpenAPI documents of ``homecog serve``.

- ``GET /api/openapi.json``: the fleet's own, of ``GET /api/homes`` (the list of homes). It is
  not under ``/api/homes/``, where any name could be a home's (a home may be called
  ``openapi.json``).
- ``GET /api/homes/{home}/openapi.json``: each home's, the one-home schema of ``homecog up``
  (:func:`homecog.web.main.create_app` with ``fleet``) with its paths where the fleet serves
  them.

As with ``homecog up``'s ``/openapi.json``, neither needs the token: a schema describes the
API, not what the homes learned.
"""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI, Security
from pydantic import BaseModel, ConfigDict, Field

from homecog.web import errors
from homecog.web.deps import bearer

PREFIX = "/api/homes"
FLEET_SCHEMA = "/api/openapi.json"
HOME_SCHEMA = "openapi.json"  # under PREFIX/{home}/

DESCRIPTION = f"""Every home of one database. `GET {PREFIX}` lists them; each home answers the
API of `homecog up` under `{PREFIX}/{{home}}/` (`GET home`, `POST cognize`, `POST corrections`,
`POST plan`, `GET history`), described by its own schema at
`{PREFIX}/{{home}}/{HOME_SCHEMA}` (made for that home: its features, devices and services).
Every error is `{{"detail": "..."}}`."""


class HomesOut(BaseModel):
    """The homes of the database that have a tree (learned), by name."""

    model_config = ConfigDict(extra="forbid")
    homes: list[str] = Field(
        description=f"Names; each home's API is under `{PREFIX}/{{name}}/`, "
        f"its schema at `{PREFIX}/{{name}}/{HOME_SCHEMA}`."
    )


def fleet_schema(*, token: bool) -> dict[str, Any]:
    """The OpenAPI document of the fleet level (``GET /api/homes``): its 200, its 503 (the
    database cannot be used) and, with a ``token``, its 401, each error the one-home model."""
    app = FastAPI(
        title="homecog serve: the homes",
        summary="Service cognition for a fleet of home service robots",
        description=DESCRIPTION,
        version="0.1.0",
    )
    guard: dict[str, Any] = {}
    if token:
        guard = {"dependencies": [Security(bearer)]}

    @app.get(
        PREFIX,
        response_model=HomesOut,
        responses=errors.responses(*((401, 503) if token else (503,))),
        tags=["homes"],
        **guard,
    )
    def homes() -> HomesOut:  # pragma: no cover - documented here, answered by FleetApp
        """The homes of the database that have been learned, by name. 503 when the database
        cannot be used."""
        raise NotImplementedError

    return app.openapi()


def prefixed(schema: dict[str, Any], prefix: str) -> dict[str, Any]:
    """A home's OpenAPI schema with its paths where the fleet serves them."""
    paths = {prefix + p[len("/api") :]: v for p, v in schema["paths"].items() if p.startswith("/api")}
    return {**schema, "paths": paths}
