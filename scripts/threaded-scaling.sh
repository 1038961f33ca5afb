#!/usr/bin/env bash
# How the thread-per-ball runtime's update rate falls as the ball count grows.
# Runs a gas of N balls (collisions on, no gravity or drag) for S wall-clock seconds each on
# `headless --engine threaded` and prints one markdown row per N from the run reports, with what
# the rest of the machine was doing meanwhile (the machine's busy cores from /proc/stat minus the
# run's own, and the load average before the run): ball threads are SCHED_IDLE and get only the
# CPU others leave, so a figure taken while something else ran is not the runtime's.
# Memory: the run's peak resident set (VmHWM) and that peak less the resident set before the
# runtime started, per ball (the report's `memory`).
# Usage: scripts/threaded-scaling.sh [--attraction] [SECONDS] [N ...]   (default: 5 s; 64 256 1024 4096)
#   --attraction: the gas attracts too (G = 1, so that it shapes the motion); adds how attraction
#   was summed (tree from TREE_MIN_BALLS balls on, else direct) and the monitor's tree builds a second.
# BALLFIELD_BALL_WAIT=sleep: the ball threads always sleep, never yield (for comparison).
# BALLFIELD_BIN=PATH: measure that binary (e.g. a build of another commit) instead of building this one.
set -euo pipefail
cd "$(dirname "$0")/.."
attraction=""
if [ "${1:-}" = "--attraction" ]; then
  attraction="attraction = { g-constant = 1.0 }"
  shift
fi
secs=${1:-5}
shift || true
counts=("${@:-64 256 1024 4096}")
source scripts/lib.sh
ballfield_bin
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
if [ -n "$attraction" ]; then
  echo "| balls | attraction | update rate min /s | median /s | monitor passes /s | trees /s | CPU cores | µs CPU per update | bytes per ball | peak RSS MiB | impulses sent / applied | dropped | others' cores | load before |"
  echo "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
else
  echo "| balls | update rate min /s | median /s | monitor passes /s | CPU cores | µs CPU per update | bytes per ball | peak RSS MiB | impulses sent / applied | dropped | others' cores | load before |"
  echo "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
fi
# Busy jiffies (all but idle and iowait) and total jiffies of the whole machine.
jiffies() { head -1 /proc/stat | awk '{t=0; for (i=2;i<=9;i++) t+=$i; print t-$5-$6, t}'; }
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
$attraction
[[generate]]
count = $n
diameter = 0.8
mass = 1.0
speed = 3.0
TOML
  load=$(cut -d' ' -f1 /proc/loadavg)
  before=$(jiffies)
  "$bin" --scene "$dir/gas$n.toml" headless --engine threaded --duration "$secs" --report "$dir/r$n.json" -q
  after=$(jiffies)
  python3 - "$dir/r$n.json" "$n" "$before" "$after" "$load" "$(nproc)" "$attraction" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); t = r["runtime"]; n = int(sys.argv[2])
(b0, t0), (b1, t1) = (map(int, a.split()) for a in sys.argv[3:5])
machine = int(sys.argv[6]) * (b1 - b0) / max(t1 - t0, 1)
others = max(0.0, machine - t["cpu_cores_used"])
per_update = 1e6 * t["cpu_cores_used"] / max(t["ball_rate_median"] * n, 1e-9)
m = r.get("memory") or {}
memory = (f"{m['bytes_per_ball']:.0f} | {m['rss_peak_bytes'] / 2**20:.1f}" if m else "— | —")
att = ""
if sys.argv[7]:
    how = next((e[len("attraction ("):-1] for e in r["active_effects"] if e.startswith("attraction (")), "?")
    att = f" {how} |"
    # A build from before the tree snapshot has no such figure.
    trees = f" {t['tree_builds_per_second']:.0f} |" if "tree_builds_per_second" in t else " — |"
else:
    trees = ""
print(f"| {n} |{att} {t['ball_rate_min']:.0f} | {t['ball_rate_median']:.0f} | {t['monitor_passes_per_second']:.0f} |"
      f"{trees} {t['cpu_cores_used']:.2f} | {per_update:.1f} | {memory} | {t['impulses_sent']} / {t['impulses_applied']} | "
      f"{t['messages_dropped']} | {others:.2f} | {sys.argv[5]} |")
PY
done
