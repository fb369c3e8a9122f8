#!/usr/bin/env bash
# Runs every libFuzzer target in fuzz/ for a time budget (issue 18):
#   scripts/fuzz.sh [SECONDS]        (default 60 per target)
# Builds build-fuzz/ with clang and -DVINCI_FUZZ=ON (ASan + UBSan, libFuzzer), seeds each
# target's working corpus (build-fuzz/fuzz/corpus_<target>) from examples/, tests/data and
# fuzz/crashes/<target>, and uses fuzz/<target>.dict. A finding is written as
# build-fuzz/fuzz/crash-* (or leak-*, timeout-*); add it to fuzz/crashes/<target>/ with the
# fix so that the replay test (ctest -R fuzz_replay) keeps it fixed.
set -euo pipefail
seconds="${1:-60}"
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${root}/build-fuzz"
cmake -S "${root}" -B "${build}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DVINCI_FUZZ=ON \
  -DVINCI_BUILD_BENCH=OFF -DVINCI_BUILD_EXAMPLES=OFF -DVINCI_BUILD_TESTS=ON >/dev/null
cmake --build "${build}" -j"$(nproc)" --target vinci_fuzz_scene vinci_fuzz_lcp
status=0
for target in scene lcp; do
  case "${target}" in
    scene) seeds=("${root}/examples/scenes" "${root}/tests/data/scenes" "${root}/tests/cli/data") ;;
    lcp) seeds=("${root}/examples/lcp" "${root}/tests/data/lcp" "${root}/tests/cli/solve/data") ;;
  esac
  corpus="${build}/fuzz/corpus_${target}"
  mkdir -p "${corpus}"
  echo "== fuzz ${target}: ${seconds} s"
  (cd "${build}/fuzz" &&
    ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
      ./vinci_fuzz_${target} -max_total_time="${seconds}" -timeout=10 -rss_limit_mb=2048 \
      -print_final_stats=1 -dict="${root}/fuzz/${target}.dict" "${corpus}" "${seeds[@]}" \
      "${root}/fuzz/crashes/${target}") || status=1
done
exit "${status}"
