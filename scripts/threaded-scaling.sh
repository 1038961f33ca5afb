#!/usr/bin/env bash
# How the thread-per-ball runtime's update rate falls as the ball count grows.
# Runs a gas of N balls (collisions on, no gravity or drag) for S wall-clock seconds each on
# `headless --engine threaded` and prints one markdown row per N from the run reports.
# Usage: scripts/threaded-scaling.sh [SECONDS] [N ...]     (default: 5 s; 64 256 1024 4096)
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-5}
shift || true
counts=("${@:-64 256 1024 4096}")
cargo build --release --quiet
bin="${CARGO_TARGET_DIR:-target}/release/ballfield"
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
echo "| balls | update rate min /s | median /s | monitor passes /s | CPU cores | impulses sent = applied | dropped |"
echo "|---:|---:|---:|---:|---:|---:|---:|"
for n in ${counts[@]}; do
  cat > "$dir/gas$n.toml" <<TOML
name = "gas-$n"
[field]
width = 140.0
height = 100.0
[simulation]
max-balls = $n
[effects]
collisions = {}
[[generate]]
count = $n
diameter = 0.8
mass = 1.0
speed = 3.0
TOML
  "$bin" --scene "$dir/gas$n.toml" headless --engine threaded --duration "$secs" --report "$dir/r$n.json" -q
  python3 - "$dir/r$n.json" "$n" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); t = r["runtime"]
print(f"| {sys.argv[2]} | {t['ball_rate_min']:.0f} | {t['ball_rate_median']:.0f} | {t['monitor_passes_per_second']:.0f} | "
      f"{t['cpu_cores_used']:.2f} | {t['impulses_sent']} = {t['impulses_applied']} | {t['messages_dropped']} |")
PY
done
