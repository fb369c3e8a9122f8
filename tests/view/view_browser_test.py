#!/usr/bin/python3
"""`vinci view` in a real browser (Debian's headless Chromium). Three modes:

ball-drop  Simulates a bundled scene (a ball dropped onto a floor), writes its page and checks:
  1. the page's data: every CSV row is a frame; with --max-frames the trajectory is decimated
     (first and last rows kept, the step report's peaks kept), not truncated;
  2. the page reports itself ready at the time in its URL fragment (#t=0.5), i.e. three.js and
     the viewer loaded and drew a frame without an error; with #t=0.1&play it plays on;
  3. screenshots at #t=0 and #t=0.5 are not blank and the ball's pixels moved down the screen
     (it falls 0.9 m between the two times);
  4. the same page with its three.js removed, or with its data corrupted, reports an error: the
     readiness check in 2 cannot pass for a page whose script fails.
shapes     The page of a scene without trajectory is ready, and every dynamic body's colour
           (the viewer's palette, in scene order) covers some pixels: each shape kind is drawn.
field      A plate scene's page with a velocity field (vinci field) is ready, and its screenshot
           differs from the one with the field hidden (#field=0): the arrows are drawn.
Exits non-zero with a message on the first failed check. Chromium missing is a failure
(scripts/setup.sh installs it), never a skip.
"""
import argparse
import csv
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import matplotlib.image

WINDOW = (960, 540)  # screenshot size (px)
# Virtual time Chromium grants the page before it dumps the DOM or takes the screenshot (ms):
# the page draws its first frame synchronously on load, this only has to cover loading.
VIRTUAL_TIME_MS = 5000
CHROMIUM_TIMEOUT_S = 90


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def run(cmd, **kw):
    print("+ " + " ".join(cmd), flush=True)
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        fail("command failed with exit code %d: %s\nstdout:\n%s\nstderr:\n%s" %
             (r.returncode, " ".join(cmd), r.stdout, r.stderr))
    return r


def chromium(args, chromium_path, url):
    with tempfile.TemporaryDirectory(prefix="vinci-view-chromium-") as profile:
        cmd = [chromium_path, "--headless", "--no-sandbox", "--disable-gpu",
               "--enable-unsafe-swiftshader", "--disable-quic", "--no-first-run",
               "--disable-background-networking", "--disable-component-update", "--disable-sync",
               "--hide-scrollbars", "--user-data-dir=" + profile,
               "--window-size=%d,%d" % WINDOW, "--virtual-time-budget=%d" % VIRTUAL_TIME_MS
               ] + args + [url]
        return run(cmd, timeout=CHROMIUM_TIMEOUT_S)


def page_state(chromium_path, url):
    """(data-vinci-state, data-vinci-time, DOM) of the page at url after loading."""
    dom = chromium(["--dump-dom"], chromium_path, url).stdout
    body = re.search(r"<body[^>]*>", dom)
    if not body:
        fail("no <body> in the DOM of " + url + ":\n" + dom[:2000])
    state = re.search(r'data-vinci-state="([^"]*)"', body.group(0))
    time = re.search(r'data-vinci-time="([^"]*)"', body.group(0))
    return (state.group(1) if state else None, time.group(1) if time else None, dom)


def screenshot(chromium_path, url, path):
    if os.path.exists(path):
        os.remove(path)
    chromium(["--screenshot=" + path], chromium_path, url)
    if not os.path.exists(path):
        fail("chromium wrote no screenshot " + path)
    img = matplotlib.image.imread(path)  # float RGB(A) in [0, 1]
    return (img[:, :, :3] * 255).round().astype(np.int32)


def page_data(html_path):
    text = open(html_path, encoding="utf-8").read()
    m = re.search(r'<script type="application/json" id="vinci-data">(.*?)</script>', text, re.S)
    if not m:
        fail("no vinci-data script in " + html_path)
    return json.loads(m.group(1)), text


# The viewer's colours of dynamic bodies (cli/view/viewer.js, kDynamicColors), in order.
PALETTE = [0xe8833a, 0x3a9ad9, 0x4caf50, 0x9c5fc7, 0xd94c6a, 0x2bb5a6, 0xc9a227, 0x6d7fd6]
HUE_TOLERANCE_DEG = 10  # shading keeps the hue of a body's colour (and of its lighter tint)


def hue_saturation(rgb):
    f = rgb.astype(np.float64) / 255.0
    mx, mn = f.max(axis=2), f.min(axis=2)
    c = mx - mn
    r, g, b = f[..., 0], f[..., 1], f[..., 2]
    safe = np.where(c > 0, c, 1)
    h = np.where(mx == r, ((g - b) / safe) % 6, np.where(mx == g, (b - r) / safe + 2,
                                                           (r - g) / safe + 4)) * 60
    return h, np.where(mx > 0, c / np.where(mx > 0, mx, 1), 0)


def color_mask(rgb, color):
    """Pixels of the hue of `color` (saturated, so not the grey floor, edges or background)."""
    h, s = hue_saturation(rgb)
    ref_h, _ = hue_saturation(np.array([[[color >> 16, (color >> 8) & 255, color & 255]]]))
    d = np.abs((h - ref_h[0, 0] + 180) % 360 - 180)
    return (d < HUE_TOLERANCE_DEG) & (s > 0.3)


def color_pixels(rgb, color):
    return int(color_mask(rgb, color).sum())


def check_not_blank(rgb, name):
    bg = np.array([0xee, 0xf1, 0xf5])
    differs = np.abs(rgb - bg).sum(axis=2) > 30
    frac = differs.mean()
    colors = len(np.unique(rgb.reshape(-1, 3), axis=0))
    print("%s: %.1f%% of the pixels differ from the background, %d colours" %
          (name, 100 * frac, colors))
    if frac < 0.05 or colors < 50:
        fail(name + " looks blank")


def check_ready(a, url, t):
    state, time, dom = page_state(a.chromium, url + "#t=" + t)
    if state != "ready" or time is None or abs(float(time) - float(t)) > 1e-12:
        fail("expected data-vinci-state=ready at t=%s, got state %r time %r\n%s" %
             (t, state, time, dom[:3000]))
    print("page ready at t =", time)


def shapes(a):
    name = os.path.splitext(os.path.basename(a.scene))[0]
    html = os.path.join(a.out_dir, name + ".html")
    run([a.vinci, "view", a.scene, "--out", html, "--quiet"])
    url = "file://" + os.path.abspath(html)
    check_ready(a, url, "0")
    rgb = screenshot(a.chromium, url, os.path.join(a.out_dir, name + ".png"))
    check_not_blank(rgb, name)
    rgb = rgb[: rgb.shape[0] - 60]  # above the controls
    data, _ = page_data(html)
    dynamic = [b for b in data["scene"]["bodies"] if b["kind"] == "dynamic"]
    for i, b in enumerate(dynamic):
        n = color_pixels(rgb, PALETTE[i % len(PALETTE)])
        print("%s (%s): %d px of its colour" % (b["name"], b["shapes"][0]["type"], n))
        if n < 30:
            fail("body %s (%s) is not drawn: %d px of its colour #%06x" %
                 (b["name"], b["shapes"][0]["type"], n, PALETTE[i % len(PALETTE)]))
    print("OK")


def field(a):
    csv_path = os.path.join(a.out_dir, "field.csv")
    run([a.vinci, "field", a.scene, "--grid", "7", "--cycles", "2", "--average-cycles", "1",
         "--quiet", "--out", csv_path])
    html = os.path.join(a.out_dir, "field.html")
    run([a.vinci, "view", a.scene, "--field", csv_path, "--out", html, "--quiet"])
    url = "file://" + os.path.abspath(html)
    check_ready(a, url, "0")
    # The same page with the field hidden by its fragment: only the arrows differ.
    shots = [screenshot(a.chromium, url + frag, os.path.join(a.out_dir, name))
             for frag, name in (("#t=0", "field.png"), ("#t=0&field=0", "field_hidden.png"))]
    H = shots[0].shape[0]
    diff = (np.abs(shots[0] - shots[1]).sum(axis=2) > 60)[: H - 60]  # above the controls
    print("field arrows: %d px differ" % diff.sum())
    if diff.sum() < 200:
        fail("the page with --field looks like the page without: %d px differ" % diff.sum())
    print("OK")


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("mode", choices=["ball-drop", "shapes", "field"])
    ap.add_argument("--vinci", required=True)
    ap.add_argument("--chromium", default="")
    ap.add_argument("--scene", required=True)
    ap.add_argument("--out-dir", required=True)
    a = ap.parse_args()

    if not a.chromium or not os.access(a.chromium, os.X_OK):
        fail("Chromium not found (%r): install it with scripts/setup.sh (Debian package "
             "chromium)" % a.chromium)
    os.makedirs(a.out_dir, exist_ok=True)
    {"ball-drop": ball_drop, "shapes": shapes, "field": field}[a.mode](a)


def ball_drop(a):
    traj = os.path.join(a.out_dir, "ball_drop.csv")
    html = os.path.join(a.out_dir, "ball_drop.html")
    run([a.vinci, "simulate", a.scene, "--quiet", "--out", traj])
    rows = list(csv.DictReader(open(traj)))
    run([a.vinci, "view", a.scene, traj, "--out", html])

    # 1. Data: all rows, then decimated.
    data, _ = page_data(html)
    tr = data["trajectory"]
    if tr["rows"] != len(rows) or tr["frames"] != len(rows):
        fail("expected %d rows as frames, got rows %d frames %d" % (len(rows), tr["rows"],
                                                                     tr["frames"]))
    html50 = os.path.join(a.out_dir, "ball_drop_50.html")
    run([a.vinci, "view", a.scene, traj, "--max-frames", "50", "--out", html50, "--quiet"])
    d50, _ = page_data(html50)
    t50 = d50["trajectory"]
    if t50["frames"] != 50 or len(t50["t"]) != 50 or t50["rows"] != len(rows):
        fail("--max-frames 50: expected 50 frames of %d rows, got %d" % (len(rows), t50["frames"]))
    if t50["t"][0] != float(rows[0]["t"]) or abs(t50["t"][-1] - float(rows[-1]["t"])) > 1e-9:
        fail("decimation must keep the first and last rows: t = %g..%g, CSV %s..%s" %
             (t50["t"][0], t50["t"][-1], rows[0]["t"], rows[-1]["t"]))
    if any(b <= a_ for a_, b in zip(t50["step"], t50["step"][1:])):
        fail("decimated frames must be increasing steps")
    max_csv = max(int(r["contacts"]) for r in rows)
    max_50 = max(t50["report"]["contacts"])
    if max_50 != max_csv:
        fail("the decimated report must keep the peak contact count %d, got %d" % (max_csv, max_50))
    ball = [b["name"] for b in d50["scene"]["bodies"]].index("ball")
    z50 = t50["poses"][ball][2::7]
    z_csv = {int(r["step"]): float(r["ball.z"]) for r in rows}
    for s, z in zip(t50["step"], z50):
        if abs(z - z_csv[s]) > 1e-6:
            fail("frame of step %d: ball.z %g, CSV %g" % (s, z, z_csv[s]))

    # 2. Ready at the fragment's time.
    url = "file://" + os.path.abspath(html)
    check_ready(a, url, "0.5")

    # Playing (#play) advances the time drawn, without an error, up to at most the end.
    state, time, dom = page_state(a.chromium, url + "#t=0.1&play")
    if state != "ready" or time is None or not (0.1 < float(time) <= float(rows[-1]["t"])):
        fail("#t=0.1&play: expected ready with 0.1 < t <= the end, got state %r time %r\n%s" %
             (state, time, dom[:3000]))
    print("playing from t = 0.1: drawn t =", time)

    # 3. Screenshots: not blank, the ball moved down.
    shots = {}
    for t in ("0", "0.5"):
        path = os.path.join(a.out_dir, "ball_drop_t%s.png" % t)
        shots[t] = screenshot(a.chromium, url + "#t=" + t, path)
        check_not_blank(shots[t], path)
    H, W = shots["0"].shape[:2]
    centroids = {}
    for t, rgb in shots.items():
        m = color_mask(rgb[: H - 60], PALETTE[0])  # the first dynamic body, above the controls
        if m.sum() < 100:
            fail("t=%s: expected the ball's orange pixels, found %d" % (t, m.sum()))
        ys, xs = np.nonzero(m)
        centroids[t] = (xs.mean(), ys.mean())
        print("t=%s: ball %d px, centroid (%.1f, %.1f)" % (t, m.sum(), xs.mean(), ys.mean()))
    dx = centroids["0.5"][0] - centroids["0"][0]
    dy = centroids["0.5"][1] - centroids["0"][1]
    # The ball falls 0.9 m, about 4/5 of the framed height: far more than 15% of the image.
    if dy < 0.15 * H:
        fail("the ball must move down the screen between t=0 and t=0.5: dy = %.1f px" % dy)
    if abs(dx) > 0.1 * W:
        fail("the ball falls straight down; its centroid moved sideways by %.1f px" % dx)

    # 4. A page whose script fails must not report ready.
    _, text = page_data(html)
    start = text.index("<script>\n", text.index('id="vinci-data"')) + len("<script>\n")
    end = text.index("</script>", start)
    broken = {"no_three": text[:start] + "/* three.js removed */\n" + text[end:],
              "bad_data": text.replace('"format":"vinci-view-1"', '"format":vinci-view-1', 1)}
    for name, content in broken.items():
        path = os.path.join(a.out_dir, "broken_%s.html" % name)
        open(path, "w", encoding="utf-8").write(content)
        state, _, _ = page_state(a.chromium, "file://" + os.path.abspath(path) + "#t=0.5")
        if state != "error":
            fail("a page with %s must report data-vinci-state=error, got %r" % (name, state))
        print("broken page (%s): state %s" % (name, state))
    print("OK")


if __name__ == "__main__":
    main()
