#!/usr/bin/python3
"""Draws a velocity field written by `vinci field` (docs/field.md) as a quiver image.

usage: scripts/plot_field.py FIELD.csv [OUT.png] [--theory THEORY.csv] [--start]

Arrows sit at each part's mean position over the averaging window (x_mean, y_mean; --start puts
them at the grid start points instead) and show (vx, vy); the colour is the speed. Points whose
part left the plate are drawn as red crosses, failed points as black crosses. A planar field
(one row, y = 0) is drawn as vx against x.
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def load(path):
    data = np.genfromtxt(path, delimiter=",", names=True)
    return np.atleast_1d(data)


def main(argv):
    args = [a for a in argv[1:] if not a.startswith("--")]
    if not args:
        print(__doc__, file=sys.stderr)
        return 2
    field = load(args[0])
    out = args[1] if len(args) > 1 else args[0].rsplit(".", 1)[0] + ".png"
    at_start = "--start" in argv
    ok = (field["left_plate"] == 0) & (field["failed"] == 0)
    x = field["x"] if at_start else np.where(ok, field["x_mean"], field["x"])
    y = field["y"] if at_start else np.where(ok, field["y_mean"], field["y"])
    speed = np.hypot(field["vx"], field["vy"])
    fig, ax = plt.subplots(figsize=(6.5, 5.5))
    planar = np.all(field["y"] == 0) and np.all(field["vy"] == 0) or len(np.unique(field["y"])) == 1
    if planar:
        ax.axhline(0.0, color="0.7", lw=0.8)
        ax.plot(x[ok], field["vx"][ok], "o-", label="simulated")
        ax.set_xlabel("x on the plate (m)")
        ax.set_ylabel("average velocity vx (m/s)")
    else:
        q = ax.quiver(x[ok], y[ok], field["vx"][ok], field["vy"][ok], speed[ok], cmap="viridis",
                      angles="xy")
        fig.colorbar(q, ax=ax, label="speed (m/s)")
        ax.set_aspect("equal")
        ax.set_xlabel("x on the plate (m)")
        ax.set_ylabel("y on the plate (m)")
    left = field["left_plate"] == 1
    failed = field["failed"] == 1
    if left.any():
        ax.plot(field["x"][left], field["y"][left] if not planar else 0 * field["x"][left], "rx",
                label="left the plate")
    if failed.any():
        ax.plot(field["x"][failed], field["y"][failed] if not planar else 0 * field["x"][failed],
                "kx", label="failed")
    if "--theory" in argv:
        theory = load(argv[argv.index("--theory") + 1])
        if planar:
            ax.plot(theory["x"], theory["vx"], "--", label="theory")
        else:
            ax.quiver(theory["x"], theory["y"], theory["vx"], theory["vy"], color="r", alpha=0.5,
                      angles="xy", label="theory")
    if left.any() or failed.any() or "--theory" in argv or planar:
        ax.legend(loc="best", fontsize=8)
    ax.set_title(f"velocity field ({len(field)} points, max speed {np.nanmax(speed[ok]):.3g} m/s)"
                 if ok.any() else "velocity field (no valid point)")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
