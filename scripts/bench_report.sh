#!/usr/bin/env bash
# Builds the benchmarks in Release and writes a dated report (bench/README.md explains the
# numbers). Usage: scripts/bench_report.sh [OUT_DIR]   (default: build-bench/report)
# The machine should be otherwise idle: the report records the load average before each run.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
build="${root}/build-bench"
out="${1:-${build}/report}"
mkdir -p "${out}"

cmake -S "${root}" -B "${build}" -DCMAKE_BUILD_TYPE=Release -DVINCI_BUILD_EXAMPLES=OFF >/dev/null
cmake --build "${build}" -j2 --target vinci_sim_bench
have_mujoco=0
if cmake --build "${build}" -j2 --target vinci_vs_mujoco 2>/dev/null; then have_mujoco=1; fi

stamp="$(date -u +%Y-%m-%dT%H:%M:%SZ)"
{
  echo "date: ${stamp}"
  echo "commit: $(git -C "${root}" rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores"
  echo "build: Release"
} >"${out}/machine.txt"

echo "load before vinci_sim_bench: $(cut -d' ' -f1-3 /proc/loadavg)" >>"${out}/machine.txt"
"${build}/bench/vinci_sim_bench" --benchmark_min_time=1 \
  --benchmark_out="${out}/sim_bench.json" --benchmark_out_format=json | tee "${out}/sim_bench.txt"

if [[ ${have_mujoco} == 1 ]]; then
  echo "load before vinci_vs_mujoco: $(cut -d' ' -f1-3 /proc/loadavg)" >>"${out}/machine.txt"
  "${build}/bench/vinci_vs_mujoco" --csv "${out}/vinci_vs_mujoco.csv" |
    tee "${out}/vinci_vs_mujoco.txt"
else
  echo "vinci_vs_mujoco not built (MuJoCo not found)" | tee "${out}/vinci_vs_mujoco.txt"
fi
cat "${out}/machine.txt"
echo "report in ${out}"
