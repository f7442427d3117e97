"""Talking to a Home Assistant instance's WebSocket API: its address, a connection
authenticated with a token, and one-off commands.

The client is ``hass-client`` (Apache-2.0, on aiohttp); docs/design.md says why. Every failure
becomes one :class:`HomeAssistantError` line: an address that is not Home Assistant's, one that
cannot be reached, a refused token, no answer in time.

>>> websocket_url("http://homeassistant.local:8123")
'ws://homeassistant.local:8123/api/websocket'
>>> websocket_url("https://example.org/ha/")
'wss://example.org/ha/api/websocket'
>>> websocket_url("mqtt://broker")
Traceback (most recent call last):
...
homecog.errors.HomeAssistantError: Home Assistant URL 'mqtt://broker': expected http(s)://host:port
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any
from urllib.parse import urlsplit, urlunsplit

from homecog.errors import HomeAssistantError

CONNECT_TIMEOUT = 10.0  # seconds for a connection, its authentication and each command
TOKEN_HELP = "a long-lived access token (Home Assistant: your profile → Security → Long-lived access tokens)"


def websocket_url(url: str) -> str:
    """The WebSocket API address of an instance given by its web address (``http(s)://``) or
    by its WebSocket address (``ws(s)://``, with or without ``/api/websocket``)."""
    try:
        parts = urlsplit(str(url).strip())
        parts.port  # noqa: B018 - raises ValueError for a bad port
    except ValueError as e:
        raise HomeAssistantError(f"Home Assistant URL {url!r}: {e}") from None
    scheme = {"http": "ws", "https": "wss", "ws": "ws", "wss": "wss"}.get(parts.scheme.lower())
    if scheme is None or not parts.hostname:
        raise HomeAssistantError(f"Home Assistant URL {url!r}: expected http(s)://host:port")
    if parts.query or parts.fragment:
        raise HomeAssistantError(f"Home Assistant URL {url!r}: unexpected query; expected http://host:port")
    path = parts.path.rstrip("/")
    if not path.endswith("/api/websocket"):
        path += "/api/websocket"
    return urlunsplit((scheme, parts.netloc, path, "", ""))


def reason(error: BaseException) -> str:
    """An exception as one line (aiohttp's can span several, or be empty)."""
    text = " ".join(str(error).split()) or type(error).__name__
    cause = error.__cause__
    if cause is not None and str(cause) and str(cause) not in text:
        text = f"{text}: {' '.join(str(cause).split())}"
    return text


async def connect(url: str, token: str, timeout: float) -> Any:
    """A connected, authenticated hass-client (raises HomeAssistantError with one line)."""
    from hass_client import HomeAssistantClient
    from hass_client.exceptions import AuthenticationFailed

    client = HomeAssistantClient(url, token)
    try:
        await asyncio.wait_for(client.connect(), timeout)
    except AuthenticationFailed as e:
        await client.disconnect()
        raise HomeAssistantError(f"Home Assistant at {url} refused the token: {reason(e)}") from None
    except TimeoutError:
        await client.disconnect()
        raise HomeAssistantError(f"Home Assistant at {url} did not answer within {timeout:g} s") from None
    except Exception as e:  # CannotConnect, and whatever aiohttp raises for a broken address
        await client.disconnect()
        raise HomeAssistantError(f"Home Assistant at {url} cannot be reached: {reason(e)}") from None
    return client


def query(url: str, token: str, commands: list[str], *, timeout: float = CONNECT_TIMEOUT) -> list[Any]:
    """Connect once, send WebSocket commands (``get_states``, ``auth/current_user``, …) and
    return their results in order; for the commands that only read."""
    ws = websocket_url(url)
    if not token:
        raise HomeAssistantError(f"no token for Home Assistant at {url}: give {TOKEN_HELP}")

    async def run() -> list[Any]:
        client = await connect(ws, token, timeout)
        listener = asyncio.create_task(client.start_listening())
        try:
            return [await asyncio.wait_for(client.send_command(c), timeout) for c in commands]
        except TimeoutError:
            raise HomeAssistantError(f"Home Assistant at {ws} did not answer within {timeout:g} s") from None
        finally:
            await client.disconnect()
            listener.cancel()
            with contextlib.suppress(BaseException):
                await listener

    return asyncio.run(run())
