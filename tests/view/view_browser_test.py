#!/usr/bin/python3
"""`vinci view` in a real browser (Debian's headless Chromium).

Simulates a bundled scene (a ball dropped onto a floor), writes its page with `vinci view`, and
checks:
  1. the page's data: every CSV row is a frame; with --max-frames the trajectory is decimated
     (first and last rows kept, the step report's peaks kept), not truncated;
  2. the page reports itself ready at the time in its URL fragment (#t=0.5), i.e. three.js and
     the viewer loaded and drew a frame without an error;
  3. screenshots at #t=0 and #t=0.5 are not blank and the ball's pixels moved down the screen
     (it falls 0.9 m between the two times);
  4. the same page with its three.js removed, or with its data corrupted, reports an error: the
     readiness check in 2 cannot pass for a page whose script fails.
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


def ball_mask(rgb):
    """Pixels of the first dynamic body's colour (orange, hue ~26 deg, and its lighter tint)."""
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    mx = np.maximum(np.maximum(r, g), b)
    mn = np.minimum(np.minimum(r, g), b)
    sat = (mx - mn) / np.maximum(mx, 1)
    # Orange: red is the largest channel, blue the smallest, green in between.
    hue_ok = (r == mx) & (b == mn) & (g > b + 0.15 * (r - b)) & (g < b + 0.75 * (r - b))
    return hue_ok & (sat > 0.25) & (mx > 60)


def check_not_blank(rgb, name):
    bg = np.array([0xee, 0xf1, 0xf5])
    differs = np.abs(rgb - bg).sum(axis=2) > 30
    frac = differs.mean()
    colors = len(np.unique(rgb.reshape(-1, 3), axis=0))
    print("%s: %.1f%% of the pixels differ from the background, %d colours" %
          (name, 100 * frac, colors))
    if frac < 0.05 or colors < 50:
        fail(name + " looks blank")


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--vinci", required=True)
    ap.add_argument("--chromium", default="")
    ap.add_argument("--scene", required=True)
    ap.add_argument("--out-dir", required=True)
    a = ap.parse_args()

    if not a.chromium or not os.access(a.chromium, os.X_OK):
        fail("Chromium not found (%r): install it with scripts/setup.sh (Debian package "
             "chromium)" % a.chromium)
    os.makedirs(a.out_dir, exist_ok=True)
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
    state, time, dom = page_state(a.chromium, url + "#t=0.5")
    if state != "ready" or time is None or abs(float(time) - 0.5) > 1e-12:
        fail("expected data-vinci-state=ready at t=0.5, got state %r time %r\n%s" %
             (state, time, dom[:3000]))
    print("page ready at t =", time)

    # 3. Screenshots: not blank, the ball moved down.
    shots = {}
    for t in ("0", "0.5"):
        path = os.path.join(a.out_dir, "ball_drop_t%s.png" % t)
        shots[t] = screenshot(a.chromium, url + "#t=" + t, path)
        check_not_blank(shots[t], path)
    H, W = shots["0"].shape[:2]
    centroids = {}
    for t, rgb in shots.items():
        m = ball_mask(rgb)
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
