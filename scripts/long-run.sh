#!/usr/bin/env bash
# A long run of the mobile base through the real service, as a robot would run it: the rooms
# route of the building world driven --passes times (recorded once by epmap-sim, 12 passes =
# 750 m, 27162 frames, 4.5 GB, about 4 min), replayed over DDS at --rate Hz into epmapd (with
# a state folder), while a planner-like client polls every --poll seconds for the whole
# perceptual map and the 8 m grid window around the robot, and samples GetStatus every 15 s.
# At the end epmapd is stopped (it saves its maps) and started again on the same state folder
# to time the resume. Prints, by quarter of the run, the service's rolling medians (key frame,
# open-stop snapshot, the readers' first read of the perceptual map), its resident memory and
# the client's round trip; then frames, drops, key frames, peak memory, the saved state, the
# final pose against the ground truth, and the resume. Everything is left in --work.
# Needs a build (scripts/build.sh). 12 passes at 15 Hz take about 30 min.
#
#   scripts/long-run.sh [--work DIR] [--passes N] [--rate HZ] [--poll S]
set -euo pipefail
cd "$(dirname "$0")/.."

WORK=long-run
PASSES=12
RATE=15
POLL=1
while [ $# -gt 0 ]; do
  case "$1" in
    --work) WORK="$2"; shift 2 ;;
    --passes) PASSES="$2"; shift 2 ;;
    --rate) RATE="$2"; shift 2 ;;
    --poll) POLL="$2"; shift 2 ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) echo "long-run.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
[[ "$PASSES" =~ ^[1-9][0-9]*$ ]] || { echo "long-run.sh: --passes takes a whole number, not '$PASSES'" >&2; exit 2; }
[[ "$RATE" =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "long-run.sh: --rate takes frames per second, not '$RATE'" >&2; exit 2; }
[[ "$POLL" =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "long-run.sh: --poll takes seconds, not '$POLL'" >&2; exit 2; }
BIN=build/bin
for tool in epmapd epmapctl epmap-sim epmap-replay; do
  [ -x "$BIN/$tool" ] || { echo "long-run.sh: $BIN/$tool missing: run scripts/build.sh" >&2; exit 1; }
done

export SKIP_DEFAULT_XML_FILE=1
DOMAIN=${EPMAP_DOMAIN:-$(( 20 + $$ % 200 ))}
PORT=${EPMAP_PORT:-$(( 51000 + $$ % 1000 ))}
SERVER=127.0.0.1:$PORT
DATA="$WORK/rooms-x$PASSES"
OUT="$WORK/run-x$PASSES"
mkdir -p "$WORK"
if [ ! -f "$DATA/.complete" ]; then
  echo "== recording the rooms route driven $PASSES times into $DATA"
  rm -rf "$DATA"
  "$BIN/epmap-sim" record --scenario building --route rooms --passes "$PASSES" --out "$DATA" \
    > "$WORK/record-x$PASSES.log"
  touch "$DATA/.complete"
fi
rm -rf "$OUT"
mkdir -p "$OUT/status"

PIDS=()
cleanup() {
  for pid in "${PIDS[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap cleanup EXIT INT TERM

wait_for_service() {  # prints the seconds it took
  local t0 now
  t0=$(date +%s.%N)
  for _ in $(seq 1 400); do
    "$BIN/epmapctl" --server "$SERVER" --timeout 1 status > /dev/null 2>&1 && break
    sleep 0.05
  done
  now=$(date +%s.%N)
  awk -v a="$t0" -v b="$now" 'BEGIN { printf "%.3f\n", b - a }'
}

echo "== epmapd on $SERVER, DDS domain $DOMAIN, state in $OUT/state"
"$BIN/epmapd" --listen "$SERVER" --domain "$DOMAIN" --urdf clients/sim/urdf/pan_robot.urdf \
  --state-dir "$OUT/state" > "$OUT/epmapd.log" 2>&1 &
EPMAPD=$!
PIDS+=("$EPMAPD")
wait_for_service > /dev/null
echo "== replaying $DATA at $RATE Hz (restamped with the wall clock)"
"$BIN/epmap-replay" "$DATA" --domain "$DOMAIN" --rate "$RATE" --restamp > "$OUT/replay.log" 2>&1 &
REPLAY=$!
PIDS+=("$REPLAY")

# The planner: the whole perceptual map and the grid around the robot, every POLL seconds.
# A refusal before the first odometry (the service is in head mode until rt/odom arrives) is
# logged, not fatal.
i=0
echo "# poll,unix_s,pmap_round_trip_s,grid_round_trip_s,pmap_ok,grid_ok" > "$OUT/poll.csv"
while kill -0 "$REPLAY" 2>/dev/null; do
  t0=$(date +%s.%N)
  pmap_ok=1; grid_ok=1
  "$BIN/epmapctl" --server "$SERVER" pmap --out "$OUT/pmap_poll.json" > "$OUT/pmap_poll.txt" 2>&1 || pmap_ok=0
  t1=$(date +%s.%N)
  "$BIN/epmapctl" --server "$SERVER" grid --around-robot 8 --out "$OUT/grid_poll.pgm" > /dev/null 2>&1 || grid_ok=0
  t2=$(date +%s.%N)
  awk -v i="$i" -v a="$t0" -v b="$t1" -v c="$t2" -v p="$pmap_ok" -v g="$grid_ok" \
    'BEGIN { printf "%d,%.3f,%.4f,%.4f,%d,%d\n", i, a, b - a, c - b, p, g }' >> "$OUT/poll.csv"
  if [ $(( i % 15 )) = 0 ]; then
    "$BIN/epmapctl" --server "$SERVER" status --json > "$OUT/status/$(date +%s).json" 2>/dev/null || true
  fi
  i=$(( i + 1 ))
  sleep "$POLL"
done
wait "$REPLAY" || { echo "long-run.sh: epmap-replay failed (see $OUT/replay.log)" >&2; exit 1; }
sleep 1  # the last frames through the queue
"$BIN/epmapctl" --server "$SERVER" status > "$OUT/status_end.txt"
"$BIN/epmapctl" --server "$SERVER" status --json > "$OUT/status_end.json"
"$BIN/epmapctl" --server "$SERVER" pose --json > "$OUT/pose_end.json"
"$BIN/epmapctl" --server "$SERVER" pmap --out "$OUT/pmap_end.json" > /dev/null
kill -INT "$EPMAPD"
wait "$EPMAPD" || { echo "long-run.sh: epmapd exited with $? (see $OUT/epmapd.log)" >&2; exit 1; }

echo "== epmapd again on the same state folder (resume)"
"$BIN/epmapd" --listen "$SERVER" --domain "$DOMAIN" --urdf clients/sim/urdf/pan_robot.urdf \
  --state-dir "$OUT/state" > "$OUT/epmapd_resume.log" 2>&1 &
EPMAPD=$!
PIDS+=("$EPMAPD")
RESUME_S=$(wait_for_service)
t0=$(date +%s.%N)
"$BIN/epmapctl" --server "$SERVER" pmap --out "$OUT/pmap_resumed.json" > /dev/null
t1=$(date +%s.%N)
RESUME_PMAP_S=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f\n", b - a }')
"$BIN/epmapctl" --server "$SERVER" status --json > "$OUT/status_resumed.json"
kill -INT "$EPMAPD"
wait "$EPMAPD" || true

python3 - "$OUT" "$DATA" "$RESUME_S" "$RESUME_PMAP_S" <<'EOF' | tee "$OUT/summary.txt"
import csv, glob, json, math, os, statistics, sys

out, data, resume_s, resume_pmap_s = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])

def stage(status, name):
    for s in status["stages"]:
        if s["stage"] == name:
            return s["median_ms"]
    return None

samples = []
for f in glob.glob(os.path.join(out, "status", "*.json")):
    with open(f) as fh:
        s = json.load(fh)
    if s.get("mode") == "mobile-base":
        samples.append((int(os.path.basename(f)[:-5]), s))
samples.sort(key=lambda p: p[0])
polls = []
with open(os.path.join(out, "poll.csv")) as fh:
    for row in csv.reader(line for line in fh if not line.startswith("#")):
        if row[4] == "1":
            polls.append((float(row[1]), float(row[2]), float(row[3])))
with open(os.path.join(out, "status_end.json")) as fh:
    end = json.load(fh)
total = int(end["frames_processed"]) or 1

def med(values, scale=1.0):
    values = [v * scale for v in values if v is not None]
    return f"{statistics.median(values):.1f}" if values else "-"

print("rolling medians (last 256 values) sampled every 15 s, median by quarter of the run:")
print(f"{'quarter':<8} {'key_frame ms':>13} {'open_stop ms':>13} {'first read ms':>14} "
      f"{'resident MB':>12} {'pmap poll ms':>13} {'grid poll ms':>13}")
for q in range(4):
    in_quarter = [(t, s) for t, s in samples
                  if min(3, 4 * int(s["frames_processed"]) // total) == q]
    part = [s for _, s in in_quarter]
    times = [t for t, _ in in_quarter]
    in_q = [p for p in polls if times and min(times) - 15 <= p[0] <= max(times)]
    print(f"{q + 1:<8} {med([stage(s, 'maps.key_frame') for s in part]):>13} "
          f"{med([stage(s, 'maps.open_stop') for s in part]):>13} "
          f"{med([stage(s, 'maps.perceptual_read') for s in part]):>14} "
          f"{med([s['resident_mb'] for s in part]):>12} "
          f"{med([p[1] for p in in_q], 1e3):>13} {med([p[2] for p in in_q], 1e3):>13}")

events = {e["reason"]: int(e["count"]) for e in end["events"]}
saved = end.get("saved_maps") or {}
print(f"frames: {end['frames_received']} received, {end['frames_processed']} processed, "
      f"{end['frames_rejected']} rejected, {end['queue_dropped']} dropped in queue")
print(f"key frames: {events.get('maps_key_frames', 0)}, correlation shifts "
      f"{events.get('maps_correlation_shifts', 0)}, heading turns {events.get('maps_heading_turns', 0)}, "
      f"saves {events.get('maps_saved', 0)}, grids on rt/map {events.get('ros_map_published', 0)}")
print(f"memory: resident {end['resident_mb']:.1f} MB at the end, peak {end['peak_resident_mb']:.1f} MB; "
      f"saved state {int(saved.get('bytes', 0)) / 1e6:.1f} MB")
print(f"client polls: {len(polls)} answered (poll ms: epmapctl's whole round trip, its own start of "
      f"about 0.1 s included; the grid window costs the service well under 1 ms)")

with open(os.path.join(out, "pose_end.json")) as fh:
    pose = json.load(fh)
with open(os.path.join(data, "mav0", "gt_base_pose0", "data.csv")) as fh:
    rows = [r for r in csv.reader(line for line in fh if not line.startswith("#"))]
gx, gy, gt = (float(v) for v in rows[-1][1:4])
def errors(p):
    d = math.atan2(math.sin(p["theta"] - gt), math.cos(p["theta"] - gt))
    return math.hypot(p["x"] - gx, p["y"] - gy), abs(math.degrees(d))
for name in ("odometry", "corrected"):
    e_pos, e_deg = errors(pose[name])
    print(f"final pose, {name:<9}: {e_pos:.3f} m and {e_deg:.2f} deg from the ground truth")

with open(os.path.join(out, "pmap_end.json")) as fh:
    pm_end = json.load(fh)
with open(os.path.join(out, "pmap_resumed.json")) as fh:
    pm_res = json.load(fh)
with open(os.path.join(out, "status_resumed.json")) as fh:
    res = json.load(fh)
print(f"perceptual map at the end: {len(pm_end['segments'])} segments, path of {len(pm_end['path'])} points")
print(f"resume: serving {resume_s:.2f} s after start, first GetPerceptualMap {resume_pmap_s:.2f} s "
      f"(client round trip), {len(pm_res['segments'])} segments, resumed_unconfirmed "
      f"{str(pm_res.get('resumed_unconfirmed', False)).lower()}, resident {res['resident_mb']:.1f} MB")
EOF
