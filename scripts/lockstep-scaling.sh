#!/usr/bin/env bash
# How the lockstep engine scales with the ball count and the thread count, and what memory a ball
# costs. Runs the benches' target scene (balls of 2 m covering 20 % of a field of aspect 1.6;
# gravity, drag, collisions) at each N for STEPS steps on `headless --engine lockstep` with 1 and
# 2 threads, and prints one markdown row per run from the run reports (steps/s over the whole
# run, from the start: balls in the air, not a settled pile).
# Usage: scripts/lockstep-scaling.sh [STEPS] [N ...]     (default: 1000 steps; 1000 10000 100000)
set -euo pipefail
cd "$(dirname "$0")/.."
steps=${1:-1000}
shift || true
counts=("${@:-1000 10000 100000}")
source scripts/lib.sh
ballfield_bin
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
echo "| balls | threads | steps/s | µs per step | memory per ball (peak RSS) |"
echo "|---:|---:|---:|---:|---:|"
for n in ${counts[@]}; do
  lattice_scene "$dir/rain$n.toml" "rain-$n" "$n" 'collisions = {}
gravity = { g = [0.0, -9.81] }
drag = { model = "quadratic", rho = 1.225, cd = 0.47 }'
  for threads in 1 2; do
    "$bin" --scene "$dir/rain$n.toml" headless --steps "$steps" --threads "$threads" --report "$dir/r$n-$threads.json" -q
    python3 - "$dir/r$n-$threads.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); m = r["memory"]
print(f"| {r['balls']} | {r['threads']} | {r['steps_per_second']:.0f} | {1e6 / r['steps_per_second']:.0f} | "
      f"{m['bytes_per_ball']:.0f} B |")
PY
  done
done
