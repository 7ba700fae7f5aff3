#!/usr/bin/python3
"""Opens postproc's HTML reports in headless Chromium through WebDriver and checks that they render.

Usage: html_render.py OUT_DIR KIND=PAGE.html…
KIND is diff (with a machine), diff-predict (with --predict), diff-plain (no machine), predict,
compensate (geometric mode; its PAGE.json is the run's --json, whose before / after figures the page
must show) or compensate-all (--mode all: the contour report with the geometric part).
For diff pages, PAGE.json and PAGE.err (the same run's --json and stderr) are compared with the
figures shown. Per page: no SEVERE console entries, no resource loads beyond the page itself, the
expected element ids, drawn SVG content, a 3-D canvas that draws and redraws when dragged, and a
full-page screenshot (OUT_DIR/<page>.png) that is not blank. Exit code 0 when every page passes,
1 otherwise (every failure is printed).

Needs Debian's python3-selenium and python3-pil, /usr/bin/chromium and /usr/bin/chromedriver.
"""
import base64
import io
import json
import os
import re
import sys
import tempfile

from PIL import Image
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By

DIFF_IDS = ["summary", "projection-xy", "projection-xz", "projection-yz", "view3d", "view3d-data", "along-path",
            "histogram", "worst"]
EXPECTED = {
    "diff": DIFF_IDS + ["along-path-angle", "angle-max-arcsec"],
    "diff-predict": DIFF_IDS + ["along-path-angle", "contour", "contour-summary", "contour-tip", "contour-axis"],
    "diff-plain": DIFF_IDS,
    "predict": ["summary", "figures", "worst", "worst_axis"],
    "compensate": ["summary", "figures", "reduction", "tip_along", "axis_along", "residual_along", "hist_before",
                   "hist_after", "worst_before", "worst_after", "before-tip-max-um", "after-tip-max-um"],
    # --mode all: the contour report with the geometric part after it (ids prefixed).
    "compensate-all": ["summary", "figures", "worst", "geometric-title", "geometric-figures", "geometric-reduction",
                       "geometric-tip_along", "geometric-hist_before", "geometric-worst_after",
                       "geometric-before-tip-max-um"],
}
ABSENT = {"diff-plain": ["along-path-angle", "angle-max-arcsec"], "diff": ["contour"]}

failures = []


def fail(page, what):
    failures.append(f"{os.path.basename(page)}: {what}")
    print(f"FAIL: {os.path.basename(page)}: {what}")


def make_driver(profile):
    opts = webdriver.ChromeOptions()
    opts.binary_location = "/usr/bin/chromium"
    for a in ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
              "--disable-background-networking", "--disable-component-update", "--disable-sync",
              "--disable-dev-shm-usage", "--window-size=1280,1000", f"--user-data-dir={profile}"]:
        opts.add_argument(a)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(executable_path="/usr/bin/chromedriver"), options=opts)


CANVAS_PIXELS = """
const c = document.getElementById(arguments[0]);
if (!c || !c.getContext) return -1;
const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
let n = 0;  // pixels in colour (the path), not white nor the grey of the axis labels
for (let i = 0; i < d.length; i += 4)
  if (d[i + 3] > 0 && Math.max(d[i], d[i + 1], d[i + 2]) - Math.min(d[i], d[i + 1], d[i + 2]) > 60) n++;
return n;
"""


def check_canvas(driver, page, cid):
    drawn = driver.execute_script(CANVAS_PIXELS, cid)
    if drawn is None or drawn < 200:
        fail(page, f"3-D canvas #{cid} has {drawn} coloured pixels")
    before = driver.execute_script("return document.getElementById(arguments[0]).toDataURL();", cid)
    canvas = driver.find_element(By.ID, cid)
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'});", canvas)
    ActionChains(driver).move_to_element(canvas).click_and_hold().move_by_offset(90, 40).release().perform()
    after = driver.execute_script("return document.getElementById(arguments[0]).toDataURL();", cid)
    if before == after:
        fail(page, f"dragging the 3-D canvas #{cid} did not change it")
    if driver.execute_script(CANVAS_PIXELS, cid) < 200:
        fail(page, "the 3-D canvas is blank after dragging")


def check_svgs(driver, page, kind):
    stats = driver.execute_script("""
        return Array.from(document.querySelectorAll('svg.plot')).map(s => ({
          id: s.id, w: s.getBoundingClientRect().width,
          lines: s.querySelectorAll('polyline, path, circle').length,
          rects: s.querySelectorAll('rect').length}));""")
    if len(stats) < (4 if kind == "predict" else 5):
        fail(page, f"only {len(stats)} SVG plots")
    for s in stats:
        if s["w"] <= 0:
            fail(page, f"SVG {s['id'] or '(no id)'} is not laid out")
        drawn = s["rects"] - 1 if "hist" in s["id"] else s["lines"]
        if drawn <= 0:
            fail(page, f"SVG {s['id'] or '(no id)'} draws nothing")


def screenshot(driver, page, out_dir):
    w = driver.execute_script("return Math.max(document.documentElement.scrollWidth, document.body.scrollWidth);")
    h = driver.execute_script("return Math.max(document.documentElement.scrollHeight, document.body.scrollHeight);")
    shot = driver.execute_cdp_cmd("Page.captureScreenshot", {
        "format": "png", "captureBeyondViewport": True,
        "clip": {"x": 0, "y": 0, "width": w, "height": h, "scale": 1}})
    png = base64.b64decode(shot["data"])
    name = os.path.join(out_dir, os.path.basename(page) + ".png")
    with open(name, "wb") as f:
        f.write(png)
    img = Image.open(io.BytesIO(png)).convert("RGB")
    small = img.copy()
    small.thumbnail((600, 6000))
    colours = len(set(small.getdata()))
    non_white = sum(1 for p in small.getdata() if min(p) < 245)
    if img.height < 1000 or colours < 16 or non_white < 0.01 * small.width * small.height:
        fail(page, f"screenshot {img.width}×{img.height} looks blank ({colours} colours, {non_white} non-white pixels)")
    return img.width, img.height, colours


def text(driver, eid):
    found = driver.find_elements(By.ID, eid)
    return found[0].text.strip() if found else None


def check_figures(driver, page, kind):
    """The figures shown equal those of the same run's JSON and stderr."""
    stem = page[:-len(".html")]
    try:
        with open(stem + ".json") as f:
            j = json.load(f)
        with open(stem + ".err") as f:
            err = f.read()
    except OSError as e:
        fail(page, f"no JSON / stderr of the run: {e}")
        return
    want = {"max-um": f"{j['deviation']['max_um']:.3f}", "rms-um": f"{j['deviation']['rms_um']:.3f}",
            "p95-um": f"{j['deviation']['p95_um']:.3f}", "pairs": str(j["pairs"]), "changed": str(j["changed"]),
            "unmatched": str(j["unmatched"]), "aligned": j["aligned"],
            "motions-original": str(j["motions"]["original"]), "motions-corrected": str(j["motions"]["corrected"])}
    if "axis_angle" in j:
        want["angle-max-arcsec"] = f"{j['axis_angle']['max_arcsec']:.2f}"
        want["angle-rms-arcsec"] = f"{j['axis_angle']['rms_arcsec']:.2f}"
    if kind == "diff-predict":
        for prog in ("original", "corrected"):
            want[f"contour-{prog}-tip-max-um"] = f"{j['predicted'][prog]['tip_um']['max']:.3f}"
            want[f"contour-{prog}-axis-max-arcsec"] = f"{j['predicted'][prog]['axis_arcsec']['max']:.2f}"
    for eid, value in want.items():
        shown = text(driver, eid)
        if shown != value:
            fail(page, f"#{eid} shows {shown!r}, the JSON says {value!r}")
    m = re.search(r"max ([0-9.]+) µm, RMS ([0-9.]+) µm, p95 ([0-9.]+) µm", err)
    if not m or (m.group(1), m.group(2), m.group(3)) != (want["max-um"], want["rms-um"], want["p95-um"]):
        fail(page, f"stderr summary {m.groups() if m else None} differs from the page")
    if kind == "diff-predict":
        for prog in ("original", "corrected"):
            m = re.search(rf"predicted contour error, {prog}: tool tip max ([0-9.]+) µm", err)
            if not m or m.group(1) != want[f"contour-{prog}-tip-max-um"]:
                fail(page, f"stderr's predicted {prog} tip error {m.group(1) if m else None} differs from the page")


def check_compensate_figures(driver, page):
    """The before / after figures shown equal those of the same run's JSON (geometric compensate: the
    error before on the calibrated machine, and the residual after, from the written program)."""
    try:
        with open(page[:-len(".html")] + ".json") as f:
            fig = json.load(f)["figures"]
    except (OSError, KeyError) as e:
        fail(page, f"no JSON of the run: {e}")
        return
    want = {"before-tip-max-um": f"{fig['max_error_before_mm'] * 1000:.3f}",
            "after-tip-max-um": f"{fig['max_residual_after_mm'] * 1000:.3f}",
            "before-axis-max-arcsec": f"{fig['max_error_before_deg'] * 3600:.2f}"}
    for eid, value in want.items():
        shown = text(driver, eid)
        if shown != value:
            fail(page, f"#{eid} shows {shown!r}, the JSON says {value!r}")
    if float(want["after-tip-max-um"]) >= float(want["before-tip-max-um"]):
        fail(page, "the compensated program's error is not below the original's")


def check_page(driver, kind, page, out_dir):
    failed_before = len(failures)
    driver.get_log("browser")  # drop what earlier pages left
    driver.get("file://" + os.path.abspath(page))
    driver.execute_script("return document.readyState")
    for entry in driver.get_log("browser"):
        if entry.get("level") == "SEVERE":
            fail(page, f"console: {entry.get('message')}")
    resources = driver.execute_script(
        "return performance.getEntriesByType('resource').map(e => e.name);")
    for r in resources:
        if not r.startswith("data:"):
            fail(page, f"loads a resource: {r}")
    refs = driver.execute_script("""
        return Array.from(document.querySelectorAll('[src], [href]'))
          .map(e => e.getAttribute('src') || e.getAttribute('href'))
          .filter(u => !u.startsWith('data:') && !u.startsWith('#'));""")
    for r in refs:
        fail(page, f"references {r}")
    for eid in EXPECTED[kind]:
        if not driver.find_elements(By.ID, eid):
            fail(page, f"element #{eid} missing")
    for eid in ABSENT.get(kind, []):
        if driver.find_elements(By.ID, eid):
            fail(page, f"element #{eid} should not be there")
    check_svgs(driver, page, kind)
    if kind.startswith("diff"):
        check_canvas(driver, page, "view3d")
        check_figures(driver, page, kind)
    if kind == "compensate":
        check_compensate_figures(driver, page)
    # Interaction must not log errors either.
    for entry in driver.get_log("browser"):
        if entry.get("level") == "SEVERE":
            fail(page, f"console after interaction: {entry.get('message')}")
    w, h, colours = screenshot(driver, page, out_dir)
    verdict = "passed" if len(failures) == failed_before else f"FAILED ({len(failures) - failed_before} checks)"
    print(f"{kind}: {os.path.basename(page)}: {verdict}; screenshot {w}×{h} px, {colours} colours")


def main(argv):
    if len(argv) < 3:
        print(__doc__)
        return 64
    out_dir = argv[1]
    pages = []
    for spec in argv[2:]:
        kind, _, page = spec.partition("=")
        if kind not in EXPECTED or not page:
            print(f"bad page spec {spec!r}")
            return 64
        pages.append((kind, page))
    with tempfile.TemporaryDirectory(prefix="postproc-chromium-") as profile:
        driver = make_driver(profile)
        try:
            for kind, page in pages:
                try:
                    check_page(driver, kind, page, out_dir)
                except Exception as e:  # a WebDriver failure on one page fails that page
                    fail(page, f"{type(e).__name__}: {e}")
        finally:
            driver.quit()
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
