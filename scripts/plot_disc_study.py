#!/usr/bin/python3
"""Plot the disc-on-plane study (examples/disc_on_plane_study.cc): kinetic energy and distance
after T versus the number of polygon sides N, one line per time step h for the N-gon discs under
Stewart-Trinkle, the geometrically implicit (GI) disc per h as markers at the right edge, and the
closed form as a dashed line.

usage: scripts/plot_disc_study.py [disc_on_plane_study.csv] [out.png]
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    src = sys.argv[1] if len(sys.argv) > 1 else "disc_on_plane_study.csv"
    out = sys.argv[2] if len(sys.argv) > 2 else "disc_on_plane_study.png"
    with open(src, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"{src}: no rows")
    hs = sorted({float(r["h"]) for r in rows}, reverse=True)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, key, closed, label in (
        (axes[0], "kinetic_energy", "closed_energy", "kinetic energy after T (J)"),
        (axes[1], "distance", "closed_distance", "distance travelled in T (m)"),
    ):
        n_max = max(int(r["sides"]) for r in rows)
        for i, h in enumerate(hs):
            color = f"C{i}"
            st = sorted((int(r["sides"]), float(r[key])) for r in rows
                        if r["method"] != "gi" and float(r["h"]) == h)
            if st:
                ax.plot([n for n, _ in st], [v for _, v in st], "o-", color=color,
                        label=f"N-gon, Stewart-Trinkle, h = {h:g}")
            gi = [float(r[key]) for r in rows if r["method"] == "gi" and float(r["h"]) == h]
            if gi:
                ax.plot([n_max * 1.6], gi, "*", markersize=12, color=color,
                        label=f"GI disc, h = {h:g}")
        ax.axhline(float(rows[0][closed]), color="k", ls="--", lw=1, label="closed form")
        ax.set_xscale("log")
        ax.set_xlabel("polygon sides N (GI disc: star at the right)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle(f"Disc on a plane after T = {float(rows[0]['T']):g} s: "
                 "GI keeps the rolling energy, N-gons lose it")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
