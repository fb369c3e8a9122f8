#!/usr/bin/python3
"""The table of bench/design_bench.sh: one row per optimizer from DIR/<optimizer>/history.csv and
result.json (and DIR/runs.txt: exit code, wall time in ms, load average at the end).

    /usr/bin/python3 bench/design_bench_table.py DIR OPTIMIZER...

Columns: simulations run (search, screening and the fresh-sample validation), wall time,
simulations per second, the best success rate on the search samples after 25%, 50% and 100% of
the search's simulations (the best design so far by the search's loss, as the optimizer ranks
them), the best design's rate on the fresh samples with its 95% Wilson interval, and the start
design's. A run that failed or was not found is listed with its exit code, and the exit code of
this script is then 1.
"""
import csv
import json
import os
import sys

SEARCH = ("start", "global", "local", "ipopt")


def rate(row):
    n = max(1, int(row["samples"]))
    return int(row["successes"]) / n


def best_so_far(rows, fractions):
    """Best rate (by loss) after each fraction of the search's simulations."""
    search = [r for r in rows if r["phase"] in SEARCH or r["phase"].startswith("screened")]
    total = sum(int(r["samples"]) for r in search if r["phase"] in SEARCH)
    out = []
    for f in fractions:
        used, best = 0, None
        for r in search:
            if r["phase"] in SEARCH:
                if used + int(r["samples"]) > f * total + 1e-9:
                    break
                used += int(r["samples"])
            if best is None or float(r["loss"]) < float(best["loss"]):
                best = r
        out.append("-" if best is None else f"{int(best['successes'])}/{best['samples']}")
    return out, total


def pct(x):
    return f"{100 * x:.1f}%"


def main():
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 1
    out, optimizers = sys.argv[1], sys.argv[2:]
    runs = {}
    try:
        with open(os.path.join(out, "runs.txt")) as f:
            for line in f:
                name, code, ms, load = line.split()
                runs[name] = (int(code), int(ms) / 1000.0, load)
    except OSError:
        pass
    print("| optimizer | simulations | wall (s) | sims/s | best on search samples at 25% / 50% / "
          "100% of the search | best on fresh samples (Wilson 95%) | start on fresh samples | "
          "load at end |")
    print("|---|---|---|---|---|---|---|---|")
    failed = False
    for opt in optimizers:
        d = os.path.join(out, opt.replace("+", "_"))
        code, wall, load = runs.get(opt, (None, None, "-"))
        try:
            with open(os.path.join(d, "history.csv")) as f:
                rows = list(csv.DictReader(f))
            with open(os.path.join(d, "result.json")) as f:
                res = json.load(f)
        except (OSError, ValueError) as e:
            print(f"| {opt} | failed (exit {code}: {e}) | | | | | | |")
            failed = True
            continue
        failed = failed or code not in (None, 0)
        marks, _ = best_so_far(rows, (0.25, 0.5, 1.0))
        t = wall if wall is not None else res["time_s"]
        sims = res["simulations"]
        name = opt + (" (margin objective)" if res.get("objective_type") == "margin" else "")
        fresh = res.get("best_fresh")
        start = res.get("start_fresh")
        f_txt = (f"{pct(fresh['success_rate'])} [{pct(fresh['interval'][0])}, "
                 f"{pct(fresh['interval'][1])}] of {fresh['samples']}") if fresh else "-"
        s_txt = (f"{pct(start['success_rate'])} [{pct(start['interval'][0])}, "
                 f"{pct(start['interval'][1])}]") if start else "-"
        print(f"| {name} | {sims} | {t:.0f} | {sims / max(t, 1e-9):.0f} | {' / '.join(marks)} | "
              f"{f_txt} | {s_txt} | {load} |")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
