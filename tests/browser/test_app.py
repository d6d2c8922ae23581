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
    ids = page.url.split("ids=")[1].split("&")[0].split(",")
    assert len(ids) == 2
    for run_id in ids:
        # Short ids (time of day and suffix) in the table, the full id in the title.
        expect(compare.locator(f'#compare-runs-table a[title="{run_id}"]')).to_have_count(1)
    labels = compare.locator("#compare-runs-table tbody a").all_inner_texts()
    assert len(set(labels)) == len(labels), f"run labels that look alike: {labels}"
    shot(page, "compare")


def run_id(page, kind):
    runs = page.request.get(URL + "/api/runs?" + f"kind={kind}&limit=1").json()["runs"]
    assert runs, f"no {kind} run"
    return runs[0]["run_id"]


def loaded(page, selector, timeout=30_000):
    """Waits until the image `selector` has loaded (naturalWidth > 0)."""
    page.wait_for_function(
        "(s) => { const i = document.querySelector(s); return !!i && i.complete && i.naturalWidth > 0; }",
        arg=selector,
        timeout=timeout,
    )


def test_table3(page):
    page.goto(URL + "/#/tables/forecast")
    table = page.locator("#table3-leak_free")
    row = table.locator('tbody tr[data-model="logistic_regression"]')
    expect(row).to_be_visible(timeout=30_000)
    # Every metric with its interval under it.
    assert row.locator("td.ci .ival").count() >= 8, row.inner_text()
    expect(page.locator("#protocol-leak_free")).to_contain_text("headline")
    expect(page.locator("#protocol-leak_free")).to_contain_text("prevalence")
    head = table.locator('th[data-sort="auroc"]')
    expect(head).to_have_attribute("aria-sort", "descending")
    head.click()
    expect(head).to_have_attribute("aria-sort", "ascending")
    loaded(page, '#protocol-leak_free figure.plot.large[data-plot^="roc_"] img')
    expect(page.locator("#table3-dataset")).to_have_text("app-ignitions")
    # A thumbnail opens large, Escape closes it.
    thumbs = page.locator("#protocol-leak_free figure.plot.thumb button")
    if thumbs.count():
        thumbs.first.click()
        expect(page.locator(".lightbox img")).to_be_visible()
        page.keyboard.press("Escape")
        expect(page.locator(".lightbox")).to_have_count(0)
    page.wait_for_timeout(500)
    shot(page, "table3")

    # The run page links its table; the table's run link goes back.
    page.locator("#table3-head a.button", has_text="Run page").click()
    expect(page.locator("#run-table-link")).to_have_text("Table III of this run", timeout=30_000)


def test_table4_and_rerun(page):
    page.goto(URL + "/#/tables/rl")
    table = page.locator("#table4-table")
    for agent in ["ppo", "rule", "none"]:
        expect(table.locator(f'tbody tr[data-agent="{agent}"]')).to_be_visible(timeout=30_000)
    expect(page.locator('#table4-comparisons-table tbody tr[data-baseline="none"]')).to_be_visible()
    loaded(page, '#table4-plots figure[data-plot="table4.png"] img')
    links = page.locator("#table4-recordings a[data-testid=open-rerun]")
    expect(links.first).to_be_visible()
    href = links.first.get_attribute("href")
    assert href.startswith("/rerun/?url=") and href.endswith(".rrd"), href
    shot(page, "table4")

    # The recording in Rerun's viewer (served by FireCast; the wasm takes a while at first).
    with page.context.expect_page() as opened:
        links.first.click()
    viewer = opened.value
    viewer.wait_for_selector("#the_canvas_id.visible", state="attached", timeout=90_000)
    assert viewer.title() == "Rerun Viewer"
    box = viewer.locator("#the_canvas_id").bounding_box()
    assert box and box["width"] > 600 and box["height"] > 400, box
    viewer.wait_for_timeout(6000)  # the recording streams in
    viewer.screenshot(path=os.path.join(SHOTS, "rerun.png"))
    viewer.close()

    # The run page of the evaluation: its table and a Rerun link per recording.
    page.goto(URL + f"/#/runs/{run_id(page, 'rl.evaluate')}")
    expect(page.locator("#run-table-link")).to_have_text("Table IV of this run", timeout=30_000)
    assert page.locator("#run-artifacts a[data-testid=open-rerun]").count() >= 2


def test_datasets(page):
    page.goto(URL + "/#/datasets")
    expect(page.locator('#datasets-table tr[data-name="app-ignitions"]')).to_be_visible(timeout=30_000)
    page.locator('#datasets-table a', has_text="app-ignitions").first.click()
    expect(page).to_have_url(re.compile(r"#/datasets/app-ignitions$"))
    card = page.locator("#dataset-card")
    expect(card.locator("h2.md-h").first).to_contain_text("app-ignitions", timeout=30_000)
    expect(card.locator("table").first).to_be_visible()
    loaded(page, "#dataset-map-img")
    # The map's colours are named beside it.
    expect(page.locator("#dataset-map-legend")).to_contain_text("positive")
    expect(page.locator("#stats-table tbody tr").first).to_be_visible()
    rows = page.locator("#stats-table tbody tr").count()
    page.locator("#stats-split").select_option("train")
    assert 0 < page.locator("#stats-table tbody tr").count() < rows
    expect(page.locator("#versions-table")).to_contain_text("on disk")
    # The card's text is shown as text: nothing in it runs or becomes markup (tests/cli/serve.rs
    # appends HTML and a javascript: link to the card).
    expect(card).to_contain_text("<script>window.__pwned = 1</script>")
    expect(card).to_contain_text("<b>not bold</b>")
    assert page.evaluate("window.__pwned") is None
    assert card.locator("script, iframe, b, img[src=x]").count() == 0
    link = card.locator("a", has_text="a script link")
    assert link.count() == 0 or not (link.get_attribute("href") or "").startswith("javascript"), link
    page.wait_for_timeout(500)
    shot(page, "dataset")

    # The version's run links back to the dataset.
    page.locator("#versions-table tbody a").first.click()
    expect(page.locator("#run-datasets")).to_contain_text("app-ignitions", timeout=30_000)


def test_compare_grouped(page):
    ids = [run_id(page, k) for k in ["rl.train", "forecast.experiment", "rl.evaluate"]]
    page.goto(URL + "/#/compare?ids=" + ",".join(ids))
    select = page.locator("#group-by")
    expect(select).to_be_visible(timeout=30_000)
    select.select_option("name")
    expect(page).to_have_url(re.compile(r"group=name"))
    groups = page.locator("#compare-groups .group-chip")
    expect(groups).to_have_count(3, timeout=30_000)
    expect(page.locator("#group-table tbody tr").first).to_be_visible()
    assert page.locator("#compare-groups canvas").count() >= 1
    page.locator("#compare-group").scroll_into_view_if_needed()
    page.wait_for_timeout(500)
    page.locator("#compare-group").screenshot(path=os.path.join(SHOTS, "compare-grouped.png"))

    # The grouping is in the address: reloading keeps it.
    page.reload()
    expect(page.locator("#compare-groups .group-chip")).to_have_count(3, timeout=30_000)
    expect(page.locator("#group-by")).to_have_value("name")


def test_phone_nav(browser):
    context = browser.new_context(viewport={"width": 390, "height": 800}, is_mobile=True)
    page = context.new_page()
    page.goto(URL + "/#/datasets")
    for label in ["Runs", "Table III", "Table IV", "Datasets"]:
        link = page.locator(".topnav a", has_text=label)
        box = link.bounding_box()
        assert box and box["x"] >= 0 and box["x"] + box["width"] <= 390, (label, box)
    page.locator(".topnav a", has_text="Table IV").click()
    expect(page.locator("#table4-page")).to_be_visible()
    shot(page, "phone-nav")
    context.close()
