#!/usr/bin/python3
"""Draws a `vinci plan` result (docs/planning.md): every part's path on the plate in the
re-simulation, its start (circle), its goal (the tolerance disc) and where it ended (cross).

usage: scripts/plot_plan.py plan.json [OUT.png]

Reads plan.json and the trajectory CSV it names (the `vinci simulate` columns: PART.x, PART.y,
PART.z world positions); writes OUT.png (default: plan.json with extension .png). Positions are
drawn in the plate's initial frame, which the bundled plate scenes put at the world origin.
"""
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Circle, Rectangle  # noqa: E402


def main():
    if len(sys.argv) not in (2, 3):
        print(__doc__, file=sys.stderr)
        return 2
    plan_path = sys.argv[1]
    out = sys.argv[2] if len(sys.argv) == 3 else os.path.splitext(plan_path)[0] + ".png"
    with open(plan_path) as f:
        plan = json.load(f)
    traj = plan["trajectory"]
    if not os.path.isabs(traj) and not os.path.exists(traj):
        traj = os.path.join(os.path.dirname(plan_path), os.path.basename(traj))
    parts = list(plan["goals"].keys())
    xs = {p: [] for p in parts}
    ys = {p: [] for p in parts}
    with open(traj) as f:
        for row in csv.DictReader(f):
            for p in parts:
                xs[p].append(float(row[p + ".x"]))
                ys[p].append(float(row[p + ".y"]))
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    ext = plan["plate_extent"]
    ax.add_patch(Rectangle((ext["x"][0], ext["y"][0]), ext["x"][1] - ext["x"][0],
                           ext["y"][1] - ext["y"][0], fill=False, color="0.5", lw=1.5))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, p in enumerate(parts):
        c = colors[i % len(colors)]
        g = plan["goals"][p]
        ax.plot(xs[p], ys[p], color=c, lw=1.2, label=p)
        ax.plot(xs[p][0], ys[p][0], "o", color=c, mfc="none", ms=8)
        ax.add_patch(Circle(g["position"], g["tolerance"], color=c, alpha=0.25))
        ax.plot(*g["position"], "+", color=c, ms=10)
        ax.plot(xs[p][-1], ys[p][-1], "x", color=c, ms=8)
    steps = " ".join("%s×%d" % (s["primitive"], s["cycles"]) for s in plan["steps"])
    if len(steps) > 90:
        steps = steps[:87] + "..."
    ax.set_title("%s (%s): %s, %d steps\n%s" % (
        os.path.basename(plan.get("spec", plan_path)), plan["planner"],
        "solved" if plan["solved"] else "NOT solved", len(plan["steps"]), steps), fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.set_xlim(ext["x"][0] - 0.01, ext["x"][1] + 0.01)
    ax.set_ylim(ext["y"][0] - 0.01, ext["y"][1] + 0.01)
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("wrote", out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
