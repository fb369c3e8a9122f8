#!/usr/bin/env bash
# The main job: installs the Debian packages (scripts/setup.sh), builds only the `vinci` executable
# in build/, and runs the bundled design search — the part-reorienting feeder
# (examples/design/feeder.yaml, docs/design.md): where to put a pin and a ledge so that a U-shaped
# part leaves a chute opening up whichever way it entered. Under a minute on 2 cores.
#
#   bash scripts/demo.sh                          vinci design examples/design/feeder.yaml
#                                                   --out build/feeder_design
#   bash scripts/demo.sh SCENE [vinci simulate flags...]
#       e.g. bash scripts/demo.sh examples/scenes/other.yaml --duration 2 --out /tmp/other.csv
#
# With arguments, they are passed to `vinci simulate` as they are (relative paths are relative to
# the directory you ran the script from). If SCENE comes first and there is no --out, the CSV
# goes to build/<scene name>.csv.
# Exit status = vinci's (0 ok, 1 bad input, 3 simulation (or an evaluation) failed).
set -euo pipefail

caller_dir="$(pwd)"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

bash scripts/setup.sh

echo "demo.sh: configuring build/ and building the vinci executable"
cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo
cmake --build build --target vinci -j"${VINCI_JOBS:-$(nproc)}"
vinci="$root/build/cli/vinci"

if [ "$#" -eq 0 ]; then
  threads="${VINCI_JOBS:-$(nproc)}"
  echo "demo.sh: vinci design examples/design/feeder.yaml --out build/feeder_design --threads $threads"
  set +e
  "$vinci" design examples/design/feeder.yaml --out build/feeder_design --threads "$threads"
  rc=$?
  set -e
  if [ -f build/feeder_design/result.json ]; then
    echo "demo.sh: results in $root/build/feeder_design (result.json, history.csv, best.yaml:"
    echo "         vinci simulate build/feeder_design/best.yaml --out feeder.csv replays the best design)"
  fi
  exit "$rc"
fi

# Run from the caller's directory so that relative paths mean what the user typed.
cd "$caller_dir"
args=("$@")
out=""
has_out=0
for ((i = 1; i <= $#; i++)); do
  case "${!i}" in
    --out) has_out=1; j=$((i + 1)); out="${!j:-}" ;;
    --out=*) has_out=1; out="${!i#--out=}" ;;
  esac
done
if [ "$has_out" -eq 0 ] && [ "${1#-}" = "$1" ]; then
  scene_name="$(basename "$1")"
  out="$root/build/${scene_name%.*}.csv"
  args+=(--out "$out")
fi
echo "demo.sh: vinci simulate ${args[*]}"
set +e
"$vinci" simulate "${args[@]}"
rc=$?
set -e
if [ -n "$out" ] && [ -f "$out" ]; then
  case "$out" in /*) ;; *) out="$(pwd)/$out" ;; esac
  echo "demo.sh: trajectory CSV written to $out ($(wc -l < "$out") lines)"
fi
exit "$rc"
