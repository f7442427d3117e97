"""The web server's settings, one object: given by ``homecog up`` or read from ``HOMECOG_*``
environment variables (``HOMECOG_TOKEN`` keeps the token off the command line, where any user
of the machine could read it in the process list).

>>> Settings(token="s3cret-token", live=60).live
60.0
>>> from pydantic import ValidationError
>>> try:
...     Settings(token="short")
... except ValidationError as e:
...     print(e.errors()[0]["msg"])
String should have at least 8 characters
>>> Settings.of(token="sécret-token")
Traceback (most recent call last):
...
homecog.errors.SettingsError: token (or $HOMECOG_TOKEN): printable ASCII without spaces, not 'sécret-token'
"""

from __future__ import annotations

import re

from pydantic import Field, ValidationError, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from homecog.errors import SettingsError
from homecog.names import shown

MAX_BODY = 64 * 1024
TOKEN_PATTERN = re.compile(r"[!-~]+")  # printable ASCII, no space: as a header carries it, byte for byte


class Settings(BaseSettings):
    """How the server answers; every field can also come from ``HOMECOG_<FIELD>``."""

    model_config = SettingsConfigDict(env_prefix="HOMECOG_", extra="ignore", frozen=True)

    token: str | None = Field(
        None,
        min_length=8,
        description="When set, every /api endpoint needs it (Authorization: Bearer <token>); "
        "`homecog up` sets one on any address other than 127.0.0.1.",
    )
    live: float = Field(
        0.0,
        ge=0,
        le=100_000,
        description="Simulated seconds the home lives per real second, the robot acting on what "
        "it proposes; 0: the server's clock does not move the home.",
    )
    max_body: int = Field(MAX_BODY, ge=1024, description="Request bodies over this many bytes get 413.")
    request_timeout: float = Field(
        5.0,
        gt=0,
        le=600,
        description="Seconds a client has to send a whole request (its headers and body); a slower "
        "or half-sent one is answered 408 and its connection closed.",
    )
    history_limit: int = Field(
        500, ge=1, le=1_000, description="Corrections GET /api/history gives when not asked for a number."
    )

    @field_validator("token")
    @classmethod
    def _ascii(cls, token: str | None) -> str | None:
        """A token is compared as the bytes of a header: only printable ASCII is the same text
        to every client, proxy and check."""
        if token is not None and not TOKEN_PATTERN.fullmatch(token):
            raise ValueError(f"printable ASCII without spaces, not {shown(token)}")
        return token

    @classmethod
    def of(cls, **given: object) -> Settings:
        """Settings from options (``None``: not given, so from the environment or the default);
        :class:`SettingsError` naming the first bad one."""
        try:
            return cls(**{k: v for k, v in given.items() if v is not None})
        except ValidationError as e:
            first = e.errors()[0]
            name = ".".join(str(p) for p in first["loc"])
            msg = first["msg"].removeprefix("Value error, ")
            raise SettingsError(f"{name} (or $HOMECOG_{name.upper()}): {msg[:1].lower()}{msg[1:]}") from None
