"""The HMI's screenshot (docs/hmi.png): ``homecog up`` on a fresh data directory, the page at a
phone's width in headless chromium, one full-page PNG, and everything stopped.

A plain ``chromium --headless --screenshot`` never returns on this page: the page keeps its
event stream (``GET /api/events``) open, so the browser never sees the network go idle. Here
Playwright waits for what the page shows instead (the stream live, the robot's services in),
so the recipe ends.

    bin/screenshot                                   # docs/hmi.png: the paper home at 22:00
    bin/screenshot --home my_home.yaml --set "" --out /tmp/hmi.png --width 390

``--set`` gives features (and devices) by hand through ``PUT /api/context`` once the page is
live, so the picture shows a chosen moment; the robot then acts on what it proposes, and the
page shows what it did. It needs chromium (``/usr/bin/chromium``, Debian's package) and
Playwright (installed with homecog's test tools).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EVENING = "time=22:00,temperature=19,illumination=200,location=table,posture=sit,behavior=read"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_up(base: str, proc: subprocess.Popen[bytes], log: Path, seconds: float = 300) -> None:
    """Until ``homecog up`` answers (it trains and builds first on a fresh data directory)."""
    deadline = time.monotonic() + seconds
    while True:
        try:
            urllib.request.urlopen(f"{base}/openapi.json", timeout=2).close()
            return
        except (urllib.error.URLError, OSError):
            if proc.poll() is not None:
                sys.exit(f"screenshot: homecog up exited:\n{log.read_text()}")
            if time.monotonic() > deadline:
                sys.exit(f"screenshot: homecog up did not answer within {seconds:g} s")
            time.sleep(0.2)


def set_context(base: str, text: str) -> None:
    """``name=value,...`` sent by hand (``PUT /api/context``); numbers as numbers."""
    values: dict[str, object] = {}
    for pair in filter(None, (p.strip() for p in text.split(","))):
        name, _, value = pair.partition("=")
        try:
            values[name.strip()] = float(value) if ":" not in value else value.strip()
        except ValueError:
            values[name.strip()] = value.strip()
    if not values:
        return
    body = json.dumps({"values": values}).encode()
    request = urllib.request.Request(
        f"{base}/api/context", data=body, method="PUT", headers={"Content-Type": "application/json"}
    )
    try:
        urllib.request.urlopen(request, timeout=10).close()
    except urllib.error.HTTPError as e:
        sys.exit(f"screenshot: --set: {json.load(e)['detail']}")


def shoot(base: str, out: Path, *, width: int, context: str, settle: float, chromium: str) -> None:
    from playwright.sync_api import expect, sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, headless=True, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": width, "height": 900})
        page.goto(base)
        expect(page.locator("#status")).to_have_text("live", timeout=30_000)
        set_context(base, context)
        page.wait_for_timeout(settle * 1000)  # the robot acts; the page follows its events
        expect(page.locator("#services li").first).to_be_visible()
        out.parent.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(out), full_page=True)
        browser.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--home", default="paper", help="a built-in home or a home file (default paper)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "hmi.png")
    parser.add_argument("--width", type=int, default=390, help="the viewport's width in px (a phone's)")
    parser.add_argument("--set", default=EVENING, help="name=value,... set by hand once the page is live")
    parser.add_argument("--settle", type=float, default=4.0, help="seconds to let the robot act first")
    args = parser.parse_args()
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        sys.exit("screenshot: no chromium on this machine (Debian's package chromium)")
    with tempfile.TemporaryDirectory(prefix="homecog-screenshot-") as data:
        port, log = free_port(), Path(data) / "up.log"
        command = [sys.executable, "-m", "homecog.cli.main", "up", "--home", args.home, "--port", str(port)]
        with log.open("wb") as out:
            proc = subprocess.Popen(command, env={**os.environ, "HOMECOG_DATA": data}, stdout=out, stderr=out)
        base = f"http://127.0.0.1:{port}"
        try:
            wait_up(base, proc, log)
            shoot(base, args.out, width=args.width, context=args.set, settle=args.settle, chromium=chromium)
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
    print(f"screenshot: {args.out}")


if __name__ == "__main__":
    main()
