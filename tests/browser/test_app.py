"""The web app in Debian's Chromium, driven by Playwright (run by tests/cli/serve.rs against
a running `firecast serve`: FIRECAST_URL is its address, FIRECAST_SCREENSHOTS a folder for
one screenshot per page). The whole flow a duty officer and a researcher follow."""

import os
import re
import tempfile

import pytest
from playwright.sync_api import expect, sync_playwright

URL = os.environ["FIRECAST_URL"].rstrip("/")
SHOTS = os.environ.get("FIRECAST_SCREENSHOTS", tempfile.mkdtemp())
CHROMIUM = os.environ.get("FIRECAST_CHROMIUM", "/usr/bin/chromium")
# The flags the machine's Chromium needs offline and as root (no sandbox, no GPU, no
# background connections).
ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


@pytest.fixture(scope="module")
def browser():
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        yield b
        b.close()


@pytest.fixture()
def page(browser):
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    pg = context.new_page()
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    yield pg
    context.close()
    assert not errors, f"JavaScript errors: {errors}"


def shot(page, name):
    page.screenshot(path=os.path.join(SHOTS, f"{name}.png"), full_page=True)


def acres(panel):
    value = panel.locator(".acres").get_attribute("data-value")
    return float(value) if value else 0.0


def test_forecast_fire_and_report(page):
    page.goto(URL + "/#/")
    canvas = page.locator("#map")
    expect(canvas).to_be_visible()
    page.wait_for_timeout(1500)  # the base map image
    box = canvas.bounding_box()
    # The base map is the data's box with a tenth more on each side: its centre is inside.
    page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    expect(page.locator("#probability")).to_contain_text("%", timeout=60_000)
    model = page.request.get(URL + "/api/coverage").json()["forecaster"]["model"]
    expect(page.locator("#forecast")).to_contain_text(model)
    page.wait_for_timeout(1000)  # the probability map
    shot(page, "forecast")

    # A place outside the data is answered in the page.
    page.mouse.click(box["x"] + 3, box["y"] + 3)
    expect(page.locator(".error").first).to_contain_text("outside the data", timeout=30_000)
    page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    expect(page.locator("#probability")).to_contain_text("%", timeout=60_000)

    page.locator("#start-fire").click()
    expect(page).to_have_url(re.compile(r"#/fire\?"))
    left, right = page.locator("#fire-left"), page.locator("#fire-right")
    expect(left.locator(".hours")).to_be_visible(timeout=60_000)
    page.wait_for_timeout(1500)
    first = acres(left), acres(right)
    page.wait_for_timeout(2500)
    later = acres(left), acres(right)
    assert later[0] > 0 and later[1] > 0, (first, later)
    assert later[0] >= first[0] and later[1] >= first[1], (first, later)
    assert later != first, f"the burnt area does not grow: {first} -> {later}"
    page.locator("#pause").click()
    page.wait_for_timeout(500)
    paused = acres(left)
    page.wait_for_timeout(1000)
    assert acres(left) == paused, "pause stops the fire"
    page.locator("#step").click()
    page.wait_for_timeout(500)
    shot(page, "fire")

    # The shareable address replays the same fire: its end, played again at full speed.
    shared = page.url
    page.locator("#play").click()
    page.locator("#speed").select_option("0")
    ended = page.locator("#fire-left .ended")
    expect(ended).to_be_visible(timeout=300_000)
    first_end = ended.inner_text()
    page.locator("#report-btn").click()
    status = page.locator("#report-status")
    for _ in range(600):
        if "PDF" in page.locator("#report-links").inner_text():
            break
        assert "failed" not in status.inner_text().lower(), status.inner_text()
        page.wait_for_timeout(1000)
    expect(page.locator("#report-links")).to_contain_text("PDF")
    page.wait_for_timeout(1000)
    shot(page, "report")

    page.goto("about:blank")
    page.goto(shared)
    page.locator("#speed").select_option("0")
    expect(page.locator("#fire-left .ended")).to_have_text(first_end, timeout=300_000)


def test_runs_browser(page):
    page.goto(URL + "/#/runs")
    table = page.locator("#runs-table")
    expect(table.locator("tbody tr").first).to_be_visible(timeout=30_000)
    rows = table.locator("tbody tr").count()
    assert rows >= 8
    page.locator("#runs-search").fill("rl.train")
    page.wait_for_timeout(1000)
    assert table.locator("tbody tr").count() < rows
    expect(table).to_contain_text("rl.train")
    shot(page, "runs")

    page.locator("#runs-search").fill("")
    page.wait_for_timeout(1000)
    table.locator("tbody tr a").first.click()
    expect(page.locator("#run-page")).to_be_visible(timeout=30_000)
    expect(page.locator("#run-page")).to_contain_text("Parameters")
    page.wait_for_timeout(1000)
    shot(page, "run")

    # Two runs compared through the table's selection.
    page.goto(URL + "/#/runs")
    expect(table.locator("tbody tr").first).to_be_visible(timeout=30_000)
    boxes = table.locator("tbody input[type=checkbox]")
    boxes.nth(0).check()
    boxes.nth(1).check()
    page.locator("#compare-btn").click()
    expect(page).to_have_url(re.compile(r"#/compare\?ids="))
    compare = page.locator("#compare-page")
    expect(compare).to_be_visible(timeout=30_000)
    page.wait_for_timeout(1500)
    assert page.locator("#compare-page .error").count() == 0, compare.inner_text()
    ids = page.url.split("ids=")[1].split(",")
    assert len(ids) == 2
    for run_id in ids:
        expect(compare).to_contain_text(run_id[:12])
    shot(page, "compare")
