"""The explorer's page in a real browser: Debian's chromium, driven through
chromedriver by selenium's WebDriver client, against a real `jeffcott explore`.

It checks that the page loads and draws, that a box-zoom sends the recompute for the
window under the box and redraws, that a click on a basin cell opens that cell's
trajectory, that a parameter change recomputes, that a bad value gets the command
line's message, and that the page logs no console errors. Screenshots go to
$JEFFCOTT_SCREENSHOTS (default target/explore-screenshots) for a person to look at.

Run by scripts/browser-test.sh. Without chromium or chromedriver the tests are skipped,
unless JEFFCOTT_REQUIRE_BROWSER=1 (CI), where they fail.
"""

import os
import re
import shutil
import subprocess
import time
import urllib.parse

import pytest

BIN = os.environ.get("JEFFCOTT_BIN", "target/release/jeffcott")
SHOTS = os.environ.get("JEFFCOTT_SCREENSHOTS", "target/explore-screenshots")
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
DRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"


def need_browser():
    missing = [p for p in (CHROMIUM, DRIVER) if not os.path.exists(p)]
    try:
        import selenium  # noqa: F401
    except ImportError:
        missing.append("selenium (pip)")
    if missing:
        msg = "browser test needs " + ", ".join(missing)
        if os.environ.get("JEFFCOTT_REQUIRE_BROWSER") == "1":
            pytest.fail(msg)
        pytest.skip(msg)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    out = tmp_path_factory.mktemp("explore-out")
    proc = subprocess.Popen(
        [BIN, "explore", "--no-browser", "--port", "0", "--backend", "cpu", "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    line = proc.stdout.readline()
    m = re.search(r"(http://\S+)", line)
    assert m, f"explore printed no address: {line!r} {proc.stderr.read() if proc.poll() is not None else ''}"
    yield m.group(1), out
    proc.terminate()
    proc.wait(timeout=10)


@pytest.fixture(scope="module")
def browser():
    need_browser()
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for flag in (
        "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        "--window-size=1500,1900",
    ):
        opts.add_argument(flag)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    d = webdriver.Chrome(service=Service(DRIVER), options=opts)
    os.makedirs(SHOTS, exist_ok=True)
    yield d
    d.quit()


def wait(what, cond, timeout=120):
    t = time.time()
    while time.time() - t < timeout:
        v = cond()
        if v:
            return v
        time.sleep(0.2)
    pytest.fail(f"timed out waiting for {what}")


INK = """
const c = document.getElementById(arguments[0]);
const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
let n = 0;
for (let i = 0; i < d.length; i += 4) if (d[i + 3] > 0 && (d[i] < 200 || d[i + 1] < 200 || d[i + 2] < 200)) n++;
return n;
"""


FIRST_INK = """
const c = document.getElementById(arguments[0]);
const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
for (let y = 20; y < c.height - 20; y++) for (let x = 20; x < c.width - 20; x++) {
  const i = 4 * (y * c.width + x);
  if (d[i] < 150) return [x, y];
}
return null;
"""


def ink(d, canvas):
    """Pixels of `canvas` that are not blank (not white, not transparent)."""
    return d.execute_script(INK, canvas)


def requests(d, path):
    """The query fields of every request the page made to `path`, in order."""
    names = d.execute_script("return performance.getEntriesByType('resource').map(e => e.name)")
    out = []
    for n in names:
        u = urllib.parse.urlparse(n)
        if u.path == path:
            out.append(dict(urllib.parse.parse_qsl(u.query)))
    return out


def console_errors(d):
    return [e for e in d.get_log("browser") if e["level"] == "SEVERE"]


def set_form(d, form, **values):
    for name, v in values.items():
        el = d.find_element("css selector", f"#{form} [name={name}]")
        el.clear()
        el.send_keys(str(v))


def test_the_page_draws_zooms_drills_down_and_recomputes(server, browser):
    from selenium.webdriver.common.action_chains import ActionChains

    url, out = server
    d = browser
    d.get(url)
    d.execute_script("performance.setResourceTimingBufferSize(100000)")
    # Lighter views than the defaults, so the test takes seconds on two cores.
    set_form(d, "bif-form", n=48, transient=60, periods=16, k=2)
    d.find_element("css selector", "#bif-form button").click()
    set_form(d, "basin-form", n=12, transient=60, periods=8)
    d.find_element("css selector", "#basin-form button").click()
    wait("the bifurcation diagram", lambda: ink(d, "bif-canvas") > 200)
    wait("the whole diagram", lambda: "starts in" in d.find_element("id", "bif-status").text)
    d.save_screenshot(f"{SHOTS}/1-loaded.png")

    # Box-zoom: from 25 % to 50 % of the plot's width.
    overlay = d.find_element("id", "bif-overlay")
    w, h, m = 800, 360, 16
    before = len(requests(d, "/api/bifurcation"))
    ink_before = ink(d, "bif-canvas")
    x0, x1 = m + 0.25 * (w - 2 * m), m + 0.5 * (w - 2 * m)
    # The box spans the whole height, so the zoomed window holds points.
    ActionChains(d).move_to_element_with_offset(overlay, int(x0 - w / 2), int(-h / 2 + 2)).click_and_hold().move_by_offset(
        int(x1 - x0), int(h - 4)
    ).release().perform()
    new = wait("the zoom's requests", lambda: requests(d, "/api/bifurcation")[before:])
    lo, hi = float(new[0]["lo"]), float(new[0]["hi"])
    want_lo, want_hi = 125 + 20 * 0.25, 125 + 20 * 0.5
    px = 20 / (w - 2 * m)
    assert abs(lo - want_lo) < 2 * px and abs(hi - want_hi) < 2 * px, (lo, hi)
    wait("the zoomed diagram", lambda: "starts in" in d.find_element("id", "bif-status").text)
    assert ink(d, "bif-canvas") > 200 and ink(d, "bif-canvas") != ink_before
    assert float(d.find_element("css selector", "#bif-form [name=lo]").get_attribute("value")) == lo
    d.save_screenshot(f"{SHOTS}/2-zoomed.png")

    # A click on a point of the diagram opens that lane's trajectory.
    x, y = d.execute_script(FIRST_INK, "bif-canvas")
    ActionChains(d).move_to_element_with_offset(overlay, int(x - w / 2), int(y - h / 2)).click().perform()
    wait("the point's trajectory", lambda: "status" in d.find_element("id", "traj-summary").text)
    t = requests(d, "/api/trajectory")[-1]
    assert "start" in t and lo <= float(t["omega"]) <= hi, t
    assert "jeffcott simulate --omega" in d.find_element("id", "traj-cmd").text

    # A click on a basin cell opens its trajectory.
    wait("the basin", lambda: "12 x 12" in d.find_element("id", "basin-status").text)
    cell = d.find_element("id", "basin-overlay")
    ActionChains(d).move_to_element_with_offset(cell, 40, -60).click().perform()
    wait("the trajectory", lambda: "status" in d.find_element("id", "traj-summary").text)
    traj = requests(d, "/api/trajectory")
    assert traj and len(traj[-1]["x0"].split(",")) == 8
    assert ink(d, "traj-orbit") > 100 and ink(d, "traj-section") > 0
    assert "jeffcott simulate --omega 133" in d.find_element("id", "traj-cmd").text
    d.save_screenshot(f"{SHOTS}/3-trajectory.png")

    # A parameter change recomputes both views with it.
    before = len(requests(d, "/api/basin"))
    set_form(d, "params", mu="0.1")
    d.find_element("id", "params-apply").click()
    new = wait("the recompute", lambda: requests(d, "/api/basin")[before:])
    assert new[0]["p.mu"] == "0.1"
    assert "--param mu=0.1" in d.find_element("id", "basin-cmd").text
    wait("the recomputed basin", lambda: "12 x 12" in d.find_element("id", "basin-status").text)
    assert console_errors(d) == []

    # Save puts the data into --out.
    d.find_element("css selector", "#basin [data-act=npy]").click()
    # The server reserves the name with an empty file, then renames the data onto it.
    saved = out / "basin-1.npy"
    wait("the saved file", lambda: saved.exists() and saved.stat().st_size > 0)
    assert (out / "basin-1.npy").read_bytes()[:6] == b"\x93NUMPY"

    # A bad value gets the command line's message in the page.
    set_form(d, "params", mu="0", delta="-1")
    d.find_element("id", "params-apply").click()
    err = d.find_element("id", "error")
    wait("the error", lambda: err.is_displayed() and "delta" in err.text)
    assert "must be finite and > 0" in err.text
    d.save_screenshot(f"{SHOTS}/4-error.png")
    other = [e for e in console_errors(d) if "400 (Bad Request)" not in e["message"]]
    assert other == []
