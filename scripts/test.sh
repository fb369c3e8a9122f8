#!/usr/bin/env bash
# The test command: installs the Debian packages (scripts/setup.sh), configures and builds vinci,
# and runs the tests with ctest. Exit status = ctest's.
#
#   bash scripts/test.sh              fast tests (label `fast`) in build/ (RelWithDebInfo)
#   bash scripts/test.sh --all        every test, including those labelled `slow`
#   bash scripts/test.sh --sanitize   ASan + UBSan build in build-asan/ (-DVINCI_SANITIZE=ON)
#
# Options combine (--sanitize --all). Works from any directory. Environment:
#   VINCI_JOBS       build parallelism (default: nproc)
#   VINCI_TEST_JOBS  ctest parallelism (default: 2)
set -euo pipefail

usage() { sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; }

sanitize=0
all=0
for arg in "$@"; do
  case "$arg" in
    --sanitize) sanitize=1 ;;
    --all) all=1 ;;
    -h|--help) usage; exit 0 ;;
    *) echo "test.sh: unknown option '$arg' (expected --sanitize, --all or --help)" >&2; exit 2 ;;
  esac
done

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

bash scripts/setup.sh

build_dir=build
cmake_args=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DVINCI_BUILD_TESTS=ON)
if [ "$sanitize" -eq 1 ]; then
  build_dir=build-asan
  cmake_args+=(-DVINCI_SANITIZE=ON)
  # The sanitizer runtime options, for test discovery at build time and for ctest (the test
  # binaries also have them built in; see cmake/VinciHelpers.cmake).
  export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
  export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
fi

jobs="${VINCI_JOBS:-$(nproc)}"
test_jobs="${VINCI_TEST_JOBS:-2}"

echo "test.sh: configuring $build_dir/ (${cmake_args[*]})"
cmake -S . -B "$build_dir" "${cmake_args[@]}"
echo "test.sh: building $build_dir/ with -j$jobs"
cmake --build "$build_dir" -j"$jobs"

ctest_args=(--test-dir "$build_dir" --output-on-failure -j"$test_jobs")
if [ "$all" -eq 0 ]; then
  ctest_args+=(-L fast)
fi
echo "test.sh: ctest ${ctest_args[*]}"
set +e
ctest "${ctest_args[@]}"
rc=$?
set -e
exit "$rc"
