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
cargo build --release --quiet
bin="${CARGO_TARGET_DIR:-target}/release/ballfield"
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
echo "| balls | threads | steps/s | µs per step | memory per ball (peak RSS) |"
echo "|---:|---:|---:|---:|---:|"
for n in ${counts[@]}; do
  read -r width height < <(python3 -c "import math; a=$n*math.pi/0.2; w=math.sqrt(a*1.6); print(f'{w:.3f} {a/w:.3f}')")
  cat > "$dir/rain$n.toml" <<TOML
name = "rain-$n"
[field]
width = $width
height = $height
[simulation]
max-balls = $n
[effects]
collisions = {}
gravity = { g = [0.0, -9.81] }
drag = { model = "quadratic", rho = 1.225, cd = 0.47 }
[[generate]]
count = $n
diameter = 2.0
mass = 1.0
speed = 5.0
layout = "lattice"
gap = 1.0
TOML
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
