#!/bin/sh
# The friction-estimation studies of issue 15 (docs/estimation.md, "Studies"): the thesis' three
# (particle on a vibrating plate, several particles sharing μ, block sliding to rest) and the
# tossed cube, each over its noise levels and window lengths with seeded trials, then the
# tables and plots (scripts/plot_estimation_study.py).
#
#   scripts/estimation_studies.sh [BUILD_DIR] [OUT_DIR] [TRIALS] [METHODS]
#
# Defaults: build, estimation_results, 20 trials, lsq,lsq_sens,lsq_ms,filter,mpec,mpec_pen. The full run takes
# hours (the cube and mpec dominate); run it on an idle machine, or cut TRIALS / METHODS.
set -eu
BUILD=${1:-build}
OUT=${2:-estimation_results}
TRIALS=${3:-20}
METHODS=${4:-lsq,lsq_sens,lsq_ms,filter,mpec,mpec_pen}
STUDY="$BUILD/examples/estimation_study"
[ -x "$STUDY" ] || { echo "no $STUDY: build the estimation_study target first" >&2; exit 1; }
HERE=$(dirname "$0")
mkdir -p "$OUT"
for s in plate particles block cube; do
  "$STUDY" "$s" --trials "$TRIALS" --methods "$METHODS" --out "$OUT/estimation_study_$s.csv"
done
/usr/bin/python3 "$HERE/plot_estimation_study.py" "$OUT"/estimation_study_*.csv \
  --out "$OUT/estimation_study" | tee "$OUT/estimation_study_table.txt"
