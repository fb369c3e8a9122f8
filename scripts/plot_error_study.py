#!/usr/bin/python3
"""Plots the CSVs of examples/plate_error_study (sources of error on a vibrating plate).

usage: scripts/plot_error_study.py DIR   (reads DIR/{step_size,friction_cone,solve_time,
pose_rule}.csv, writes DIR/error_study.png)
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def load(path):
    return np.atleast_1d(np.genfromtxt(path, delimiter=",", names=True, dtype=None,
                                       encoding="utf-8"))


def main(argv):
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    d = argv[1]
    fig, axes = plt.subplots(2, 2, figsize=(11, 8.5))
    ax = axes[0, 0]
    step = load(os.path.join(d, "step_size.csv"))
    for scene in np.unique(step["scene"]):
        s = step[step["scene"] == scene]
        slope = np.polyfit(np.log(s["h"]), np.log(s["error_m"]), 1)[0]
        ax.loglog(s["h"], s["error_m"], "o-", label=f"{scene} (slope {slope:.2f})")
    ax.set_xlabel("step h (s)")
    ax.set_ylabel("displacement error (m)")
    ax.set_title("trajectory error vs step size")
    ax.legend(fontsize=8)
    ax = axes[0, 1]
    cone = load(os.path.join(d, "friction_cone.csv"))
    st = cone[cone["formulation"] == "stewart-trinkle"]
    ref = cone["reference"][0]
    ax.semilogx(st["friction_directions"], np.abs(st["direction_error_deg"]), "o-",
                label="|direction error| (deg)")
    ax.set_xlabel("friction-cone directions n_d")
    ax.set_ylabel("|direction error| (deg)")
    ax3 = ax.twinx()
    ax3.semilogx(st["friction_directions"], 100 * st["speed_error_rel"], "s--", color="C1",
                 label="speed error (%)")
    ax3.set_ylabel("speed error (%)")
    ax.legend(loc="upper left", fontsize=8)
    ax3.legend(loc="upper right", fontsize=8)
    ax.set_title(f"Stewart-Trinkle n_d vs reference: {ref}")
    ax = axes[1, 0]
    t = load(os.path.join(d, "solve_time.csv"))
    nd = t[t["sweep"] == "friction_directions"]
    hs = t[t["sweep"] == "step"]
    ax.loglog(nd["friction_directions"], 1e6 * nd["seconds_per_step"], "o-", label="vs n_d")
    ax.set_xlabel("friction-cone directions n_d")
    ax.set_ylabel("wall time per step (us)")
    ax2 = ax.twiny()
    ax2.semilogy(hs["h"], 1e6 * hs["seconds_per_step"], "s--", color="C1", label="vs h (n_d 8)")
    ax2.set_xlabel("step h (s)")
    ax.set_title("step time")
    ax.legend(loc="upper left", fontsize=8)
    ax2.legend(loc="lower right", fontsize=8)
    ax = axes[1, 1]
    pose = load(os.path.join(d, "pose_rule.csv"))
    for p in np.unique(pose["pose"]):
        for v in np.unique(pose["velocity"]):
            s = pose[(pose["pose"] == p) & (pose["velocity"] == v)]
            if len(s):
                ax.loglog(s["h"], s["error_m"], "o-", label=f"pose {p}, velocity {v}")
    ax.set_xlabel("step h (s)")
    ax.set_ylabel("displacement error (m)")
    ax.set_title("plate pose: set exactly vs integrated")
    ax.legend(fontsize=8)
    fig.tight_layout()
    out = os.path.join(d, "error_study.png")
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
