#!/bin/sh
# Friction estimation, time and iterations per method on 50 tossed-cube episodes (issue 15
# item 9; bench/README.md): a 5 cm cube tossed onto a table 50 times (seeded launch velocities),
# 100 samples per toss at ≈ 143 Hz with 30 µm position noise (5000 samples, orientations
# logged), estimated together (shared μ, per-episode initial states) by each method in turn.
#
#   bench/estimation_cube_bench.sh [BUILD_DIR] [METHODS] [EPISODES] [THREADS] [SUBSTEPS]
#
# BUILD_DIR defaults to build (estimation_study must be built there: cmake --build BUILD_DIR
# --target estimation_study); METHODS a comma list of lsq,lsq_ms,filter,mpec,mpec_pen,mpec_dec
# (default all but mpec_dec; mpec_dec = mpec with --mpec-episodes decomposed: per-toss NLPs at a
# shared μ, docs/estimation.md); EPISODES default 50; THREADS (default 2) evaluate lsq's episodes and mpec's steps in
# parallel; SUBSTEPS (default 1) the MPEC's steps per logged sample (--mpec-substeps: 1 = one
# step of 7 ms per sample, 99 steps and ~7000 unknowns per toss; 0 = the simulator's 1 ms grid,
# 7× larger). Writes estimation_cube_bench_<METHODS>_<EPISODES>.csv in the current directory and
# prints a table (wall and CPU time). Run it on an idle machine; one method at a time is fine; a
# smaller EPISODES gives the per-toss cost. VERBOSE=1 in the environment prints every NLP's
# summary line on stderr as it ends (progress on the long runs). LSQ_HORIZON=H fits lsq and
# lsq_sens with a growing horizon from H samples (--lsq-horizon; docs/estimation.md).
set -eu
BUILD=${1:-build}
METHODS=${2:-lsq,lsq_ms,filter,mpec,mpec_pen}
EPISODES=${3:-50}
THREADS=${4:-2}
SUBSTEPS=${5:-1}
STUDY="$BUILD/examples/estimation_study"
[ -x "$STUDY" ] || { echo "no $STUDY: build the estimation_study target first" >&2; exit 1; }
OUT=estimation_cube_bench_$(echo "$METHODS" | tr , _)_$EPISODES.csv
echo "# $(date -u +%FT%TZ) $(git rev-parse --short HEAD 2>/dev/null || echo '?') load: $(cut -d' ' -f1-3 /proc/loadavg)" >&2
"$STUDY" cube --trials 1 --episodes "$EPISODES" --methods "$METHODS" \
  --threads "$THREADS" --mpec-substeps "$SUBSTEPS" --lsq-horizon "${LSQ_HORIZON:-0}" \
  --verbose "${VERBOSE:-0}" --out "$OUT"
/usr/bin/python3 - "$OUT" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
print("| method | episodes | samples | mu_hat (true 0.4) | std. error | iterations | time (s) | CPU (s) | converged |")
print("|---|---|---|---|---|---|---|---|---|")
for r in rows:
    print(f"| {r['method']} | {r['episodes']} | {r['samples']} | {float(r['mu_hat']):.5f} | "
          f"{float(r['std_error']):.2e} | {r['iterations']} | {float(r['time_s']):.1f} | "
          f"{float(r.get('cpu_s') or 'nan'):.1f} | "
          f"{'yes' if r['converged'] == '1' else 'no'} |")
PY
