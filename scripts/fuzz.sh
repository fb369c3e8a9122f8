#!/usr/bin/env bash
# Runs every libFuzzer target in fuzz/ for a time budget (issue 18; docs/fuzzing.md):
#   scripts/fuzz.sh [SECONDS] [TARGET...]   (default 60 s per target, every target)
# Targets: scene lcp design field_design plan log. Builds build-fuzz/ with clang and
# -DVINCI_FUZZ=ON (ASan + UBSan, libFuzzer), seeds each target's working corpus
# (build-fuzz/fuzz/corpus_<target>) from the folders fuzz/CMakeLists.txt lists (examples/,
# tests/, fuzz/seeds) and fuzz/crashes/<target>, and uses fuzz/<target>.dict. A finding is
# written as build-fuzz/fuzz/crash-* (or leak-*, timeout-*, oom-*); add it to
# fuzz/crashes/<target>/ with the fix so that the replay test (ctest -R fuzz_replay) keeps it
# fixed. Runs under nice: the machine may be shared.
set -euo pipefail
seconds="${1:-60}"
shift || true
targets=("$@")
[ "${#targets[@]}" -gt 0 ] || targets=(scene lcp design field_design plan log)
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${root}/build-fuzz"
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S "${root}" -B "${build}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DVINCI_FUZZ=ON "${launcher[@]}" \
  -DVINCI_BUILD_BENCH=OFF -DVINCI_BUILD_EXAMPLES=OFF -DVINCI_BUILD_TESTS=ON >/dev/null
nice -n 10 cmake --build "${build}" -j"$(nproc)" \
  --target $(printf 'vinci_fuzz_%s ' "${targets[@]}")
status=0
for target in "${targets[@]}"; do
  case "${target}" in
    scene) seeds=("${root}/examples/scenes" "${root}/tests/data/scenes" "${root}/tests/cli/data") ;;
    lcp) seeds=("${root}/examples/lcp" "${root}/tests/data/lcp" "${root}/tests/cli/solve/data") ;;
    design) seeds=("${root}/examples/design" "${root}/tests/design/data") ;;
    field_design) seeds=("${root}/examples/field_design" "${root}/tests/planning/data") ;;
    plan) seeds=("${root}/examples/plan") ;;
    log) seeds=("${root}/fuzz/seeds/log") ;;
    *) echo "fuzz.sh: unknown target '${target}'" >&2; exit 2 ;;
  esac
  [ -d "${root}/fuzz/crashes/${target}" ] && seeds+=("${root}/fuzz/crashes/${target}")
  corpus="${build}/fuzz/corpus_${target}"
  mkdir -p "${corpus}"
  echo "== fuzz ${target}: ${seconds} s"
  (cd "${build}/fuzz" &&
    ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
      nice -n 10 ./vinci_fuzz_${target} -max_total_time="${seconds}" -timeout=10 \
      -rss_limit_mb=2048 -print_final_stats=1 -dict="${root}/fuzz/${target}.dict" \
      "${corpus}" "${seeds[@]}") || status=1
done
exit "${status}"
