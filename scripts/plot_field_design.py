#!/usr/bin/python3
"""Draws a `vinci field-design` result (docs/planning.md): the simulated field of the best
motion beside the target field, both as quivers on the grid.

usage: scripts/plot_field_design.py DIR [OUT.png]

Reads DIR/field.csv, DIR/target.csv and DIR/result.json; writes OUT.png (default
DIR/field_design.png). Arrows start at the grid points; each panel is scaled to its own RMS
speed (the shape objective compares the fields that way). Points whose part left the plate are
red crosses, failed points black crosses. A circle target's circle is drawn dashed on both panels
(result.json's `target`, absent in results of older versions).
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def load(path):
    return np.atleast_1d(np.genfromtxt(path, delimiter=",", names=True))


def quiver(ax, x, y, vx, vy, title):
    speed = np.hypot(vx, vy)
    rms = np.sqrt(np.mean(speed**2)) if speed.size else 0.0
    scale = rms if rms > 0 else 1.0
    span = max(np.ptp(x), np.ptp(y), 1e-9)
    n = max(int(np.sqrt(x.size)), 2)
    k = 0.8 * span / (n - 1) / scale
    q = ax.quiver(x, y, vx * k, vy * k, speed, angles="xy", scale_units="xy", scale=1,
                  cmap="viridis")
    ax.set_title(title)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    return q


def main(argv):
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    d = argv[1]
    out = argv[2] if len(argv) > 2 else os.path.join(d, "field_design.png")
    field = load(os.path.join(d, "field.csv"))
    target = load(os.path.join(d, "target.csv"))
    with open(os.path.join(d, "result.json")) as f:
        result = json.load(f)
    fig, axes = plt.subplots(1, 2, figsize=(11, 5))
    ok = (field["left_plate"] == 0) & (field["failed"] == 0)
    q = quiver(axes[0], field["x"][ok], field["y"][ok], field["vx"][ok], field["vy"][ok],
               "simulated, field error %.3g (%s)" % (result["field_error"], result["objective"]))
    fig.colorbar(q, ax=axes[0], label="speed (m/s)")
    left = field["left_plate"] != 0
    failed = field["failed"] != 0
    axes[0].plot(field["x"][left], field["y"][left], "rx")
    axes[0].plot(field["x"][failed], field["y"][failed], "kx")
    q = quiver(axes[1], target["x"], target["y"], target["vx"], target["vy"], "target")
    fig.colorbar(q, ax=axes[1], label="speed (target units)")
    target_info = result.get("target", {})
    if target_info.get("type") == "circle":
        c, r = target_info["center"], target_info["radius"]
        for ax in axes:
            ax.add_patch(plt.Circle(c, r, fill=False, linestyle="--", color="0.4"))
    fig.suptitle("%s: %d evaluations, %.1f s" % (os.path.basename(result["spec"]),
                                               result["evaluations"], result["time_s"]))
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
