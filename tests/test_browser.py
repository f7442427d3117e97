"""The HMI in a real browser: Debian's chromium, headless, driven by Playwright."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
from webserver import LAYOUT, get, send, serve

from homecog.context.manual import ManualSource
from homecog.home import load_home_text
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime
from homecog.web.main import create_app
from homecog.web.settings import Settings

STUDIO = Path(__file__).parent / "homes" / "studio.yaml"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
# the studio's services under names as long as a home of real size gives them
LONG_NAMES = {
    "RaiseBlind": "RaiseTheLivingRoomBlindForDaylight",
    "LowerBlind": "LowerTheLivingRoomBlind",
    "LampOn": "SwitchTheDeskLampOnForReading",
    "LampOff": "SwitchTheDeskLampOff",
    "RadioOn": "TurnOnTheKitchenRadio_Station4",
    "BringTea": "BringACupOfGreenTeaToTheCouch",
}


def studio_runtime(directory: Path, text: str | None = None) -> Runtime:
    """The studio home with a floor plan (or the home ``text``), its knowledge built, set by
    hand: work at 10:00, dim."""
    if CHROMIUM is None:
        pytest.skip("no chromium on this machine (Debian package chromium; .ci/run installs it)")
    pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    home = load_home_text(text or STUDIO.read_text() + LAYOUT, "studio.yaml")
    store = Store.open(f"sqlite:///{directory / 'knowledge.sqlite'}", home)
    tree = build(home, store).tree
    runtime = Runtime(home=home, store=store, tree=tree, source=ManualSource(home))
    runtime.set_context({"time": "10:00", "light": 50, "activity": "work"})
    return runtime


@pytest.fixture(scope="module")
def runtime(tmp_path_factory):
    runtime = studio_runtime(tmp_path_factory.mktemp("hmi"))
    yield runtime
    runtime.store.close()


@pytest.fixture(scope="module")
def server(runtime):
    with serve(create_app(runtime)) as url:
        yield url, runtime


@pytest.fixture
def own_server(tmp_path):
    """A runtime and server of the test's own: the robot acts and is undone there, which would
    change what the module's runtime proposes to the other tests."""
    runtime = studio_runtime(tmp_path)
    try:
        with serve(create_app(runtime)) as url:
            yield url, runtime
    finally:
        runtime.store.close()


def test_the_page_shows_live_context_and_takes_a_correction(server, tmp_path):
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

        # the user answers each suggestion, and asks for one more: the robot learns at once
        expect(page.locator("#user")).to_have_value("default")  # the home's default user
        done = int(page.evaluate("document.body.dataset.cognitions"))
        page.fill("#user", "kim")
        page.locator("#user").press("Enter")  # a native change event: blurring later fires none
        # (not wait_for_function: the page's policy refuses a script made from a string)
        expect(page.locator("body")).not_to_have_attribute("data-cognitions", str(done))
        assert page.locator("#choices input:checked").count() == 0  # nothing ticked for the user
        for name in ("RaiseBlind", "BringTea"):
            page.locator(f'#services li[data-service="{name}"] button.no').click()
            expect(page.locator(f'#services li[data-service="{name}"]')).to_have_count(0)
        page.locator('#choices input[value="RadioOn"]').check()
        page.click("#correction button")
        expect(page.locator("#corrected")).to_contain_text("wanted here too: Radio on")
        expect(page.locator('#services li[data-service="RadioOn"]')).to_have_count(1)
        after = services.evaluate_all("els => els.map(e => e.dataset.service)")
        assert set(after) == {"LampOn", "RadioOn"}
        expect(page.locator("#agreement")).to_contain_text("kim told the robot 3 times")
        kims = get(f"{url}/api/history?user=kim")["corrections"]
        assert [c["concerns"] for c in kims] == [["RaiseBlind"], ["BringTea"], ["RadioOn"]]  # one each

        # the plan of the services, when asked for, drawn on the floor plan: the robot walks to
        # the desk lamp
        page.click("#plan-button")
        expect(page.locator("#plan > li")).to_have_count(2, timeout=60_000)  # the planner starts
        expect(page.locator("#trajectory")).to_be_visible()
        expect(page.locator("#trajectory rect.room")).to_have_count(2)  # the studio and the bath
        expect(page.locator("#route")).to_contain_text("m driven")
        # the plan of the services now (LampOn, RadioOn), not one drawn for those before it
        page.wait_for_function(
            """() => {
                const p = document.querySelector('#trajectory #path');
                const last = p && p.getAttribute('points').trim().split(/\\s+/).pop().split(',');
                return last && Math.abs(last[0] - 2) < 0.05 && Math.abs(last[1] - 2) < 0.05;
            }"""
        )
        path = page.locator("#trajectory #path").get_attribute("points").split()
        (x0, y0), (x1, y1) = (map(float, path[0].split(",")), map(float, path[-1].split(",")))
        assert (x0, y0) == (1, 3) and abs(x1 - 2) < 0.05 and abs(y1 - 2) < 0.05  # y drawn downwards

        # the robot raises the blind: what it did, when and why, comes live, with its undo
        assert runtime.act(runtime.context(), ["RaiseBlind"]) is not None
        acted = page.locator("#actions li").first
        expect(acted.locator(".services")).to_have_text("Raise blind")
        expect(acted.locator('[data-device="blind"]')).to_contain_text("blind → on")
        expect(acted.locator("button.undo")).to_be_visible()
        expect(page.locator('#context td[data-name="blind"]')).to_have_text("on")
        shot = tmp_path / "hmi.png"  # never a tracked file: bin/screenshot makes docs/hmi.png
        page.screenshot(path=str(shot), full_page=True)
        browser.close()
    runtime.set_context({"blind": "off"})  # as it was for the other tests (set by hand: not learned)
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 10_000


def test_off_loopback_the_page_asks_for_the_token_once_and_no_script_can_read_it(runtime):
    """With a token every /api request needs it: the page asks once and hands it to the server,
    which keeps it in an HttpOnly cookie; the event stream opens with it, a reload does not ask
    again, and no script of the page can find the token (not in storage, cookies or the page)."""
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
        expect(page.locator("#status")).to_have_text("live")  # the stream opened with the cookie
        expect(page.locator("#services li").first).to_have_attribute("data-service", "RaiseBlind")
        assert len(asked) == 1 and "token" in asked[0]
        found = page.evaluate(
            """() => JSON.stringify([document.cookie, document.documentElement.outerHTML,
                Object.entries(localStorage), Object.entries(sessionStorage), location.href])"""
        )
        assert token not in found  # what a script smuggled into the page could read
        (cookie,) = page.context.cookies()
        assert (cookie["name"], cookie["value"], cookie["httpOnly"], cookie["sameSite"], cookie["path"]) == (
            "homecog_token",
            token,
            True,
            "Strict",
            "/api",
        )
        runtime.set_context({"activity": "relax"})  # an event through the stream
        expect(page.locator('#context td[data-name="activity"]')).to_have_text("relax")
        runtime.set_context({"activity": "work"})
        page.reload()  # kept: not asked again
        expect(page.locator("#status")).to_have_text("live")
        expect(page.locator("#home-name")).to_have_text("studio")
        assert len(asked) == 1

        # a page that kept the token where scripts read it (an earlier homecog) moves it out
        fresh = browser.new_page()
        fresh.goto(url + "/openapi.json")  # the origin, without the page's script
        fresh.evaluate(f"localStorage.setItem('homecog-token', '{token}')")
        fresh.on("dialog", answer)
        fresh.goto(url)
        expect(fresh.locator("#status")).to_have_text("live")
        assert fresh.evaluate("localStorage.getItem('homecog-token')") is None and len(asked) == 1
        browser.close()


def test_the_page_shows_what_the_robot_did_and_undoes_it(own_server):
    """The robot's action in the panel (service, device, why) with an Undo: the blind switched
    back, the undo learned as a correction of kind undo for the page's user, and no second undo;
    a person's switch back within the undo window shows as undone by hand, live."""
    from playwright.sync_api import expect, sync_playwright

    from homecog.knowledge.history import correction_history

    url, runtime = own_server
    assert runtime.act(runtime.context(), ["RaiseBlind"]) is not None
    (action,) = runtime.journal.recent()
    assert action.services == ["RaiseBlind"] and action.switches == [("blind", True)]
    assert runtime.context()["blind"] == "on"
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 390, "height": 1200})  # a phone's width
        page.goto(url)
        expect(page.locator("#status")).to_have_text("live")
        row = page.locator(f'#actions li[data-action="{action.id}"]')
        expect(row.locator(".services")).to_have_text("Raise blind")
        expect(row.locator('[data-device="blind"]')).to_have_text("blind → on")
        expect(row.locator("time")).to_contain_text("10:00")
        expect(row.locator(".reasons")).to_contain_text("because Raise blind:")
        expect(page.locator("#household")).to_contain_text("People switched 0 devices by hand")
        assert page.locator("#no-actions").is_hidden()

        done = int(page.evaluate("document.body.dataset.cognitions"))
        page.fill("#user", "kim")
        page.locator("#user").press("Enter")
        # (not wait_for_function: the page's policy refuses a script made from a string)
        expect(page.locator("body")).not_to_have_attribute("data-cognitions", str(done))
        row.locator("button.undo").click()
        expect(row).to_have_class("undone")
        expect(row.locator('[data-device="blind"] .badge')).to_have_text("undone here")
        expect(row.locator("button")).to_have_count(0)  # no second undo from the page
        expect(page.locator("#undo-result")).to_contain_text("Undone for kim: blind off")
        expect(page.locator('#context td[data-name="blind"]')).to_have_text("off")
        assert runtime.context()["blind"] == "off"
        expect(page.locator('#history li[data-kind="undo"]')).to_have_count(1)
        expect(page.locator('#history li[data-kind="undo"]')).to_contain_text("Raise blind not wanted")
        expect(page.locator("#household")).to_contain_text("learned from 0 switches by hand, 1 undo and")
        (undo,) = [c for c in correction_history(runtime.store, user="kim").corrections if c.kind == "undo"]
        assert undo.concerns == ["RaiseBlind"] and undo.want == []
        kinds = [c["kind"] for c in get(f"{url}/api/history?user=kim")["corrections"]]
        assert kinds == ["undo"]
        assert send(f"{url}/api/actions/{action.id}/undo", {"user": "kim"})[0] == 409
        page.reload()  # the server says it is undone: still no Undo
        expect(row.locator('[data-device="blind"] .badge')).to_have_text("undone here")
        expect(row.locator("button")).to_have_count(0)

        # live: the robot turns the radio on, and a person switches it back off by hand
        assert runtime.act(runtime.context(), ["RadioOn"]) is not None
        radio = page.locator("#actions li").first
        expect(radio.locator(".services")).to_have_text("Radio on")
        expect(radio.locator("button.undo")).to_be_visible()
        runtime.switch("radio", False)  # within the undo window: an undo by the person
        expect(radio.locator('[data-device="radio"] .badge')).to_have_text("undone by hand")
        expect(radio.locator("button")).to_have_count(0)
        expect(page.locator("#household")).to_contain_text("People switched 1 device by hand")
        expect(page.locator("#household")).to_contain_text("learned from 0 switches by hand, 2 undos and")
        expect(page.locator("#actions li")).to_have_count(2)
        browser.close()


def test_the_robot_did_panel_shows_markup_as_text(own_server):
    """Names from home files and user names can be hostile: shown as text, at load and live."""
    from playwright.sync_api import expect, sync_playwright

    url, runtime = own_server
    hostile = "<img src=x onerror=window.pwned=1>"
    why = [{"service": hostile, "conditions": {"<i>f</i>": "<svg onload=window.pwned=3>"}}]
    first = runtime.journal.add(
        at=0.0,
        services=[hostile],
        switches=[("<svg onload=window.pwned=2>", True)],
        context={},
        user="<b>x</b>",
        why=why,
    )
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 390, "height": 1200})
        page.goto(url)
        expect(page.locator("#status")).to_have_text("live")
        row = page.locator(f'#actions li[data-action="{first.id}"]')
        expect(row.locator(".services")).to_have_text(hostile)
        expect(row.locator("time")).to_contain_text("for <b>x</b>")
        expect(row.locator(".switches")).to_contain_text("<svg onload=window.pwned=2> → on")
        expect(row.locator(".reasons")).to_contain_text("<i>f</i>: <svg onload=window.pwned=3>")

        second = runtime.journal.add(
            at=0.0, services=["<script>window.pwned=4</script>"], switches=[], context={}, user="<u>y</u>"
        )
        runtime.publish("action", second.as_dict())  # live, as when the robot acts
        live = page.locator(f'#actions li[data-action="{second.id}"]')
        expect(live.locator(".services")).to_have_text("<script>window.pwned=4</script>")
        expect(live.locator("time")).to_contain_text("for <u>y</u>")
        assert page.locator("#actions img, #actions svg, #actions b:not(.services), #actions u").count() == 0
        assert page.evaluate("window.pwned") is None
        browser.close()


# Each service's label in the list: the box of its name (a Range over what follows the checkbox,
# so a name that overflows its cell shows where it is drawn) and its checkbox.
LABEL_BOXES = """() => [...document.querySelectorAll("#choices label")].map((label) => {
  const box = label.querySelector("input"), range = document.createRange();
  range.setStartAfter(box);
  range.setEnd(label, label.childNodes.length);
  const rect = (r) => [r.left, r.top, r.right, r.bottom];
  return { name: box.value, text: rect(range.getBoundingClientRect()), box: rect(box.getBoundingClientRect()),
           panel: rect(document.querySelector("#correction").getBoundingClientRect()) };
})"""


def overlap(a: list[float], b: list[float], slack: float = 0.5) -> bool:
    """Whether two boxes [left, top, right, bottom] share more than ``slack`` pixels each way.

    >>> overlap([0, 0, 10, 10], [9, 9, 20, 20]), overlap([0, 0, 10, 10], [10, 0, 20, 10])
    (True, False)
    """
    return min(a[2], b[2]) - max(a[0], b[0]) > slack and min(a[3], b[3]) - max(a[1], b[1]) > slack


def test_long_service_names_stay_in_their_place_on_a_phone(tmp_path):
    """At a phone's 390 px, a service whose name is longer than its column wraps: no name's box
    overlaps another name or any checkbox, and every name stays inside its panel."""
    from playwright.sync_api import expect, sync_playwright

    text = STUDIO.read_text() + LAYOUT
    for short, long in LONG_NAMES.items():
        text = re.sub(rf"\b{short}\b", long, text)
    runtime = studio_runtime(tmp_path, text)
    try:
        with serve(create_app(runtime)) as url, sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=["--no-sandbox"])
            page = browser.new_page(viewport={"width": 390, "height": 900})
            page.goto(url)
            expect(page.locator("#choices label")).to_have_count(8)
            labels = page.evaluate(LABEL_BOXES)
            browser.close()
    finally:
        runtime.store.close()
    assert {entry["name"] for entry in labels} >= set(LONG_NAMES.values())
    for i, a in enumerate(labels):
        assert a["text"][2] - a["text"][0] > 20, f"{a['name']}: no text drawn"
        left, _, right, _ = a["panel"]
        assert left <= a["text"][0] and a["text"][2] <= right + 0.5, f"{a['name']} leaves its panel"
        assert not overlap(a["text"], a["box"]), f"{a['name']} covers its own checkbox"
        for j, b in enumerate(labels):
            if i != j:
                assert not overlap(a["text"], b["text"]), f"{a['name']} overlaps {b['name']}"
                assert not overlap(a["text"], b["box"]), f"{a['name']} covers the checkbox of {b['name']}"
