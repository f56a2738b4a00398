#!/usr/bin/env python3
"""The inspector page (index.html of `vectorize --debug DIR`) in a real browser.

Runs vectorize on an image, opens DIR/index.html from file:// in headless Chromium driven through
chromedriver's WebDriver HTTP protocol (standard library only), and checks that:
  - the page loads every layer and reports no script error;
  - a layer checkbox changes what is drawn (screenshot pixels of the view before and after);
  - hovering (a real WebDriver pointer move) over a point inside a region taken from regions.json
    shows that region's id, also after zooming in and after panning by a drag;
  - the SVG overlay format loads as well.
A screenshot of each page is saved into the scratch directory.

Exit status: 0 passed, 1 failed, 77 skipped (chromium or chromedriver missing or unable to start).
TRIXEL_CHROMIUM and TRIXEL_CHROMEDRIVER name the programs when they are not on PATH.
"""

import argparse
import base64
import json
import os
import shutil
import socket
import struct
import subprocess
import sys
import time
import urllib.error
import urllib.request
import zlib
from pathlib import Path

SKIP = 77
ELEMENT_KEY = "element-6066-11e4-a52e-4f735466cecf"


class Skip(Exception):
    pass


class Failure(Exception):
    pass


def check(condition, message):
    if not condition:
        raise Failure(message)


# --- PNG decoding (screenshots), enough for what Chromium writes: 8-bit RGB or RGBA ---------------

def decode_png(data):
    check(data[:8] == b"\x89PNG\r\n\x1a\n", "screenshot is not a PNG")
    pos, idat, header = 8, [], None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
    width, height, depth, colour, _, _, interlace = header
    check(depth == 8 and colour in (2, 6) and interlace == 0,
          "unexpected screenshot PNG format (depth %d, colour type %d)" % (depth, colour))
    bpp = 3 if colour == 2 else 4
    raw = zlib.decompress(b"".join(idat))
    stride = width * bpp
    rows, prev, at = [], bytearray(stride), 0
    for _ in range(height):
        kind = raw[at]
        line = bytearray(raw[at + 1:at + 1 + stride])
        at += 1 + stride
        if kind == 1:
            for i in range(bpp, stride):
                line[i] = (line[i] + line[i - bpp]) & 0xFF
        elif kind == 2:
            for i in range(stride):
                line[i] = (line[i] + prev[i]) & 0xFF
        elif kind == 3:
            for i in range(stride):
                left = line[i - bpp] if i >= bpp else 0
                line[i] = (line[i] + ((left + prev[i]) >> 1)) & 0xFF
        elif kind == 4:
            for i in range(stride):
                a = line[i - bpp] if i >= bpp else 0
                b = prev[i]
                c = prev[i - bpp] if i >= bpp else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 0xFF
        rows.append(line)
        prev = line
    return width, height, bpp, rows


def differing_pixels(shot_a, shot_b):
    """Pixels whose RGB differs by more than 8 levels between two screenshots of one size."""
    wa, ha, bpp, rows_a = shot_a
    wb, hb, bpp_b, rows_b = shot_b
    check((wa, ha) == (wb, hb), "screenshots of different sizes")
    n = 0
    for y in range(ha):
        ra, rb = rows_a[y], rows_b[y]
        if ra == rb and bpp == bpp_b:
            continue
        for x in range(wa):
            i, j = x * bpp, x * bpp_b
            if abs(ra[i] - rb[j]) > 8 or abs(ra[i + 1] - rb[j + 1]) > 8 or abs(ra[i + 2] - rb[j + 2]) > 8:
                n += 1
    return n


# --- geometry on regions.json ---------------------------------------------------------------------

def inside(rings, x, y):
    result = False
    for ring in rings:
        n = len(ring)
        j = n - 2
        for i in range(0, n, 2):
            xi, yi, xj, yj = ring[i], ring[i + 1], ring[j], ring[j + 1]
            if (yi > y) != (yj > y) and x < xj + (y - yj) * (xi - xj) / (yi - yj):
                result = not result
            j = i
    return result


def distance_to_rings(rings, x, y):
    best = float("inf")
    for ring in rings:
        n = len(ring)
        for i in range(0, n, 2):
            ax, ay = ring[i], ring[i + 1]
            bx, by = ring[(i + 2) % n], ring[(i + 3) % n]
            dx, dy = bx - ax, by - ay
            length2 = dx * dx + dy * dy
            t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((x - ax) * dx + (y - ay) * dy) / length2))
            px, py = ax + t * dx - x, ay + t * dy - y
            best = min(best, (px * px + py * py) ** 0.5)
    return best


def deepest_point(region, width, height):
    """The pixel centre inside the region farthest from its boundary (a point no rounding can move out)."""
    xs = region["rings"][0][0::2]
    ys = region["rings"][0][1::2]
    x0, x1 = max(0, int(min(xs))), min(width, int(max(xs)) + 1)
    y0, y1 = max(0, int(min(ys))), min(height, int(max(ys)) + 1)
    step = max(1, (x1 - x0) // 48, (y1 - y0) // 48)
    best, best_d = None, 0.0
    for y in range(y0, y1, step):
        for x in range(x0, x1, step):
            cx, cy = x + 0.5, y + 0.5
            if inside(region["rings"], cx, cy):
                d = distance_to_rings(region["rings"], cx, cy)
                if d > best_d:
                    best, best_d = (cx, cy), d
    return best, best_d


# --- WebDriver over HTTP --------------------------------------------------------------------------

class WebDriver:
    def __init__(self, port):
        self.base = "http://127.0.0.1:%d" % port
        self.session = None

    def call(self, method, path, body=None, timeout=30):
        data = None if body is None else json.dumps(body).encode()
        request = urllib.request.Request(self.base + path, data=data, method=method,
                                         headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(request, timeout=timeout) as response:
                return json.loads(response.read().decode() or "{}").get("value")
        except urllib.error.HTTPError as e:
            detail = e.read().decode(errors="replace")
            raise Failure("WebDriver %s %s: HTTP %d %s" % (method, path, e.code, detail[:600]))

    def s(self, method, path, body=None):
        return self.call(method, "/session/%s%s" % (self.session, path), body)

    def script(self, source, *args):
        return self.s("POST", "/execute/sync", {"script": source, "args": list(args)})

    def screenshot(self, css=None):
        """The whole page, or the element matched by css alone."""
        if css is None:
            return base64.b64decode(self.s("GET", "/screenshot"))
        return base64.b64decode(self.s("GET", "/element/%s/screenshot" % self.element(css)))

    def view(self):
        """The image view (#viewport) as decoded pixels: what the layers draw, without the panel."""
        return decode_png(self.screenshot("#viewport"))

    def element(self, css):
        return self.s("POST", "/element", {"using": "css selector", "value": css})[ELEMENT_KEY]

    def click(self, css):
        self.s("POST", "/element/%s/click" % self.element(css), {})

    def pointer(self, steps):
        self.s("POST", "/actions", {"actions": [{"type": "pointer", "id": "mouse",
                                                  "parameters": {"pointerType": "mouse"},
                                                  "actions": steps}]})
        self.s("DELETE", "/actions")

    def move_to(self, x, y):
        self.pointer([{"type": "pointerMove", "duration": 0, "origin": "viewport",
                       "x": int(round(x)), "y": int(round(y))}])


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def find_program(env, names):
    if os.environ.get(env):
        return os.environ[env]
    for name in names:
        found = shutil.which(name)
        if found:
            return found
    return None


def start_browser(scratch):
    chromium = find_program("TRIXEL_CHROMIUM", ["chromium", "chromium-browser", "google-chrome"])
    driver_path = find_program("TRIXEL_CHROMEDRIVER", ["chromedriver"])
    missing = [name for name, path in (("chromium", chromium), ("chromedriver", driver_path)) if not path]
    if missing:
        raise Skip("%s not found on PATH (Debian packages chromium and chromium-driver)" % " and ".join(missing))
    port = free_port()
    log = open(scratch / "chromedriver.log", "w")
    process = subprocess.Popen([driver_path, "--port=%d" % port], stdout=log, stderr=subprocess.STDOUT)
    driver = WebDriver(port)
    deadline = time.time() + 20
    while True:
        if process.poll() is not None:
            raise Skip("chromedriver exited at start (status %s); see %s" % (process.returncode, log.name))
        try:
            if (driver.call("GET", "/status", timeout=2) or {}).get("ready"):
                break
        except (OSError, Failure):
            pass
        if time.time() > deadline:
            process.kill()
            raise Skip("chromedriver did not become ready within 20 s")
        time.sleep(0.1)
    args = ["--headless", "--no-sandbox", "--disable-gpu", "--window-size=1100,720", "--hide-scrollbars",
            "--no-first-run", "--no-default-browser-check", "--disable-extensions",
            "--disable-background-networking", "--disable-component-update", "--disable-sync",
            "--force-device-scale-factor=1", "--user-data-dir=%s" % (scratch / "profile")]
    # Debian's /usr/bin/chromium is a wrapper script around the real program; start that directly.
    if not os.environ.get("TRIXEL_CHROMIUM") and os.access("/usr/lib/chromium/chromium", os.X_OK):
        chromium = "/usr/lib/chromium/chromium"
    options = {"args": args, "binary": chromium}
    try:
        created = driver.call("POST", "/session", {"capabilities": {"alwaysMatch": {
            "browserName": "chrome", "goog:chromeOptions": options}}}, timeout=60)
    except Failure as e:
        process.kill()
        raise Skip("chromium cannot start: %s" % e)
    driver.session = created["sessionId"]
    return driver, process


# --- the checks -----------------------------------------------------------------------------------

def open_page(driver, folder):
    driver.s("POST", "/url", {"url": (folder / "index.html").resolve().as_uri()})
    deadline = time.time() + 20
    while True:
        state = driver.script("return document.body && document.body.dataset.ready || '';")
        if state == "1":
            break
        check(state != "error", "the page failed: %s" % driver.script("return window.inspectorErrors;"))
        check(time.time() < deadline, "the page did not become ready within 20 s")
        time.sleep(0.1)
    errors = driver.script("return window.inspectorErrors;")
    check(errors == [], "script errors in the page: %s" % errors)
    loaded = driver.script(
        "return Array.from(document.querySelectorAll('#stage img.layer')).map("
        "i => [i.dataset.layer, i.complete, i.naturalWidth, i.naturalHeight]);")
    return loaded


def view_box(driver):
    r = driver.script("const r = document.getElementById('viewport').getBoundingClientRect();"
                      "return [r.left, r.top, r.right, r.bottom, window.devicePixelRatio];")
    return [v * r[4] for v in r[:4]]


def client_point(driver, data, x, y):
    r = driver.script("const r = document.getElementById('stage').getBoundingClientRect();"
                      "return [r.left, r.top, r.width, r.height];")
    return r[0] + x * r[2] / data["width"], r[1] + y * r[3] / data["height"]


def hovered_region(driver):
    region = driver.script("return document.getElementById('hover-info').dataset.region;")
    shown = driver.script("const e = document.getElementById('hover-region'); return e ? e.textContent : '';")
    return region, shown


def hover_and_check(driver, data, region, point, when):
    cx, cy = client_point(driver, data, *point)
    driver.move_to(cx, cy)
    got, shown = hovered_region(driver)
    check(got == str(region["id"]),
          "%s: pointer at image (%.1f, %.1f) = client (%.0f, %.0f) should show region %d, the page shows %r"
          % (when, point[0], point[1], cx, cy, region["id"], got))
    check(shown == "Region %d" % region["id"], "%s: the panel reads %r" % (when, shown))


def check_png_folder(driver, folder, scratch):
    data = json.loads((folder / "regions.json").read_text())
    loaded = open_page(driver, folder)
    check(len(loaded) == len(data["layers"]), "expected %d layers, the page has %d" % (len(data["layers"]), len(loaded)))
    for key, complete, w, h in loaded:
        check(complete and (w, h) == (data["width"], data["height"]),
              "layer %s did not load at %dx%d (got %sx%s)" % (key, data["width"], data["height"], w, h))

    # A layer checkbox changes what is drawn.
    before = driver.view()
    visible = driver.script("return document.getElementById('layer-04-cdt').checked;")
    check(visible, "the CDT layer should be on at first")
    driver.click("#layer-04-cdt")
    after = driver.view()
    changed = differing_pixels(before, after)
    check(changed > 2000, "unticking the CDT layer changed only %d pixels of the view" % changed)
    driver.click("#layer-04-cdt")
    again = driver.view()
    check(differing_pixels(before, again) < changed / 20,
          "ticking the CDT layer again did not bring the same picture back")
    print("layer toggle: %d view pixels changed" % changed)

    # Hovering inside regions shows their ids: the largest region, a small one and one between.
    # Regions with a point well inside (thin anti-aliasing rims have none): the largest, the median and
    # the smallest of them, opaque ones first (they are what the SVG draws).
    candidates = []
    for region in data["regions"]:
        if region["rings"]:
            point, depth = deepest_point(region, data["width"], data["height"])
            if point is not None and depth >= 2.0:
                candidates.append((region, point))
    candidates.sort(key=lambda c: (c[0]["transparent"], -c[0]["area"]))
    opaque = [c for c in candidates if not c[0]["transparent"]] or candidates
    check(len(opaque) >= 3, "expected at least 3 regions with a point 2 px inside in regions.json")
    picks = [opaque[0], opaque[len(opaque) // 2], opaque[-1]]
    if candidates[0][0]["transparent"] or candidates[-1][0]["transparent"]:
        picks.append(next(c for c in candidates if c[0]["transparent"]))
    targets = [c for k, c in enumerate(picks) if all(c[0]["id"] != q[0]["id"] for q in picks[:k])]
    for region, point in targets:
        hover_and_check(driver, data, region, point, "fitted view")
    print("hover: regions %s found at their deepest points" % [r["id"] for r, _ in targets])

    # Zoomed in around the first target: the pointer still names the region under it.
    driver.click("#zoom-in")
    driver.click("#zoom-in")
    scale = driver.script("return document.getElementById('stage').getBoundingClientRect().width;") / data["width"]
    for region, point in targets:
        cx, cy = client_point(driver, data, *point)
        vb = [v for v in view_box(driver)]
        if vb[0] + 5 < cx < vb[2] - 5 and vb[1] + 5 < cy < vb[3] - 5:
            hover_and_check(driver, data, region, point, "zoomed to %.2fx" % scale)

    # Drag to pan: the image moves with the pointer and hovering still agrees.
    left_before = driver.script("return document.getElementById('stage').getBoundingClientRect().left;")
    vb = view_box(driver)
    sx, sy = (vb[0] + vb[2]) / 2, (vb[1] + vb[3]) / 2
    driver.pointer([{"type": "pointerMove", "duration": 0, "origin": "viewport", "x": int(sx), "y": int(sy)},
                    {"type": "pointerDown", "button": 0},
                    {"type": "pointerMove", "duration": 100, "origin": "viewport", "x": int(sx) + 120, "y": int(sy)},
                    {"type": "pointerUp", "button": 0}])
    left_after = driver.script("return document.getElementById('stage').getBoundingClientRect().left;")
    check(abs(left_after - left_before - 120) < 2, "dragging by 120 px moved the image by %.1f px" % (left_after - left_before))
    driver.click("#zoom-fit")
    hover_and_check(driver, data, targets[0][0], targets[0][1], "after pan and fit")

    # An opacity slider fades its layer: the input at 0 % changes the picture.
    before = driver.view()
    driver.script("const r = document.getElementById('opacity-input'); r.value = '0';"
                  "r.dispatchEvent(new Event('input'));")
    opacity = driver.script("return getComputedStyle(document.querySelector('img[data-layer=input]')).opacity;")
    check(opacity == "0", "the input layer's opacity is %r after its slider went to 0" % opacity)
    changed = differing_pixels(before, driver.view())
    check(changed > 2000, "the input at opacity 0 changed only %d pixels" % changed)
    driver.script("const r = document.getElementById('opacity-input'); r.value = '55';"
                  "r.dispatchEvent(new Event('input'));")

    shot = scratch / "inspector-png.png"
    shot.write_bytes(driver.screenshot())
    print("screenshot: %s" % shot)


def check_svg_folder(driver, folder, scratch):
    data = json.loads((folder / "regions.json").read_text())
    loaded = open_page(driver, folder)
    for key, complete, w, h in loaded:
        check(complete and w > 0 and h > 0, "SVG layer %s did not load" % key)
    before = driver.view()
    driver.click("#layer-07-polygons")
    after = driver.view()
    changed = differing_pixels(before, after)
    check(changed > 500, "ticking the polygons layer (SVG) changed only %d pixels" % changed)
    region = max((r for r in data["regions"] if r["rings"] and not r["transparent"]), key=lambda r: r["area"])
    point, depth = deepest_point(region, data["width"], data["height"])
    check(point is not None and depth >= 2.0, "no point well inside region %d" % region["id"])
    hover_and_check(driver, data, region, point, "SVG layers")
    shot = scratch / "inspector-svg.png"
    shot.write_bytes(driver.screenshot())
    print("screenshot: %s" % shot)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vectorize", required=True, help="the vectorize program")
    parser.add_argument("--input", required=True, help="an image to convert")
    parser.add_argument("--scratch", required=True, help="a directory for the outputs (emptied first)")
    args = parser.parse_args()

    scratch = Path(args.scratch)
    shutil.rmtree(scratch, ignore_errors=True)
    scratch.mkdir(parents=True)
    folders = {}
    for fmt in ("png", "svg"):
        folders[fmt] = scratch / ("debug-" + fmt)
        result = subprocess.run([args.vectorize, args.input, str(scratch / ("out-%s.svg" % fmt)), "--preset", "logo",
                                 "--debug", str(folders[fmt]), "--debug-format", fmt],
                                capture_output=True, text=True, timeout=120)
        if result.returncode != 0:
            print("FAILED: vectorize --debug exited with %d:\n%s%s" % (result.returncode, result.stdout, result.stderr))
            return 1

    driver = process = None
    try:
        driver, process = start_browser(scratch)
        check_png_folder(driver, folders["png"], scratch)
        check_svg_folder(driver, folders["svg"], scratch)
    except Skip as e:
        print("SKIPPED: the browser test needs Chromium and chromedriver: %s" % e)
        return SKIP
    except Failure as e:
        print("FAILED: %s" % e)
        if driver is not None and driver.session is not None:
            try:
                (scratch / "failure.png").write_bytes(driver.screenshot())
                print("screenshot at the failure: %s" % (scratch / "failure.png"))
            except Failure:
                pass
        return 1
    finally:
        if driver is not None and driver.session is not None:
            try:
                driver.call("DELETE", "/session/%s" % driver.session, timeout=10)
            except (Failure, OSError):
                pass
        if process is not None:
            process.terminate()
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
    print("PASSED: inspector page in headless Chromium")
    return 0


if __name__ == "__main__":
    sys.exit(main())
