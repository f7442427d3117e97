"""The HMI against markup in the data, in a real browser (Debian's chromium, driven by Playwright):
every text from a home file or a user reaches the page as text, and the page's policy stops a
script that markup might ever smuggle in."""

from __future__ import annotations

from pathlib import Path

import pytest
from test_browser import CHROMIUM
from webserver import LAYOUT, serve

from homecog.context.manual import ManualSource
from homecog.home import load_home_text
from homecog.knowledge.correction import Correction
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime
from homecog.web.main import create_app

STUDIO = Path(__file__).parent / "homes" / "studio.yaml"
# each, shown as markup, would run a script that marks the window
UNIT = "<img src=x onerror=window.pwned='unit'>"
ROOM = "<img src=x onerror=window.pwned='room'>"
PLACE = "<svg onload=window.pwned='place'>"
VALUE = "<i>nap</i><script>window.pwned</script>"  # a value may not hold = , or ;
USER = "<img src=x onerror=window.pwned='user'>"


def hostile_home() -> str:
    text = (STUDIO.read_text() + LAYOUT).replace("unit: lx", f'unit: "{UNIT}"')
    text = text.replace("values: [work, relax, sleep]", f'values: [work, relax, sleep, "{VALUE}"]')
    text = text.replace("bath: [4, 0, 6, 4]", f'"{ROOM}": [4, 0, 6, 4]')
    return text.replace("desk: [1, 1]", f'"{PLACE}": [1, 1]')


@pytest.fixture(scope="module")
def hostile(tmp_path_factory):
    if CHROMIUM is None:
        pytest.skip("no chromium on this machine (Debian package chromium; .ci/run installs it)")
    pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    home = load_home_text(hostile_home(), "hostile.yaml")
    assert home.feature("light").unit == UNIT and VALUE in home.feature("activity").values
    store = Store.open(f"sqlite:///{tmp_path_factory.mktemp('hostile') / 'k.sqlite'}", home)
    runtime = Runtime(home=home, store=store, tree=build(home, store).tree, source=ManualSource(home))
    runtime.set_context({"time": "10:00", "light": 50, "activity": VALUE})
    point = runtime.space.point(runtime.context())
    runtime.correct(Correction.whole(USER, point, ["RadioOn"]))  # the user's correction, in the history
    yield runtime
    store.close()


def test_markup_in_names_values_units_and_users_runs_no_script(hostile):
    from playwright.sync_api import expect, sync_playwright

    dialogs: list[str] = []
    with serve(create_app(hostile)) as url, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=["--no-sandbox"])
        page = browser.new_page()
        page.on("dialog", lambda d: (dialogs.append(d.message), d.dismiss()))
        page.goto(url)
        expect(page.locator("#status")).to_have_text("live")
        expect(page.locator('#context td[data-name="activity"]')).to_have_text(VALUE)  # as text
        texts = page.locator("#trajectory text").all_text_contents()
        assert PLACE in texts  # the floor plan names them, as text (a name too long for the plan
        assert ROOM in page.locator("#trajectory").text_content()  # as its room's tooltip)

        done = int(page.evaluate("document.body.dataset.cognitions"))
        page.fill("#user", USER)
        page.locator("#user").press("Enter")
        # (not wait_for_function: the page's policy refuses a script made from a string)
        expect(page.locator("body")).not_to_have_attribute("data-cognitions", str(done))
        expect(page.locator("#agreement")).to_have_text(
            f"{USER} told the robot 1 time; it had already agreed 0 % of them."
        )
        expect(page.locator('#services li[data-service="RadioOn"] .why')).to_contain_text(
            f"{USER}'s corrections"
        )
        page.wait_for_timeout(300)  # an image's error or an svg's load would have fired by now
        assert page.evaluate("window.pwned") is None and dialogs == []
        made = page.evaluate("document.querySelectorAll('img, i, svg svg, script').length")
        assert made == 1  # the page's own script, and no element the data spelled
        browser.close()


def test_the_page_runs_only_its_own_script(hostile):
    """Whatever markup might ever reach the page, its policy lets only the page's own script
    run (by hash) and lets it talk only to its server."""
    from playwright.sync_api import sync_playwright

    with serve(create_app(hostile)) as url, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=["--no-sandbox"])
        page = browser.new_page()
        answer = page.goto(url)
        assert answer is not None
        policy = answer.headers["content-security-policy"]
        assert "script-src 'sha256-" in policy and "default-src 'none'" in policy
        assert "connect-src 'self'" in policy and "'unsafe-inline'" not in policy
        page.wait_for_selector("body[data-cognitions]")  # the page's own script runs
        page.evaluate(f"document.body.insertAdjacentHTML('beforeend', {UNIT!r})")  # as an injection
        page.evaluate(
            "document.body.insertAdjacentHTML('beforeend', '<p id=bait onclick=window.pwned=1>x</p>')"
        )
        assert page.evaluate("document.querySelectorAll('#bait[onclick], img[onerror]').length") == 2
        page.locator("#bait").click()
        page.wait_for_timeout(300)
        assert page.evaluate("window.pwned") is None
        browser.close()
