#!/usr/bin/env bash
# The real window's frame time with many balls on the lockstep engine, under a virtual display.
# For each N: an elastic gas of N balls of 2 m covering 20 % of a field of aspect 1.6 (the scale
# benches' field: 1,585 m × 991 m at 100,000, balls ~1.6 px across at 1280×720), drawn in a
# 1280×720 window with the panel, for SECONDS; prints one markdown row per run from the window's
# report: the median frame time (start of drawing to the GPU done, present included) and frames
# per second, once with the simulation running and once paused (Space, pressed with xdotool: the
# frames then cost only the sampling and the drawing). The window samples every 15 ms; a frame
# per sample is 66 frames/s.
# Needs Xvfb, xdotool. Usage: scripts/window-frames.sh [SECONDS] [N ...]   (default: 10 s; 100000)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-10}
shift || true
counts=("${@:-100000}")
source scripts/lib.sh
ballfield_bin
dir=$(mktemp -d)
export XDG_RUNTIME_DIR="$dir/xdg"
mkdir -m 700 "$XDG_RUNTIME_DIR"
exec 3> "$dir/display"
Xvfb -displayfd 3 -screen 0 1600x1000x24 -nolisten tcp -noreset 2>/dev/null &
xvfb=$!
trap 'kill $xvfb; rm -rf "$dir"' EXIT
for _ in $(seq 100); do [ -s "$dir/display" ] && break; sleep 0.1; done
export DISPLAY=":$(cat "$dir/display")"
echo "| balls | simulation | frame ms (median) | frames/s | adapter |"
echo "|---:|---|---:|---:|---|"
for n in ${counts[@]}; do
  lattice_scene "$dir/gas$n.toml" "gas-$n" "$n" 'collisions = {}'
  for mode in running paused; do
    "$bin" --scene "$dir/gas$n.toml" --engine lockstep --size 1280x720 --exit-after "$seconds" \
      --report "$dir/w.json" 2> "$dir/stderr" &
    app=$!
    if [ $mode = paused ]; then
      for _ in $(seq 300); do
        wid=$(xdotool search --onlyvisible --name ballfield 2>/dev/null | head -1 || true)
        [ -n "$wid" ] && break
        sleep 0.1
      done
      sleep 0.5
      xdotool windowfocus --sync "$wid"
      sleep 0.3
      xdotool key space
    fi
    wait $app || { cat "$dir/stderr"; exit 1; }
    python3 - "$dir/w.json" "$mode" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
print(f"| {r['balls_end']} | {sys.argv[2]} | {r['frame_ms_median']:.1f} | {r['frames_per_second']:.0f} | {r['adapter']} |")
PY
  done
done
