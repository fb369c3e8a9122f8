#!/usr/bin/python3
"""Plots a `vinci design` run (docs/design.md): convergence and the most influential parameters.

usage: scripts/plot_design.py DIR [--out FILE.png]

Reads DIR/history.csv (every evaluation) and, when present, DIR/result.json, and writes one PNG
(default DIR/design.png) with
  (a) convergence: the objective of each evaluation in order, coloured by phase (start, global,
      local, ipopt, validate-*) with the phases shaded, and the best so far (the objective of the
      evaluation with the lowest loss so far among the search phases). For success objectives each
      evaluation carries its 95% Wilson interval (history columns lower, upper); the validation
      rows are the best and start designs re-evaluated on fresh samples.
  (b) the objective against the two most influential parameters: a scatter of the search
      evaluations in those two parameters coloured by the objective, the best design marked with
      a star and the start design with a square. With one parameter: the objective against it,
      coloured by phase.
  (c) the influence of every parameter (when there are two or more).

Influence measure: the correlation ratio eta^2 of the loss on each parameter over the search
evaluations (phases start, global, local, ipopt): the parameter's range is cut into equal-width
bins (one bin per distinct value when there are at most 10 of them, else round(sqrt(n)) bins,
between 2 and 10), and eta^2 = sum_b n_b (mean_b - mean)^2 / sum_i (loss_i - mean)^2 is the
fraction of the loss variance explained by the bin means. Unlike a rank correlation it also
sees a parameter whose optimum is inside its range. It is a one-at-a-time, descriptive measure
of the points the optimizer chose to evaluate (which cluster near the optimum), not a global
sensitivity index.

The objective type comes from result.json (`objective_type`); without it (an interrupted run)
a history whose objective is successes/samples with loss = 1 - objective + [0, 1/samples) (the
margin tie-break; >= 2 for a screened-out candidate) is taken as a success
objective. A missing or malformed file is reported as FILE:LINE: message, exit code 1.
"""
import csv
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

LEADING = ["index", "phase", "stream", "samples"]
TRAILING = ["objective", "loss", "successes", "lower", "upper", "failures", "time_s"]
SEARCH_PHASES = ("start", "global", "local", "ipopt")
# Candidates a screening stage rejected (not simulated in full: not search evaluations here).
SCREENED_PHASES = ("screened-geometric", "screened-short")
KNOWN_PHASES = SEARCH_PHASES + SCREENED_PHASES + ("validate-best", "validate-start")
PHASE_COLOURS = {
    "start": "black",
    "global": "tab:blue",
    "local": "tab:orange",
    "ipopt": "tab:green",
    "validate-best": "tab:red",
    "validate-start": "tab:gray",
    "screened-geometric": "tab:purple",
    "screened-short": "tab:brown",
}


class InputError(Exception):
    """A missing or malformed input; the message starts with FILE or FILE:LINE."""


def read_history(path):
    """Returns (parameter names, dict of columns as numpy arrays, phases as a list)."""
    try:
        f = open(path, newline="")
    except OSError as e:
        raise InputError(f"{path}: cannot read the history: {e.strerror}")
    with f:
        rows = list(csv.reader(f))
    if not rows or not rows[0]:
        raise InputError(f"{path}:1: empty file, expected the header "
                         f"{','.join(LEADING)},<parameters...>,{','.join(TRAILING)}")
    header = [h.strip() for h in rows[0]]
    n_par = len(header) - len(LEADING) - len(TRAILING)
    if n_par < 1 or header[:4] != LEADING or header[-len(TRAILING):] != TRAILING:
        raise InputError(f"{path}:1: header '{','.join(header)}': expected "
                         f"{','.join(LEADING)},<parameters...>,{','.join(TRAILING)}")
    names = header[4:4 + n_par]
    numeric = [h for h in header if h != "phase"]
    cols = {h: [] for h in numeric}
    phases = []
    for line, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        if len(row) != len(header):
            raise InputError(f"{path}:{line}: {len(row)} fields, expected {len(header)} "
                             f"(as the header)")
        for h, v in zip(header, row):
            if h == "phase":
                if v not in KNOWN_PHASES:
                    raise InputError(f"{path}:{line}: phase '{v}': expected one of "
                                     f"{', '.join(KNOWN_PHASES)}")
                phases.append(v)
                continue
            try:
                x = float(v)
            except ValueError:
                raise InputError(f"{path}:{line}: {h} '{v}': expected a number")
            if not math.isfinite(x) and h not in ("objective", "loss"):
                raise InputError(f"{path}:{line}: {h} '{v}': expected a finite number")
            cols[h].append(x)
    if not phases:
        raise InputError(f"{path}:2: no evaluations after the header")
    return names, {h: np.array(v) for h, v in cols.items()}, phases


def read_result(path):
    """Returns the parsed result.json, or None when the file does not exist."""
    if not os.path.exists(path):
        return None
    try:
        with open(path) as f:
            result = json.load(f)
    except json.JSONDecodeError as e:
        raise InputError(f"{path}:{e.lineno}: {e.msg}")
    except OSError as e:
        raise InputError(f"{path}: {e.strerror}")
    if not isinstance(result, dict):
        raise InputError(f"{path}:1: expected a JSON object")
    return result


def is_success(cols, result):
    if result is not None and "objective_type" in result:
        return result["objective_type"] == "success"
    obj, n = cols["objective"], np.maximum(cols["samples"], 1)
    # loss = 1 - rate + a tie-break term in [0, 1/n) (docs/design.md), >= 2 if screened out.
    d = cols["loss"] - (1 - obj)
    tie = (d >= -1e-12) & ((d < 1 / n + 1e-12) | (cols["loss"] >= 2))
    return bool(np.allclose(obj, cols["successes"] / n) and tie.all())


def correlation_ratio(x, y):
    """eta^2 of y on equal-width bins of x (module docstring); 0 for a constant x or y."""
    ok = np.isfinite(y)
    x, y = x[ok], y[ok]
    if len(y) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return 0.0
    distinct = np.unique(x)
    if len(distinct) <= 10:
        bins = np.searchsorted(distinct, x)
    else:
        k = int(min(10, max(2, round(math.sqrt(len(x))))))
        bins = np.minimum(((x - x.min()) / np.ptp(x) * k).astype(int), k - 1)
    mean = y.mean()
    between = sum(np.sum(bins == b) * (y[bins == b].mean() - mean) ** 2 for b in np.unique(bins))
    return float(between / np.sum((y - mean) ** 2))


def phase_runs(phases):
    """Contiguous runs of equal phase: [(phase, first row, last row)]."""
    runs = []
    for i, p in enumerate(phases):
        if runs and runs[-1][0] == p:
            runs[-1][2] = i
        else:
            runs.append([p, i, i])
    return runs


def fmt(v, success):
    if not success:
        return f"{v:.4g}"
    text = f"{100 * v:.1f}%"
    return f"{100 * v:.2f}%" if text in ("100.0%", "0.0%") and 0 < v < 1 else text


def plot_convergence(ax, cols, phases, success, log_scale):
    idx, obj, loss = cols["index"], cols["objective"], cols["loss"]
    phases = np.array(phases)
    search = np.isin(phases, SEARCH_PHASES)
    for k, (p, a, b) in enumerate(phase_runs(list(phases))):
        lo, hi = idx[a] - 0.5, idx[b] + 0.5
        ax.axvspan(lo, hi, color=PHASE_COLOURS[p], alpha=0.06 if k % 2 == 0 else 0.12, lw=0)
    for p in KNOWN_PHASES:
        m = phases == p
        if not m.any():
            continue
        label = p + (" (fresh samples)" if p.startswith("validate") else "")
        if success:
            err = np.vstack([obj[m] - cols["lower"][m], cols["upper"][m] - obj[m]])
            ax.errorbar(idx[m], obj[m], yerr=err, fmt="none", ecolor=PHASE_COLOURS[p],
                        alpha=0.25 if not p.startswith("validate") else 0.9, lw=1,
                        capsize=0 if not p.startswith("validate") else 3)
        big = p.startswith("validate") or p == "start"
        ax.plot(idx[m], obj[m], "o", color=PHASE_COLOURS[p], ms=6 if big else 3.5,
                mec="white" if not big else PHASE_COLOURS[p], mew=0.4, label=label, zorder=3)
    # Best so far: the objective at the lowest loss seen so far, over the search phases only.
    s_idx, s_obj, s_loss = idx[search], obj[search], loss[search]
    if len(s_idx):
        best = np.empty_like(s_obj)
        j = 0
        for i in range(len(s_loss)):
            if s_loss[i] < s_loss[j] or not np.isfinite(s_loss[j]):
                j = i
            best[i] = s_obj[j]
        ax.step(s_idx, best, where="post", color="tab:red", lw=1.8, label="best so far", zorder=4)
    if success:
        ax.set_ylim(-0.03, 1.03)
        ax.set_ylabel("success rate (95% Wilson interval)")
    else:
        ax.set_ylabel("objective (minimized)")
        if log_scale:
            ax.set_yscale("log")
    ax.set_xlabel("evaluation (history index)")
    ax.set_title("(a) convergence")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=3,
              frameon=False, columnspacing=1.0, handletextpad=0.3)
    ax.grid(alpha=0.3)


def colour_norm(obj, success, log_scale):
    if success:
        return matplotlib.colors.Normalize(0.0, 1.0)
    finite = obj[np.isfinite(obj)]
    if log_scale:
        return matplotlib.colors.LogNorm(finite.min(), finite.max())
    return matplotlib.colors.Normalize(finite.min(), finite.max())


def short(name):
    return name if len(name) <= 24 else "…" + name[-23:]


def main(argv):
    args = argv[1:]
    out = None
    if "--out" in args:
        k = args.index("--out")
        if k + 1 >= len(args):
            print("plot_design.py: error: --out needs a file name", file=sys.stderr)
            return 2
        out = args[k + 1]
        del args[k:k + 2]
    if len(args) != 1 or args[0].startswith("-"):
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    folder = args[0]
    out = out or os.path.join(folder, "design.png")
    try:
        names, cols, phases = read_history(os.path.join(folder, "history.csv"))
        result = read_result(os.path.join(folder, "result.json"))
    except InputError as e:
        print(f"plot_design.py: error: {e}", file=sys.stderr)
        return 1

    success = is_success(cols, result)
    obj = cols["objective"]
    finite = obj[np.isfinite(obj)]
    log_scale = (not success and len(finite) > 0 and finite.min() > 0
                 and finite.max() / finite.min() > 100)
    search = np.isin(np.array(phases), SEARCH_PHASES)
    if not search.any():
        print(f"plot_design.py: error: {folder}/history.csv: no search evaluations (phases "
              f"{', '.join(SEARCH_PHASES)})", file=sys.stderr)
        return 1
    s_x = {n: cols[n][search] for n in names}
    s_obj, s_loss = obj[search], cols["loss"][search]
    influence = {n: correlation_ratio(s_x[n], s_loss) for n in names}
    ranked = sorted(names, key=lambda n: -influence[n])
    order = np.argsort(-s_loss)  # drawn worst first, so the best points lie on top
    i_best = int(np.nanargmin(s_loss))
    best = {n: s_x[n][i_best] for n in names}
    if result is not None and isinstance(result.get("best"), dict):
        best.update({n: v for n, v in result["best"].items() if n in best})
    start = None
    if result is not None and isinstance(result.get("start"), dict):
        start = result["start"]
    elif "start" in phases:
        k = phases.index("start")
        start = {n: cols[n][k] for n in names}

    many = len(names) >= 2
    fig, axes = plt.subplots(1, 3 if many else 2, figsize=(17, 5.2) if many else (12, 5.0),
                             gridspec_kw={"width_ratios": [1.25, 1.1, 0.65]} if many else None)
    plot_convergence(axes[0], cols, phases, success, log_scale)
    norm = colour_norm(s_obj, success, log_scale)
    cmap = "viridis" if success else "viridis_r"
    what = "success rate" if success else "objective"
    ax = axes[1]
    if many:
        px, py = ranked[0], ranked[1]
        sc = ax.scatter(s_x[px][order], s_x[py][order], c=s_obj[order], cmap=cmap, norm=norm,
                        s=28, edgecolors="0.3", linewidths=0.3)
        fig.colorbar(sc, ax=ax, label=what + " (search samples)")
        ax.plot(best[px], best[py], "*", color="tab:red", ms=18, mec="black", mew=0.8,
                label="best design", zorder=5)
        if start is not None and px in start and py in start:
            ax.plot(start[px], start[py], "s", mfc="none", mec="black", ms=10, mew=1.5,
                    label="start design", zorder=5)
        ax.set_xlabel(f"{px}  (η² = {influence[px]:.2f})")
        ax.set_ylabel(f"{py}  (η² = {influence[py]:.2f})")
        ax.set_title(f"(b) {what} vs. the two most influential parameters")
        ax.legend(fontsize=8, loc="best", framealpha=0.85)
    else:
        p = names[0]
        if success:
            err = np.vstack([s_obj - cols["lower"][search], cols["upper"][search] - s_obj])
            ax.errorbar(s_x[p], s_obj, yerr=err, fmt="none", ecolor="0.6", alpha=0.5, lw=1)
        k = np.argsort(s_x[p])
        ax.plot(s_x[p][k], s_obj[k], "-", color="0.75", lw=0.8, zorder=1)
        s_phase = np.array(phases)[search]
        for ph in SEARCH_PHASES[1:]:
            m = s_phase == ph
            if m.any():
                ax.plot(s_x[p][m], s_obj[m], "o", color=PHASE_COLOURS[ph], ms=4.5, mec="white",
                        mew=0.4, label=ph, zorder=2)
        ax.axvline(best[p], color="tab:red", lw=1, ls="--", zorder=0)
        ax.plot(s_x[p][i_best], s_obj[i_best], "*", color="tab:red", ms=18, mec="black", mew=0.8,
                label=f"best design ({p} = {best[p]:.6g})", zorder=5)
        if start is not None and p in start and "start" in phases:
            ks = phases.index("start")
            ax.plot(start[p], obj[ks], "s", mfc="none", mec="black", ms=10, mew=1.5,
                    label="start design", zorder=5)
        ax.set_xlabel(p)
        ax.set_ylabel(what + (" (minimized)" if not success else ""))
        if success:
            ax.set_ylim(-0.03, 1.03)
        elif log_scale:
            ax.set_yscale("log")
        ax.set_title(f"(b) {what} vs. {p}")
        ax.legend(fontsize=8, loc="best", framealpha=0.85)
    ax.grid(alpha=0.3)
    if many:
        ax = axes[2]
        y = np.arange(len(ranked))
        ax.barh(y, [influence[n] for n in ranked],
                color=["tab:red" if k < 2 else "tab:blue" for k in range(len(ranked))])
        ax.set_yticks(y)
        ax.set_yticklabels([short(n) for n in ranked], fontsize=8)
        ax.invert_yaxis()
        ax.set_xlim(0, 1)
        ax.set_xlabel("η²: loss variance explained by binned means")
        ax.set_title("(c) parameter influence")
        ax.grid(alpha=0.3, axis="x")

    # Title: what was run and the fresh (unbiased) result.
    title = os.path.basename(os.path.normpath(folder))
    if result is not None:
        title = f"{result.get('spec', title)}  ·  {result.get('optimizer', '?')}"
        parts = []
        for key, label in (("best_fresh", "best"), ("start_fresh", "start")):
            r = result.get(key)
            if isinstance(r, dict) and "objective" in r:
                s = f"{label} {fmt(r['objective'], success)}"
                if success and isinstance(r.get("interval"), list) and len(r["interval"]) == 2:
                    lo, hi = r["interval"]
                    s += f" [{fmt(lo, success)}, {fmt(hi, success)}]"
                s += f" on {r.get('samples', '?')} fresh samples"
                parts.append(s)
        if parts:
            title += "\n" + ";  ".join(parts)
        if "evaluations" in result:
            title += f"  ·  {result['evaluations']} evaluations, " \
                     f"{result.get('simulations', '?')} simulations"
    else:
        title += f"  ·  {len(phases)} evaluations (no result.json: interrupted run?)"
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    try:
        fig.savefig(out, dpi=110)
    except OSError as e:
        print(f"plot_design.py: error: {out}: {e.strerror}", file=sys.stderr)
        return 1
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
