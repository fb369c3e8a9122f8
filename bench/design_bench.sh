#!/usr/bin/env bash
# The design-search benchmark (issue 13, deliverable 11; bench/README.md, "Design search: the
# optimizers"): the bundled feeder search (examples/design/feeder.yaml) with each optimizer on the
# same budget and threads, then a table of simulations/s, the best success rate against the
# simulations used, the wall time and the fresh-sample rate of the best design.
#
#   bash bench/design_bench.sh [--vinci PATH] [--budget N] [--threads N] [--validation N]
#                              [--optimizers "a+b c+d ..."] [--out DIR]
#
# Defaults: build/cli/vinci, the spec's budget (1200), 2 threads, 1000 fresh samples, the
# optimizers below, DIR = bench-design-out. `ipopt` needs a smooth objective: it runs on the same
# spec with `type: margin` (its best design's success rate is still measured on fresh samples).
# The table is printed and written to DIR/table.md. Not a ctest test (it takes minutes); ctest runs
# it once with --budget 8 (bench.design_bench.smoke).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
vinci="$root/build/cli/vinci"
budget=""
threads=2
validation=1000
optimizers="direct-l+neldermead direct-l+sbplx crs2+bobyqa isres esch+neldermead ipopt"
out="bench-design-out"
spec="$root/examples/design/feeder.yaml"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --vinci) vinci="$2"; shift 2 ;;
    --budget) budget="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --validation) validation="$2"; shift 2 ;;
    --optimizers) optimizers="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --spec) spec="$2"; shift 2 ;;
    *) echo "design_bench.sh: unknown argument '$1'" >&2; exit 1 ;;
  esac
done
[[ -x "$vinci" ]] || { echo "design_bench.sh: no vinci executable at '$vinci'" >&2; exit 1; }
mkdir -p "$out"
# The margin variant of the spec for ipopt, in DIR (its scene path made absolute).
spec_dir="$(cd "$(dirname "$spec")" && pwd)"
margin_spec="$out/margin_spec.yaml"
# (Screening applies to success objectives: the `screening:` block is dropped.)
awk '/^screening:/ {skip = 1; next} skip && /^[^ #]/ {skip = 0} !skip' "$spec" |
  sed -e 's/type: success/type: margin/g' -e '/^optimizer:/d' \
      -e "s|^scene: \([^/].*\)|scene: $spec_dir/\1|" >"$margin_spec"

: >"$out/runs.txt"
echo "load before: $(cut -d' ' -f1-3 /proc/loadavg) (1, 5, 15 min), $(nproc) cores" | tee "$out/load.txt"
for opt in $optimizers; do
  dir="$out/${opt//+/_}"
  s="$spec"
  [[ "$opt" == ipopt ]] && s="$margin_spec"
  args=(design "$s" --optimizer "$opt" --threads "$threads" --validation-samples "$validation"
        --quiet --out "$dir")
  [[ -n "$budget" ]] && args+=(--budget "$budget")
  echo "design_bench: $opt" >&2
  start=$(date +%s%N)
  code=0
  "$vinci" "${args[@]}" || code=$?
  end=$(date +%s%N)
  echo "$opt $code $(( (end - start) / 1000000 )) $(cut -d' ' -f1 /proc/loadavg)" >>"$out/runs.txt"
done
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)" | tee -a "$out/load.txt"
/usr/bin/python3 "$here/design_bench_table.py" "$out" $optimizers | tee "$out/table.md"
