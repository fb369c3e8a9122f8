#!/usr/bin/python3
"""Plots and tabulates the friction-estimation studies (examples/estimation/estimation_study.cc).

usage: plot_estimation_study.py STUDY.csv [STUDY2.csv ...] [--out PREFIX]

Per study and method: the RMS error of mu_hat over the trials, its bias, the fraction of trials
within 3 reported standard errors (of all trials, and of the converged ones; in_3rse: within 3
robust standard errors, where the CSV has them, i.e. mpec_dec), convergence, mean
iterations, mean wall time and (where the CSV has it) mean CPU time, against the noise level and the
window length (the `particles` study: against the number of particles). Writes PREFIX_<study>.png
(default prefix: the first CSV without .csv) and prints a table. The plots leave out groups of
fewer than 5 trials (a cut-short run); the table lists them with their n.
"""
import csv
import math
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def load(paths):
    rows = []
    for p in paths:
        with open(p) as f:
            rows += list(csv.DictReader(f))
    return rows


MIN_PLOTTED_TRIALS = 5


def summarize(rows):
    groups = defaultdict(list)
    for r in rows:
        key = (r["study"], r["method"], float(r["noise_m"]), int(float(r["window"])),
               int(r["particles"]))
        groups[key].append(r)
    out = {}
    for key, rs in groups.items():
        err = [float(r["mu_hat"]) - float(r["true_mu"]) for r in rs]
        se = [float(r["std_error"]) if r["std_error"] not in ("", "nan") else math.nan for r in rs]
        n = len(err)
        covered = sum(1 for e, s in zip(err, se) if math.isfinite(s) and abs(e) <= 3 * s)
        conv = [(e, s) for e, s, r in zip(err, se, rs) if int(r["converged"])]
        covered_conv = sum(1 for e, s in conv if math.isfinite(s) and abs(e) <= 3 * s)
        # The s.e. from the episodes' jackknife (mpec_dec; a column since 2026-12-03).
        rse = [float(r["robust_se"]) if r.get("robust_se") not in (None, "", "nan") else math.nan
               for r in rs]
        with_rse = [(e, s) for e, s in zip(err, rse) if math.isfinite(s)]
        out[key] = dict(
            n=n,
            rms=math.sqrt(sum(e * e for e in err) / n),
            bias=sum(err) / n,
            mean_se=sum(s for s in se if math.isfinite(s)) / max(1, sum(math.isfinite(s) for s in se)),
            coverage=covered / n,
            coverage_converged=covered_conv / len(conv) if conv else math.nan,
            coverage_robust=(sum(1 for e, s in with_rse if abs(e) <= 3 * s) / len(with_rse)
                             if with_rse else math.nan),
            converged=sum(int(r["converged"]) for r in rs) / n,
            time=sum(float(r["time_s"]) for r in rs) / n,
            cpu=(sum(float(r["cpu_s"]) for r in rs) / n
                 if all(r.get("cpu_s") not in (None, "") for r in rs) else math.nan),
            iterations=sum(int(r["iterations"]) for r in rs) / n,
        )
    return out


def main():
    args = sys.argv[1:]
    prefix = None
    if "--out" in args:
        i = args.index("--out")
        prefix = args[i + 1]
        del args[i:i + 2]
    if not args:
        print(__doc__)
        return 1
    prefix = prefix or args[0].rsplit(".csv", 1)[0]
    s = summarize(load(args))
    print("study      method   noise_m   window particles  n   rms_err    bias       mean_se"
          "    in_3se conv  in_3se|conv  in_3rse  iters  time_s   cpu_s")
    for k in sorted(s):
        v = s[k]
        print(f"{k[0]:10s} {k[1]:8s} {k[2]:8.1e} {k[3]:6d} {k[4]:9d} {v['n']:3d}  {v['rms']:.3e}"
              f"  {v['bias']:+.3e}  {v['mean_se']:.3e}  {v['coverage']:5.2f}  {v['converged']:4.2f}"
              f"  {v['coverage_converged']:11.2f}  {v['coverage_robust']:7.2f}"
              f"  {v['iterations']:5.1f}  {v['time']:7.3f}  {v['cpu']:7.3f}")
    for study in sorted({k[0] for k in s}):
        keys = [k for k in s if k[0] == study and s[k]["n"] >= MIN_PLOTTED_TRIALS]
        fig, (ax, cx) = plt.subplots(1, 2, figsize=(11, 4))
        methods = sorted({k[1] for k in keys})
        for metric, axis in (("rms", ax), ("coverage", cx)):
            if study == "particles":
                for m in methods:
                    pts = sorted((k[4], s[k][metric]) for k in keys if k[1] == m)
                    axis.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=m)
                axis.set_xlabel("number of particles")
            else:
                for m in methods:
                    for w in sorted({k[3] for k in keys}):
                        pts = sorted((k[2], s[k][metric]) for k in keys if k[1] == m and k[3] == w)
                        axis.plot([p[0] for p in pts], [p[1] for p in pts], "o-",
                                  label=f"{m}, {w} samples")
                axis.set_xlabel("position noise σ (m)")
                axis.set_xscale("log")
            axis.grid(True, which="both", alpha=0.3)
            axis.legend(fontsize=8)
        ax.set_yscale("log")
        ax.set_ylabel("RMS error of μ̂")
        ax.set_title(f"friction estimation: {study}")
        cx.set_ylabel("fraction of trials with |μ̂ − μ| ≤ 3 s.e.")
        cx.set_ylim(0, 1.05)
        cx.axhline(0.9, color="k", lw=0.8, ls="--")
        cx.set_title("coverage of the reported standard errors")
        fig.tight_layout()
        fig.savefig(f"{prefix}_{study}.png", dpi=120)
        print(f"wrote {prefix}_{study}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
