"""The HMI in a real browser: Debian's chromium, headless, driven by Playwright (SPEC §10)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from webserver import LAYOUT, serve

from homecog.context.manual import ManualSource
from homecog.home import load_home_text
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime
from homecog.web.main import create_app
from homecog.web.settings import Settings

STUDIO = Path(__file__).parent / "homes" / "studio.yaml"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
SCREENSHOT = Path(__file__).parent.parent / "docs" / "hmi.png"


@pytest.fixture(scope="module")
def runtime(tmp_path_factory):
    if CHROMIUM is None:
        pytest.skip("no chromium on this machine (Debian package chromium; .ci/run installs it)")
    pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    home = load_home_text(STUDIO.read_text() + LAYOUT, "studio.yaml")
    store = Store(f"sqlite:///{tmp_path_factory.mktemp('hmi') / 'knowledge.sqlite'}", home)
    tree = build(home, store).tree
    runtime = Runtime(home=home, store=store, tree=tree, source=ManualSource(home))
    runtime.set_context({"time": "10:00", "light": 50, "activity": "work"})
    yield runtime
    store.close()


@pytest.fixture(scope="module")
def server(runtime):
    with serve(create_app(runtime)) as url:
        yield url, runtime


def test_the_page_shows_live_context_and_takes_a_correction(server):
    from playwright.sync_api import expect, sync_playwright

    url, runtime = server
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 390, "height": 1200})  # a phone's width
        page.goto(url)
        expect(page.locator("#home-name")).to_have_text("studio")
        expect(page.locator('#context td[data-name="activity"]')).to_have_text("work")
        services = page.locator("#services li")
        expect(services.first).to_have_attribute("data-service", "RaiseBlind")
        before = services.evaluate_all("els => els.map(e => e.dataset.service)")
        assert set(before) == {"RaiseBlind", "LampOn", "BringTea"}
        expect(page.locator("#status")).to_have_text("live")

        # the home changes (as the simulator or a broker would): the page follows, live
        runtime.set_context({"activity": "relax"})
        expect(page.locator('#context td[data-name="activity"]')).to_have_text("relax")
        runtime.set_context({"activity": "work"})
        expect(page.locator('#context td[data-name="activity"]')).to_have_text("work")
        expect(services.first).to_have_attribute("data-service", "RaiseBlind")

        # the user says what they want from the list: the robot's services change at once
        done = int(page.evaluate("document.body.dataset.cognitions"))
        page.fill("#user", "kim")
        page.locator("#user").press("Enter")  # a native change event: blurring later fires none
        page.wait_for_function(f"+document.body.dataset.cognitions > {done}")
        for name in ("RaiseBlind", "BringTea"):
            page.locator(f'#choices input[value="{name}"]').uncheck()
        page.locator('#choices input[value="RadioOn"]').check()
        page.click("#correction button")
        expect(page.locator("#corrected")).to_contain_text("learned: +RadioOn")
        expect(page.locator('#services li[data-service="RadioOn"]')).to_have_count(1)
        after = services.evaluate_all("els => els.map(e => e.dataset.service)")
        assert set(after) == {"LampOn", "RadioOn"}
        expect(page.locator("#agreement")).to_contain_text("1 corrections by kim")

        # the plan of the services drawn on the floor plan: the robot walks to the desk lamp
        expect(page.locator("#trajectory")).to_be_visible()
        expect(page.locator("#trajectory rect.room")).to_have_count(2)  # the studio and the bath
        expect(page.locator("#route")).to_contain_text("m driven")
        path = page.locator("#trajectory #path").get_attribute("points").split()
        (x0, y0), (x1, y1) = (map(float, path[0].split(",")), map(float, path[-1].split(",")))
        assert (x0, y0) == (1, 3) and abs(x1 - 2) < 0.05 and abs(y1 - 2) < 0.05  # y drawn downwards
        SCREENSHOT.parent.mkdir(exist_ok=True)
        page.screenshot(path=str(SCREENSHOT), full_page=True)
        browser.close()
    assert SCREENSHOT.stat().st_size > 10_000


def test_off_loopback_the_page_asks_for_the_token_once_and_keeps_it(runtime):
    """With a token every /api request needs it: the page asks once, keeps it in the browser, and
    opens the event stream with it."""
    from playwright.sync_api import expect, sync_playwright

    token = "hmi-token-123"
    asked: list[str] = []
    with serve(create_app(runtime, Settings(token=token))) as url, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=["--no-sandbox"])
        page = browser.new_page()

        def answer(dialog):
            asked.append(dialog.message)
            dialog.accept(token)

        page.on("dialog", answer)
        page.goto(url)
        expect(page.locator("#home-name")).to_have_text("studio")
        expect(page.locator("#status")).to_have_text("live")  # the stream opened with the token
        expect(page.locator("#services li").first).to_have_attribute("data-service", "RaiseBlind")
        assert len(asked) == 1 and "token" in asked[0]
        assert page.evaluate("localStorage.getItem('homecog-token')") == token
        runtime.set_context({"activity": "relax"})  # an event through the stream
        expect(page.locator('#context td[data-name="activity"]')).to_have_text("relax")
        runtime.set_context({"activity": "work"})
        page.reload()  # kept: not asked again
        expect(page.locator("#status")).to_have_text("live")
        expect(page.locator("#home-name")).to_have_text("studio")
        assert len(asked) == 1
        browser.close()
