"""``GET /``: the HMI, one page. It holds no data of the home, so it needs no token: it asks
for the token when the API answers 401 and hands it to ``POST /api/session``, which keeps it in
an HttpOnly cookie.

The page comes with a content security policy that lets only its own script and style run
(by their hashes) and lets it talk only to its own server: markup that data might ever smuggle
into the page could neither run a script nor send anything elsewhere.
"""

from __future__ import annotations

import base64
import hashlib
import re
from pathlib import Path

from fastapi import APIRouter
from fastapi.responses import HTMLResponse

router = APIRouter()
STATIC = Path(__file__).parent.parent / "static"


def assemble(folder: Path = STATIC) -> str:
    """The page: ``index.html`` with its scripts, named in order by its ``<!-- scripts: … -->``
    line, put inline in one ``<script>`` (so that the policy lets it run by its hash, and the
    page loads in one request).

    >>> "<script>" in assemble() and "<!-- scripts:" not in assemble()
    True
    """
    page = (folder / "index.html").read_text(encoding="utf-8")
    line = re.search(r"<!-- scripts: ([\w. ]+) -->", page)
    if line is None:
        raise ValueError("index.html names no scripts")
    code = "\n".join((folder / name).read_text(encoding="utf-8") for name in line.group(1).split())
    return page.replace(line.group(0), f"<script>\n{code}</script>")


PAGE = assemble()


def _hashes(tag: str) -> str:
    """The CSP sources of the page's inline ``<script>`` or ``<style>`` elements, by hash."""
    blocks = re.findall(rf"<{tag}>(.*?)</{tag}>", PAGE, flags=re.DOTALL)
    return " ".join(
        f"'sha256-{base64.b64encode(hashlib.sha256(b.encode()).digest()).decode()}'" for b in blocks
    )


POLICY = (
    f"default-src 'none'; script-src {_hashes('script')}; style-src {_hashes('style')}; "
    "connect-src 'self'; img-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'"
)
HEADERS = {
    "Content-Security-Policy": POLICY,
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
}


@router.get("/", response_class=HTMLResponse, include_in_schema=False)
async def index() -> HTMLResponse:
    """The HMI: the robot's suggestions each with a yes or no, the home now room by room,
    the plan when asked for, what the robot did, the household's switches per day, the
    corrections; one page that works on a phone."""
    return HTMLResponse(PAGE, headers=HEADERS)
