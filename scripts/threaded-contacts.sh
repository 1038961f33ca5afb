#!/usr/bin/env bash
# Contacts on the threaded runtime, measured from headless run reports and state files (never
# timed tests). Prints markdown rows, each with the 1-minute load average before the run and
# "others' cores": what the rest of the machine used meanwhile, from /proc/stat (ball threads
# are SCHED_IDLE and get only the CPU others leave, so a figure taken while something else ran is
# not the runtime's).
#
# Usage: scripts/threaded-contacts.sh [PART ...]   (default: every part)
#   pile       the shipped `pile` (1,000 balls, e = 0.8) and `hard/pile` (1,000 balls, e = 0.5)
#              dropped and run SETTLE s (wall clock), then run WATCH s more from that state: the
#              floor's impulse over the second run against M·g·T, its largest overlap and kinetic
#              energy at the end; lockstep's kinetic energy on the same scene after SETTLE s, and
#              from the threaded state after WATCH s more; how many balls slept at the end of
#              each threaded run.
#   stall      a resting column of 5 balls (e = 1, then e = 0.8), the whole process stopped for
#              0.5 s (SIGSTOP/SIGCONT): its energy change, largest overlap, whether the column
#              kept its order (nothing tunnelled). REPEAT runs each.
#   fast       8 head-on pairs of 2 cm, 10 g balls closing at 10 to 300 m/s (e = 1 and e = 0.5),
#              REPEAT runs: pairs that passed through each other, worst velocity error.
#   speed      the monitor and the balls at 1,024 balls: a gas (no contacts to speak of) and the
#              pile scene with 1,024 balls, settled first: updates a second per ball (slowest,
#              median), monitor passes a second and its mean and longest pass. First, once and
#              after the runs, the machine's ceiling in this sitting: turns a second per thread
#              of 1,024 SCHED_IDLE threads that only yield (examples/turn_ceiling.rs), which no
#              ball thread can beat.
# SETTLE (default 20), WATCH (10), REPEAT (3), SPEED_SECONDS (10) in the environment.
# BALLFIELD_BIN=PATH: measure that binary instead of building this checkout.
set -euo pipefail
cd "$(dirname "$0")/.."
parts=("${@:-pile stall fast speed}")
settle=${SETTLE:-20}
watch=${WATCH:-10}
repeat=${REPEAT:-3}
speed_seconds=${SPEED_SECONDS:-10}
source scripts/lib.sh
ballfield_bin
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT

# Busy jiffies (all but idle and iowait) and total jiffies of the whole machine.
jiffies() { head -1 /proc/stat | awk '{t=0; for (i=2;i<=9;i++) t+=$i; print t-$5-$6, t}'; }
load() { cut -d' ' -f1 /proc/loadavg; }
# others BEFORE AFTER REPORT: the cores the rest of the machine used during a run.
others() {
  python3 - "$1" "$2" "$3" "$(nproc)" <<'PY'
import json, sys
(b0, t0), (b1, t1) = (map(int, a.split()) for a in sys.argv[1:3])
r = json.load(open(sys.argv[3]))
own = (r.get("runtime") or {}).get("cpu_cores_used", 0.0) if r.get("engine") == "threaded" else 0.0
machine = int(sys.argv[4]) * (b1 - b0) / max(t1 - t0, 1)
print(f"{max(0.0, machine - own):.2f}")
PY
}

for part in ${parts[@]}; do
case $part in
pile)
  echo "| scene | floor / M·g·T | largest overlap | kinetic J | lockstep kinetic J (same scene, ${settle} s / from the threaded state) | passes /s | mean pass ms | longest pass ms | unconverged | asleep at the end (dropped / watched) | clock dropped s | others' cores | load before |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
  for scene in pile assets/scenes/hard/pile.toml; do
    name=$(echo "$scene" | sed -e 's#assets/scenes/##' -e 's#\.toml$##' -e 's#/#-#g')
    l0=$(load); j0=$(jiffies)
    "$bin" --scene "$scene" headless --engine threaded --duration "$settle" --state-out "$dir/$name.csv" \
      --report "$dir/$name-a.json" -q
    "$bin" --scene "$scene" headless --engine threaded --duration "$watch" --state-in "$dir/$name.csv" \
      --report "$dir/$name-b.json" -q
    j1=$(jiffies)
    "$bin" --scene "$scene" headless --duration "$settle" --threads 1 --report "$dir/$name-l.json" -q
    "$bin" --scene "$scene" headless --duration "$watch" --threads 1 --state-in "$dir/$name.csv" \
      --report "$dir/$name-lb.json" -q
    o=$(others "$j0" "$j1" "$dir/$name-b.json")
    python3 - "$dir/$name-b.json" "$dir/$name-l.json" "$dir/$name-lb.json" "$name" "$o" "$l0" "$dir/$name-a.json" <<'PY'
import json, sys
b, l, lb = (json.load(open(f)) for f in sys.argv[1:4])
a = json.load(open(sys.argv[7]))
t = b["runtime"]; e = b["end"]
g = 9.81
weight = b["balls"] * g  # every ball of these scenes is 1 kg
ratio = e["wall_impulses"]["bottom"] / (weight * b["simulated_seconds"])
print(f"| {sys.argv[4]} | {ratio:.4f} | {e['largest_overlap_ratio'] * 100:.2f} % | {e['kinetic']:.2e} | "
      f"{l['end']['kinetic']:.2e} / {lb['end']['kinetic']:.2e} | {t['monitor_passes_per_second']:.0f} | "
      f"{t['monitor_pass_seconds'] * 1e3:.3f} | {t['monitor_pass_seconds_max'] * 1e3:.1f} | "
      f"{t['solves_unconverged']} of {t['monitor_passes']} | {a['runtime']['balls_asleep']} / {t['balls_asleep']} of {b['balls']} | "
      f"{t['clock_dropped_seconds']:.3f} | {sys.argv[5]} | {sys.argv[6]} |")
PY
  done
  ;;
stall)
  echo "| column | run | energy change | largest overlap m | order kept | clock dropped s | load before |"
  echo "|---|---:|---:|---:|---|---:|---:|"
  for e in 1.0 0.8; do
    {
      echo "name = \"stack\""
      echo "[field]"; echo "width = 10.0"; echo "height = 10.0"; echo "restitution = $e"
      echo "[effects]"; echo "collisions = { restitution = $e }"; echo "gravity = { g = [0.0, -9.81] }"
      for k in 0 1 2 3 4; do
        echo "[[balls]]"; echo "position = [5.0, $(python3 -c "print(0.5 + $k)")]"; echo "mass = 1.0"; echo "diameter = 1.0"
      done
    } > "$dir/stack$e.toml"
    for run in $(seq "$repeat"); do
      l0=$(load)
      "$bin" --scene "$dir/stack$e.toml" headless --engine threaded --duration 2.5 --state-out "$dir/stack.csv" \
        --report "$dir/stack.json" -q &
      pid=$!
      sleep 1.0
      kill -STOP "$pid"; sleep 0.5; kill -CONT "$pid"
      wait "$pid"
      python3 - "$dir/stack.json" "$dir/stack.csv" "$e" "$run" "$l0" <<'PY'
import csv, json, sys
r = json.load(open(sys.argv[1]))
rows = sorted(csv.DictReader(open(sys.argv[2])), key=lambda row: int(row["id"]))
ys = [float(row["y"]) for row in rows]
ordered = all(a < b for a, b in zip(ys, ys[1:]))
s, e = r["start"]["total"], r["end"]["total"]
print(f"| 5 balls, e = {sys.argv[3]} | {sys.argv[4]} | {(e - s) / s:+.1e} | {r['end']['largest_overlap']:.1e} | "
      f"{'yes' if ordered else 'NO'} | {r['runtime']['clock_dropped_seconds']:.3f} | {sys.argv[5]} |")
PY
    done
  done
  ;;
fast)
  echo "| e | run | pairs passed through (of 8) | worst velocity error (relative) | load before |"
  echo "|---:|---:|---:|---:|---:|"
  for e in 1.0 0.5; do
    python3 - "$dir/fast$e.toml" "$e" <<'PY'
import sys
e = float(sys.argv[2])
lines = ['name = "fast"', "[field]", "width = 40.0", "height = 10.0", "[effects]",
         f"collisions = {{ restitution = {e} }}"]
for k, closing in enumerate([10, 30, 60, 100, 150, 200, 250, 300]):
    v, y, gap = 0.5 * closing, 1.0 + k, closing * 0.1 + 0.02
    for x, vx in ((20.0 - 0.5 * gap, v), (20.0 + 0.5 * gap, -v)):
        lines += ["[[balls]]", f"position = [{x!r}, {y!r}]", f"velocity = [{vx!r}, 0.0]", "mass = 0.01", "diameter = 0.02"]
open(sys.argv[1], "w").write("\n".join(lines) + "\n")
PY
    for run in $(seq "$repeat"); do
      l0=$(load)
      # The pairs meet at x = 20 after 0.1 s; the run stops 0.05 s later, before any ball reaches
      # a wall (the fastest, at 150 m/s, is 7.5 m from the meeting point then).
      "$bin" --scene "$dir/fast$e.toml" headless --engine threaded --duration 0.15 --state-out "$dir/fast.csv" \
        --report "$dir/fast.json" -q
      python3 - "$dir/fast.csv" "$e" "$run" "$l0" <<'PY'
import csv, sys
e = float(sys.argv[2])
rows = sorted(csv.DictReader(open(sys.argv[1])), key=lambda row: int(row["id"]))
passed, worst = 0, 0.0
for k, closing in enumerate([10, 30, 60, 100, 150, 200, 250, 300]):
    a, b = rows[2 * k], rows[2 * k + 1]
    if float(a["x"]) >= float(b["x"]):
        passed += 1
        continue
    # Equal masses, head-on: each leaves at −e times its own speed.
    v = 0.5 * closing
    worst = max(worst, abs(float(a["vx"]) + e * v) / v, abs(float(b["vx"]) - e * v) / v)
print(f"| {e} | {sys.argv[3]} | {passed} | {worst:.1e} | {sys.argv[4]} |")
PY
    done
  done
  ;;
speed)
  cargo build --release --quiet --example turn_ceiling
  ceiling="${CARGO_TARGET_DIR:-target}/release/examples/turn_ceiling"
  echo "ceiling before: $("$ceiling" --threads 1024 --seconds 5)"
  echo
  echo "| scene | balls | slowest ball /s | median /s | monitor passes /s | mean pass ms | longest pass ms | CPU cores | others' cores | load before |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
  cat > "$dir/gas1024.toml" <<TOML
name = "gas-1024"
[field]
width = 140.0
height = 100.0
[simulation]
max-balls = 1024
[effects]
collisions = {}
[[generate]]
count = 1024
diameter = 0.8
mass = 1.0
speed = 3.0
TOML
  sed -e 's/^count = 1000$/count = 1024/' -e 's/^name = "pile"$/name = "pile-1024"/' assets/scenes/pile.toml > "$dir/pile1024.toml"
  # The pile settled first (lockstep, 20 s), so that the threaded run times a resting pile.
  "$bin" --scene "$dir/pile1024.toml" headless --duration 20 --state-out "$dir/pile1024.csv" -q
  for scene in gas1024 pile1024; do
    for run in $(seq "$repeat"); do
      l0=$(load); j0=$(jiffies)
      state=()
      [ "$scene" = pile1024 ] && state=(--state-in "$dir/pile1024.csv")
      "$bin" --scene "$dir/$scene.toml" headless --engine threaded --duration "$speed_seconds" "${state[@]}" \
        --report "$dir/s.json" -q
      j1=$(jiffies)
      o=$(others "$j0" "$j1" "$dir/s.json")
      python3 - "$dir/s.json" "$scene" "$o" "$l0" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); t = r["runtime"]
print(f"| {sys.argv[2]} | {r['balls']} | {t['ball_rate_min']:.0f} | {t['ball_rate_median']:.0f} | "
      f"{t['monitor_passes_per_second']:.0f} | {t['monitor_pass_seconds'] * 1e3:.3f} | "
      f"{t['monitor_pass_seconds_max'] * 1e3:.1f} | {t['cpu_cores_used']:.2f} | {sys.argv[3]} | {sys.argv[4]} |")
PY
    done
  done
  echo
  echo "ceiling after: $("$ceiling" --threads 1024 --seconds 5)"
  ;;
*)
  echo "unknown part: $part" >&2
  exit 2
  ;;
esac
done
