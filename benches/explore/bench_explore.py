"""Measures the explorer against its targets, in a real browser (Debian's chromium via
selenium) and over raw HTTP, and appends one row per figure to explore.csv beside this
file (machine, date, commit, figure, value, unit).

- first picture: page load to the first drawn pixels of the default bifurcation view;
- refinement: the longest gap between two pictures of that view until it completes;
- zoom: a box-zoom to the first redrawn pixels of the new window;
- stale stop: a newer request of the same page and view to the older one's answer
  (cancelled), over HTTP, the older one a long diagram slice;
- basin: the default 128 x 128 basin view at 133 rad/s, load to complete;
- memory: the server's resident memory after batches of random requests.

With --screenshot PATH it then clicks a basin cell and writes the page, with that
cell's trajectory, to PATH (docs/explore.png is made so).

Usage: python benches/explore/bench_explore.py [BIN] [--backend cpu|gpu] [--screenshot PATH]
"""

import argparse
import csv
import datetime
import os
import platform
import re
import subprocess
import threading
import time
import urllib.error
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))


def start(binary, backend):
    p = subprocess.Popen([binary, "explore", "--no-browser", "--port", "0", "--backend", backend],
                         stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    url = re.search(r"(http://\S+)", p.stdout.readline()).group(1)
    return p, url


def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    o = webdriver.ChromeOptions()
    o.binary_location = "/usr/bin/chromium"
    for f in ("--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run",
              "--disable-background-networking", "--disable-component-update", "--disable-sync",
              "--window-size=1500,1900"):
        o.add_argument(f)
    return webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=o)


WATCH = """
window.__pictures = [];
const c = document.getElementById('bif-canvas');
const s = document.getElementById('bif-status');
new MutationObserver(() => window.__pictures.push([performance.now(), s.textContent])).observe(s, {childList: true, characterData: true, subtree: true});
"""


def page_figures(url, screenshot):
    from selenium.webdriver.common.action_chains import ActionChains
    d = browser()
    rows = []
    try:
        d.get(url)
        d.execute_script(WATCH)
        t0 = time.time()
        while time.time() - t0 < 900:
            pics = d.execute_script("return window.__pictures")
            if pics and "starts in" in pics[-1][1]:
                break
            time.sleep(0.1)
        nav = d.execute_script("return performance.timing.navigationStart - performance.timeOrigin")
        pics = d.execute_script("return window.__pictures")
        shown = [t for t, s in pics if " of " in s or "starts in" in s]
        rows.append(("bifurcation first picture after page load", (shown[0] - nav) / 1000, "s"))
        gaps = [b - a for a, b in zip(shown, shown[1:])]
        rows.append(("bifurcation longest gap between pictures", max(gaps) / 1000 if gaps else 0, "s"))
        rows.append(("bifurcation default view complete", (shown[-1] - nav) / 1000, "s"))
        # Zoom: a box over the middle half of the speeds, the whole height.
        d.execute_script("window.__pictures = []")
        ov = d.find_element("id", "bif-overlay")
        t = d.execute_script("return performance.now()")
        ActionChains(d).move_to_element_with_offset(ov, -200, -178).click_and_hold().move_by_offset(400, 356).release().perform()
        while True:
            pics = d.execute_script("return window.__pictures")
            got = [p for p in pics if " of " in p[1] or "starts in" in p[1]]
            if got:
                rows.append(("zoom to first recomputed pixels", (got[0][0] - t) / 1000, "s"))
                break
            time.sleep(0.05)
        # The basin: wait for its full resolution.
        t0 = time.time()
        while "128 x 128" not in d.find_element("id", "basin-status").text:
            time.sleep(0.5)
            if time.time() - t0 > 3000:
                raise SystemExit("basin did not complete")
        text = d.find_element("id", "basin-status").text
        rows.append(("basin 128 x 128 at 133 rad/s, all levels, page load to complete",
                     float(re.search(r"in ([0-9.]+) s", text).group(1)), "s"))
        if screenshot:
            cell = d.find_element("id", "basin-overlay")
            ActionChains(d).move_to_element_with_offset(cell, 60, -40).click().perform()
            t0 = time.time()
            while "status" not in d.find_element("id", "traj-summary").text and time.time() - t0 < 120:
                time.sleep(0.2)
            d.set_window_size(1500, 1800)
            d.save_screenshot(screenshot)
    finally:
        d.quit()
    return rows


def stale_stop(url):
    base = url.rstrip("/")
    got = {}

    def old():
        try:
            urllib.request.urlopen(base + "/api/bifurcation?tab=b&n=64&k=16&transient=3000&periods=8")
        except urllib.error.HTTPError as e:
            got["status"], got["t"] = e.code, time.time()

    th = threading.Thread(target=old)
    th.start()
    time.sleep(1.0)
    t = time.time()
    urllib.request.urlopen(base + "/api/bifurcation?tab=b&n=2&k=1&transient=2&periods=2").read()
    th.join()
    assert got.get("status") == 409, got
    return [("stale request's answer after the newer request's", got["t"] - t, "s")]


def memory(url, pid):
    """The server's resident memory after each batch of 60 requests of random windows,
    sizes and pages, each cancelling the last of its page and view."""
    import random
    rng = random.Random(7)
    base = url.rstrip("/")
    rows = []
    for batch in range(1, 5):
        threads = []
        for i in range(60):
            lo = rng.uniform(100, 180)
            q = (f"/api/bifurcation?tab=m{i % 3}&lo={lo}&hi={lo + rng.uniform(0.1, 20)}&n={rng.randint(50, 4000)}"
                 f"&count={rng.randint(1, 50)}&k={rng.randint(1, 8)}&transient={rng.randint(0, 100)}&periods=16")
            if i % 4 == 0:
                q = f"/api/basin?tab=m{i % 3}&n={rng.randint(4, 24)}&transient=50&periods=8"

            def go(q=q):
                try:
                    urllib.request.urlopen(base + q).read()
                except urllib.error.HTTPError:
                    pass
            t = threading.Thread(target=go)
            t.start()
            threads.append(t)
            time.sleep(0.02)
        for t in threads:
            t.join()
        rss = int(re.search(r"VmRSS:\s+(\d+)", open(f"/proc/{pid}/status").read()).group(1))
        rows.append((f"server resident memory after {60 * batch} random requests", rss / 1024, "MiB"))
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bin", nargs="?", default="target/release/jeffcott")
    ap.add_argument("--backend", default="cpu")
    ap.add_argument("--screenshot")
    a = ap.parse_args()
    p, url = start(a.bin, a.backend)
    try:
        rows = stale_stop(url) + memory(url, p.pid) + page_figures(url, a.screenshot)
    finally:
        p.terminate()
    commit = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], capture_output=True, text=True).stdout.strip()
    if subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True).stdout.strip():
        commit += "-dirty"
    machine = f"{platform.machine()} {os.cpu_count()} cores, backend {a.backend}"
    date = datetime.date.today().isoformat()
    path = os.path.join(HERE, "explore.csv")
    new = not os.path.exists(path)
    with open(path, "a", newline="") as f:
        w = csv.writer(f)
        if new:
            w.writerow(["machine", "date", "commit", "figure", "value", "unit"])
        for fig, v, u in rows:
            w.writerow([machine, date, commit, fig, f"{v:.3f}", u])
            print(f"{fig}: {v:.3f} {u}")


if __name__ == "__main__":
    main()
