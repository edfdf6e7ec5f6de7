"""The technician's page in a real browser: Debian's chromium, headless, driven by Playwright,
against a real ``bench serve`` subprocess on 127.0.0.1 with the virtual macro4 bench.

One server and one browser for the module; every test has its own browser context (so its
own sessionStorage: a fresh login).  What the page claims is checked through the API too.
The identify test takes the screenshot the README shows; it replaces docs/img/bench_page.png
only with BENCH_UPDATE_SCREENSHOT=1 (a test run leaves the checkout clean).
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
import playwright.sync_api as pw
from api_helpers import Live, wait_run

from api.server import free_port

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-first-run"]
VIEWPORT = {"width": 1280, "height": 800}       # the technician's tablet
SCREENSHOT = Path(__file__).resolve().parents[2] / "docs" / "img" / "bench_page.png"
UPDATE_SCREENSHOT = os.environ.get("BENCH_UPDATE_SCREENSHOT") == "1"
RUN_TIMEOUT_MS = 150_000


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("browser")
    port = free_port()
    log = open(tmp / "server.log", "w")
    env = {**os.environ, "BENCH_API_KEY": ""}
    proc = subprocess.Popen([sys.executable, "-c", "from bench.cli import main; main()", "serve", "--bench", "macro4",
                             "--data", str(tmp / "data"), "--port", str(port), "--log-level", "warning",
                             "--no-pin-cpus"], stdout=log, stderr=subprocess.STDOUT, env=env, cwd=tmp)
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                if httpx.get(f"{url}/health", timeout=1).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("bench serve did not start: " + (tmp / "server.log").read_text()[-2000:])
            time.sleep(0.2)
        admin = (tmp / "data" / "admin.key").read_text().strip()
        with httpx.Client(base_url=url, headers={"Authorization": f"Bearer {admin}"}, timeout=10) as c:
            operator = c.post("/keys", json={"role": "operator", "name": "tech"}).json()["key"]
            observer = c.post("/keys", json={"role": "observer", "name": "viewer"}).json()["key"]
        yield Live(url, proc, admin, operator, observer)
    finally:
        proc.terminate()
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)
        log.close()


@pytest.fixture(scope="module")
def browser():
    with pw.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True)
        yield b
        b.close()


@pytest.fixture
def page(browser, server):
    ctx = browser.new_context(viewport=VIEWPORT, accept_downloads=True)
    ctx.set_default_timeout(20_000)
    pg = ctx.new_page()
    errors: list[str] = []
    urls: list[str] = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    ctx.on("request", lambda r: urls.append(r.url))
    pg.goto(server.url + "/")
    yield pg
    ctx.close()
    assert not errors, f"JavaScript errors on the page: {errors}"
    # the page asked nothing of any other host, and never put a key into a URL
    assert all(u.startswith((server.url + "/", "blob:", "data:", "about:")) for u in urls), urls
    keys = (server.admin, server.operator, server.observer)
    assert not [u for u in urls if any(k in u for k in keys)]


def login(page, key: str, role: str) -> None:
    page.fill("#login-key", key)
    page.click("#login-form button")
    pw.expect(page.locator("#who")).to_contain_text(role)
    page.wait_for_selector("#joints tbody tr[data-joint]")


def estop_in_view(page) -> bool:
    box = page.locator("#estop").bounding_box()
    return box is not None and box["y"] >= 0 and box["y"] + box["height"] <= VIEWPORT["height"] \
        and box["x"] >= 0 and box["x"] + box["width"] <= VIEWPORT["width"]


def test_browser_wrong_key_gets_a_clear_message(page, server):
    page.fill("#login-key", "not-a-key")
    page.click("#login-form button")
    pw.expect(page.locator("#login-msg")).to_contain_text("not accepted")
    assert "invalid API key" in page.inner_text("#login-msg")
    assert page.locator("#view-login").is_visible() and page.locator("#nav").is_hidden()
    assert page.evaluate("sessionStorage.getItem('bench.key')") is None    # a refused key is not kept
    assert "not-a-key" not in page.url


def test_browser_observer_sees_no_operator_controls(page, server):
    login(page, server.observer, "observer")
    assert page.locator("#estop").is_visible() and estop_in_view(page)    # any key may stop the bench
    assert page.locator("nav button[data-view=start]").is_hidden()
    assert page.locator("nav button[data-view=analyze]").is_hidden()      # POST /analyze needs an operator
    assert page.locator(".comp-switch").count() == 0                      # compensation shown, not switchable
    assert page.locator("#joints tbody tr[data-joint]").count() == 4
    for hidden in ("#start-run", "#live-cancel", "#estop-reset"):
        assert page.locator(hidden).is_hidden(), hidden
    # forced past the page, the API refuses the observer's key
    status = page.evaluate("""async () => {
        const h = {"Authorization": "Bearer " + sessionStorage.getItem("bench.key"), "content-type": "application/json"};
        const run = await fetch("/runs", {method: "POST", headers: h,
                                          body: JSON.stringify({procedure: "identify", joints: ["j1"]})});
        const comp = await fetch("/joints/j1/compensation", {method: "PUT", headers: h,
                                                             body: JSON.stringify({enabled: true})});
        return [run.status, (await run.json()).detail, comp.status];
    }""")
    assert status[0] == 403 and "operator" in status[1] and status[2] == 403, status


def test_browser_every_view_fits_the_tablet_with_the_estop_in_reach(page, server):
    login(page, server.admin, "admin")
    for view in ("bench", "start", "live", "history", "compare", "analyze"):
        page.click(f"nav button[data-view={view}]")
        assert page.locator(f"#view-{view}").is_visible()
        assert page.evaluate("document.documentElement.scrollWidth") <= VIEWPORT["width"], view
        page.mouse.wheel(0, 2000)                                        # the e-stop never scrolls away
        assert page.locator("#estop").is_visible() and estop_in_view(page), view
        pw.expect(page.locator("#estop-state")).to_have_text("e-stop: clear")


def test_browser_identify_live_then_report_and_trace(page, server):
    login(page, server.operator, "operator")
    page.reload()                                   # the key is entered once per tab
    pw.expect(page.locator("#who")).to_contain_text("operator")
    page.click("nav button[data-view=start]")
    page.check("input[name=joint][value=j1]")
    page.fill("input[name=search_max_trials]", "99")
    page.click("#start-run")
    # the API's 422 message, next to the field at fault
    pw.expect(page.locator('.field-error[data-field="options.search_max_trials"]')).to_contain_text("30")
    assert page.inner_text("#start-msg") == ""
    page.fill("input[name=search_max_trials]", "8")
    page.fill("input[name=seed]", "5007")
    page.click("#start-run")
    pw.expect(page.locator("#view-live")).to_be_visible()
    run_id = page.inner_text("#live-id")
    # live: the trial list and the plot fill from the event stream while the run goes on
    page.wait_for_selector("#trials tbody tr.trial", timeout=RUN_TIMEOUT_MS)
    page.wait_for_function("Number(document.querySelector('#plot').dataset.points) >= 5", timeout=RUN_TIMEOUT_MS)
    first = int(page.get_attribute("#plot", "data-points"))
    page.wait_for_function(f"Number(document.querySelector('#plot').dataset.points) > {first}",
                           timeout=RUN_TIMEOUT_MS)
    page.wait_for_selector("#trials tbody .decision-accepted", timeout=RUN_TIMEOUT_MS)
    shot = page.screenshot(path=str(SCREENSHOT) if UPDATE_SCREENSHOT else None)
    assert shot[:8] == b"\x89PNG\r\n\x1a\n" and len(shot) > 10_000   # a real page, not a blank
    assert page.locator("#stages li").count() >= 1
    pw.expect(page.locator("#live-state")).to_contain_text("succeeded", timeout=RUN_TIMEOUT_MS)
    pw.expect(page.locator("#live-pct")).to_have_text("100 %")
    pw.expect(page.locator("#results")).to_contain_text("j1 model")
    with server.client(server.observer) as c:
        run = c.get(f"/runs/{run_id}").json()
    assert run["state"] == "succeeded" and run["procedure"] == "identify", run
    trials = run["result"]["joints"]["j1"]["excitation"]["trials"]
    assert page.locator("#trials tbody tr.trial").count() == trials
    # the report opens in a new tab (fetched with the key, shown from a blob: no key in a URL)
    with page.context.expect_page() as opened:
        page.click("#live-report")
    report = opened.value
    report.wait_for_load_state()
    pw.expect(report.locator("img").first).to_be_visible()
    assert report.url.startswith("blob:") and server.operator not in report.url
    assert "data:image/png;base64" in report.content()
    with page.expect_download() as dl:
        page.click("#live-csv")
    lines = [ln for ln in Path(dl.value.path()).read_text().splitlines() if not ln.startswith("#")]
    assert lines[0] == "t,tau,q,qd" and len(lines) > 1000
    # the history lists it with its duration
    page.click("nav button[data-view=history]")
    row = page.locator(f"#history tr[data-run='{run_id}']")
    pw.expect(row).to_contain_text("succeeded")
    pw.expect(row).to_contain_text(" s")
    # the operator switches j1's compensation on with its new model, and off again
    page.click("nav button[data-view=bench]")
    switch = page.locator(".comp-switch[data-joint=j1]")
    pw.expect(page.locator("#joints tr[data-joint=j1]")).to_contain_text(run["result"]["joints"]["j1"]["model_id"])
    with server.client(server.observer) as c:
        for enabled in (True, False):
            switch.click()
            pw.expect(switch).to_be_checked(checked=enabled)
            deadline = time.monotonic() + 10
            while c.get("/joints/j1").json()["compensation"]["enabled"] is not enabled:
                assert time.monotonic() < deadline, "the switch did not reach the API"
                time.sleep(0.1)


def test_browser_compares_two_identifications_of_a_joint(page, server):
    query = {"procedure": "identify", "joint": "j1", "state": "succeeded"}
    with server.client(server.operator) as c:
        for seed in (5011, 5013):       # two, whether or not the identify test above ran
            if len(c.get("/runs", params=query).json()["runs"]) >= 2:
                break
            r = c.post("/runs", json={"procedure": "identify", "joints": ["j1"],
                                      "options": {"search_max_trials": 8, "seed": seed, "plots": False}})
            assert r.status_code == 202, r.text
            done = wait_run(c, r.json()["id"])
            assert done["state"] == "succeeded", done["error"]
        run, older = c.get("/runs", params=query).json()["runs"][:2]
    login(page, server.observer, "observer")
    page.click("nav button[data-view=compare]")
    page.select_option("#cmp-joint", "j1")
    pw.expect(page.locator("#compare tbody tr")).to_have_count(6)
    a, b = older["result"]["joints"]["j1"]["parameters"], run["result"]["joints"]["j1"]["parameters"]
    for name in ("Fc", "sigma0"):
        text = page.inner_text(f"#compare tr[data-param={name}] td.change")
        assert text.endswith("%")
        assert float(text.rstrip(" %")) == pytest.approx(100 * (b[name] - a[name]) / abs(a[name]), abs=0.051), name


def test_browser_analyzes_a_robots_log_and_the_error_falls(page, server, tmp_path):
    """A log as a robot's logger writes it (its own column names, degrees, no metadata lines)
    with cogging the virtual joint hid in it (fresh seed 10343): uploaded from the page, a
    wrong column named in the API's one line, then read with the mapping typed into the form;
    the page shows the model, cogging named with the held-out error falling, the plots, and
    an effect ticked in is fitted on the next analysis."""
    import numpy as np

    from virtual_drives.conditions import make_record
    from virtual_drives.presets import PRESETS
    spec = PRESETS["rotary"]
    rec, _ = make_record(spec, "clean", seed=10343, duration=8.0, effects=("cogging:amplitude=0.02,pitch=0.3",))
    log = tmp_path / "arm_log.csv"
    np.savetxt(log, np.column_stack([rec.t, np.degrees(rec.q), rec.tau]), delimiter=",",
               header="time_s,angle_deg,motor_torque", comments="", fmt="%.9g")
    login(page, server.operator, "operator")
    page.click("nav button[data-view=analyze]")
    page.click("#an-run")
    pw.expect(page.locator("#an-msg")).to_contain_text("Choose a log file first")
    page.set_input_files("#an-file", str(log))
    page.fill("input[name=columns]", "t=time_s,tau=torque,q=angle_deg")
    page.click("#an-run")
    pw.expect(page.locator("#an-msg")).to_contain_text("motor_torque", timeout=60_000)   # the file's columns listed
    assert "\n" not in page.inner_text("#an-msg") and "Traceback" not in page.inner_text("#an-msg")
    assert page.locator("#an-result").is_hidden()
    page.fill("input[name=columns]", "t=time_s,tau=motor_torque,q=angle_deg")
    page.fill("input[name=inertia]", str(spec.inertia))
    page.fill("input[name=position_unit]", "deg")
    page.click("#an-run")
    pw.expect(page.locator("#an-history tbody tr")).to_have_count(1, timeout=120_000)
    pw.expect(page.locator("#an-verdict")).to_have_text("Named: cogging; nothing left to explain")
    assert page.inner_text("#an-diag tr[data-effect=cogging] td:nth-child(2)") == "yes"
    fall = page.inner_text("#an-history tr[data-run='1'] td.fall")
    assert float(fall.split("(")[1].rstrip(" %)")) < -50, fall         # the held-out error falls
    fc = float(page.inner_text("#an-params tr[data-param=Fc] td.value"))
    assert fc == pytest.approx(spec.friction.Fc, rel=0.03)
    assert page.locator("#an-params tr[data-param=sigma0]").count() == 1
    pw.expect(page.locator("#an-plots img")).to_have_count(len(["map", "presliding", "inertia", "residual_baseline",
                                                               "step1", "error_fall"]))
    assert page.evaluate("[...document.querySelectorAll('#an-plots img')].every(i => i.complete && i.naturalWidth > 300)")
    # the residuals at the file's own times, a row per row of the log, saved as a file
    with page.expect_download() as dl:
        page.click("#an-residuals")
    assert dl.value.suggested_filename == "arm_log-residuals.csv"
    rows = Path(dl.value.path()).read_text().splitlines()
    assert rows[0] == "t,measured,baseline,final,held_out" and len(rows) == len(rec.t) + 1
    assert float(rows[-1].split(",")[0]) == pytest.approx(rec.t[-1])
    # the technician ticks an effect the diagnosis did not name: fitted, shown as added
    page.check("input[name=add][value=torque_offset]")
    page.click("#an-run")
    pw.expect(page.locator("#an-history tbody tr")).to_have_count(2, timeout=120_000)
    pw.expect(page.locator("#an-history tr[data-run='2']")).to_contain_text("torque_offset")
    assert page.locator("#an-diag tr[data-effect=torque_offset]").count() == 1
    assert page.evaluate("document.documentElement.scrollWidth") <= VIEWPORT["width"]
    assert page.locator("#estop").is_visible() and estop_in_view(page)


def test_browser_analyzes_a_runs_trace_from_the_history(page, server):
    """History -> "analyze j1": the run's trace (fetched with the key, no file chosen) is
    analysed in the Analyze view; its model is the run's own within a few per cent."""
    query = {"procedure": "identify", "joint": "j1", "state": "succeeded"}
    with server.client(server.operator) as c:
        runs = c.get("/runs", params=query).json()["runs"]
        if not runs:            # one, whether or not the identify test above ran
            r = c.post("/runs", json={"procedure": "identify", "joints": ["j1"],
                                      "options": {"search_max_trials": 8, "seed": 10361, "plots": False}})
            assert r.status_code == 202, r.text
            assert wait_run(c, r.json()["id"])["state"] == "succeeded"
            runs = c.get("/runs", params=query).json()["runs"]
    run = runs[0]
    login(page, server.operator, "operator")
    page.click("nav button[data-view=history]")
    row = page.locator(f"#history tr[data-run='{run['id']}']")
    # the row's buttons are buttons (a joint's list of them was shown as "[object HTMLButtonElement]")
    assert "object" not in row.inner_text(), row.inner_text()
    with page.expect_download() as dl:
        row.locator("button.csv[data-joint=j1]").click()
    assert Path(dl.value.path()).read_text().splitlines()[-1].count(",") == 3
    row.locator("button.analyze[data-joint=j1]").click()
    pw.expect(page.locator("#view-analyze")).to_be_visible()
    pw.expect(page.locator("#an-trace")).to_contain_text(run["id"])
    page.click("#an-run")
    pw.expect(page.locator("#an-history tbody tr")).to_have_count(1, timeout=120_000)
    pw.expect(page.locator("#an-history tr[data-run='1']")).to_contain_text(f"{run['id']}-j1.csv")
    identified = run["result"]["joints"]["j1"]["parameters"]
    for name in ("Fc", "Fs", "sigma2"):
        shown = float(page.inner_text(f"#an-params tr[data-param={name}] td.value"))
        assert shown == pytest.approx(identified[name], rel=0.03), name
    assert page.inner_text("#an-msg") == ""


def test_browser_estop_stops_a_calibration_until_an_admin_resets(page, server):
    login(page, server.operator, "operator")
    page.click("nav button[data-view=start]")
    page.select_option("select[name=procedure]", "calibrate")
    page.check("input[name=joint][value=j3]")
    page.uncheck("input[name=plots]")
    page.click("#start-run")
    pw.expect(page.locator("#view-live")).to_be_visible()
    run_id = page.inner_text("#live-id")
    page.wait_for_function("Number(document.querySelector('#plot').dataset.points) >= 3", timeout=RUN_TIMEOUT_MS)
    page.click("#estop")                                        # one click, no dialog
    pw.expect(page.locator("#estop-banner")).to_be_visible()
    pw.expect(page.locator("#estop-state")).to_have_text("E-STOP LATCHED")
    with server.client(server.observer) as c:
        state = c.get("/estop").json()
        assert state["active"] is True and "tech" in state["reason"]
        assert {d["joint"] for d in state["drives"]} == {"j1", "j2", "j3", "j4"}
        assert all(d["torque_off"] is True for d in state["drives"]), state["drives"]
        assert {j["state"] for j in c.get("/joints").json()["joints"]} == {"estopped"}
        run = wait_run(c, run_id)
        assert run["state"] == "failed" and "emergency stop" in run["error"]
        for jid in ("j1", "j2", "j3", "j4"):
            drive = c.get(f"/joints/{jid}").json()["drive"]
            assert drive["open"] is False and drive["state"] in ("disabled", "quick_stop", "fault"), (jid, drive)
    pw.expect(page.locator("#live-state")).to_contain_text("failed", timeout=RUN_TIMEOUT_MS)
    # new runs are refused, on the page and through the API, and only an admin may reset
    page.click("nav button[data-view=start]")
    page.select_option("select[name=procedure]", "identify")
    page.click("#start-run")
    pw.expect(page.locator("#start-msg")).to_contain_text("e-stop")
    assert page.locator("#estop-reset").is_hidden()
    with server.client(server.operator) as c:
        refused = c.post("/runs", json={"procedure": "identify", "joints": ["j1"]})
        assert refused.status_code == 409 and "e-stop" in refused.json()["detail"]
        assert c.post("/estop/reset").status_code == 403
    page.click("#logout")
    login(page, server.admin, "admin")
    pw.expect(page.locator("#estop-banner")).to_be_visible()          # the latch outlives the session
    page.click("#estop-reset")
    pw.expect(page.locator("#estop-banner")).to_be_hidden()
    pw.expect(page.locator("#estop-state")).to_have_text("e-stop: clear")
    with server.client(server.observer) as c:
        assert c.get("/estop").json()["active"] is False
        assert {j["state"] for j in c.get("/joints").json()["joints"]} == {"idle"}
