"""Runs a `vinci design` job and checks its result.json: the best design's fresh success rate is
above the start design's, and the ranking is sorted best first, by the fresh rates with --rank-fresh
(ctest cli_design_grasp).

usage: check_design_ranking.py VINCI OUT_DIR -- ARGS...   (ARGS are passed to `vinci design`)
"""
import json
import subprocess
import sys


def main():
    vinci, out = sys.argv[1], sys.argv[2]
    args = sys.argv[sys.argv.index("--") + 1:]
    run = subprocess.run([vinci, "design", *args, "--out", out], capture_output=True, text=True)
    sys.stdout.write(run.stdout)
    sys.stderr.write(run.stderr)
    if run.returncode != 0:
        sys.exit("vinci design exited with %d" % run.returncode)
    with open(out + "/result.json") as f:
        r = json.load(f)
    best, start = r["best_fresh"], r["start_fresh"]
    print("fresh: best %.3f [%.3f, %.3f], start %.3f [%.3f, %.3f]" %
          (best["success_rate"], *best["interval"], start["success_rate"], *start["interval"]))
    if not best["success_rate"] > start["success_rate"]:
        sys.exit("the best design's fresh success rate is not above the start design's")
    ranking = r["ranking"]
    if not ranking:
        sys.exit("empty ranking")
    rates = [e["search"]["success_rate"] for e in ranking]
    by = r["ranking_by"]
    if by == "fresh":  # --rank-fresh: every entry re-judged on the fresh samples, sorted by those
        if any("fresh" not in e for e in ranking):
            sys.exit("--rank-fresh: a ranked design without a fresh evaluation")
        rates = [e["fresh"]["success_rate"] for e in ranking]
        top_search = max(e["search"]["success_rate"] for e in ranking)
    else:
        top_search = rates[0]
    if any(a < b for a, b in zip(rates, rates[1:])):
        sys.exit("ranking not sorted by its %s success rate: %s" % (by, rates))
    if [e["rank"] for e in ranking] != list(range(1, len(ranking) + 1)):
        sys.exit("ranks are not 1..%d" % len(ranking))
    if top_search != r["best_search"]["success_rate"]:
        sys.exit("the top search rate %g is not the best design's %g" %
                 (top_search, r["best_search"]["success_rate"]))
    designs = [json.dumps(e["design"], sort_keys=True) for e in ranking]
    if len(set(designs)) != len(designs):
        sys.exit("a design is ranked twice")
    print("ranking of %d designs sorted by the %s rate, best %.3f" % (len(ranking), by, rates[0]))


if __name__ == "__main__":
    main()
