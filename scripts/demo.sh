#!/usr/bin/env bash
# The main job: installs the dependencies, builds, then runs epmapd on the built-in synthetic
# stereo head (epmap-sim publish --scenario head) and a client (epmapctl) that reads the maps
# the service builds and writes them to demo-out/ as files a person can open. Ends by itself
# after about 30 s; --keep-going runs until Ctrl-C (the head; the building route has an end).
# --scenario building runs the mobile base instead: a pan-head robot drives ~60 m through the
# synthetic building floor (a person walks along its first corridor) and the client writes the
# maps for planners (perceptual map, occupancy grid, corrected pose); the whole route takes
# about 3 min at the scenario's 10 Hz unless --seconds cuts it short (--route rooms: the route
# that steps into seven of the eight rooms, about 3 min 40 s). The progress line comes
# every 5 s; the pictures are rewritten every --refresh seconds (default 15) and the whole set
# (expectation images, PFM) at the end: the client shares the 2 cores with the service and the
# simulator, and rewriting everything every 5 s made the head's service drop 0-10 of 900 frames.
#
#   scripts/demo.sh [--scenario head|building] [--route corridors|rooms] [--seconds N]
#                   [--refresh S] [--keep-going] [--out DIR]
set -euo pipefail
cd "$(dirname "$0")/.."

SCENARIO="head"
ROUTE=corridors
SECONDS_TO_RUN=
KEEP_GOING=0
REFRESH=15
OUT=demo-out
while [ $# -gt 0 ]; do
  case "$1" in
    --scenario) SCENARIO="$2"; shift 2 ;;
    --route) ROUTE="$2"; shift 2 ;;
    --seconds) SECONDS_TO_RUN="$2"; shift 2 ;;
    --refresh) REFRESH="$2"; shift 2 ;;
    --keep-going) KEEP_GOING=1; shift ;;
    --out) OUT="$2"; shift 2 ;;
    -h|--help) sed -n '2,17p' "$0"; exit 0 ;;
    *) echo "demo.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
case "$SCENARIO" in
  head | building) ;;
  *) echo "demo.sh: --scenario is head or building, not '$SCENARIO'" >&2; exit 2 ;;
esac
case "$ROUTE" in
  corridors | rooms) ;;
  *) echo "demo.sh: --route is corridors or rooms, not '$ROUTE'" >&2; exit 2 ;;
esac
if [ "$ROUTE" != corridors ] && [ "$SCENARIO" != building ]; then
  echo "demo.sh: --route applies to --scenario building only" >&2; exit 2
fi
if [ -n "$SECONDS_TO_RUN" ] && ! [[ "$SECONDS_TO_RUN" =~ ^[1-9][0-9]*$ ]]; then
  echo "demo.sh: --seconds takes a whole number of seconds, not '$SECONDS_TO_RUN'" >&2
  exit 2
fi
if ! [[ "$REFRESH" =~ ^[1-9][0-9]*$ ]]; then
  echo "demo.sh: --refresh takes a whole number of seconds, not '$REFRESH'" >&2
  exit 2
fi

./scripts/install-deps.sh
./scripts/build.sh

export SKIP_DEFAULT_XML_FILE=1
BIN=build/bin
DOMAIN=${EPMAP_DOMAIN:-42}
PORT=${EPMAP_PORT:-50051}
SERVER=127.0.0.1:$PORT
mkdir -p "$OUT"
rm -rf "$OUT"/*.png "$OUT"/*.pfm "$OUT"/*.pgm "$OUT"/*.yaml "$OUT"/*.svg "$OUT"/*.json \
  "$OUT"/*.jsonl "$OUT"/*.txt "$OUT"/expectation

PIDS=()
cleanup() {
  for pid in "${PIDS[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap cleanup EXIT INT TERM

# Both robots publish over DDS at their own rates (the head 30 Hz, the base 10 Hz), as a camera
# driver and encoders would: the stamps are the wall clock, so a faster rate would be a faster
# robot. The head runs 30 s by default; the building robot its whole route (1849 frames, or 2207
# on the rooms route), or --seconds of it (epmap-sim publish --max-frames stops at the route's
# end if that comes first).
if [ "$SCENARIO" = head ]; then
  RATE=30
  URDF=clients/sim/urdf/icub_head.urdf
  # The head's nearest surfaces (~0.38 m at 554 px focal length, 68 mm baseline) need ~100 px.
  EPMAPD_ARGS=(--num-disparities 112)
  SIM_ARGS=()
  FRAMES_ARG=(--frames "$(( ${SECONDS_TO_RUN:-30} * RATE ))")
else
  URDF=clients/sim/urdf/pan_robot.urdf
  EPMAPD_ARGS=()
  # The person walking along the first corridor is what the unexpected-motion detector flags
  # and what the maps leave out.
  SIM_ARGS=(--walker --route "$ROUTE")
  RATE=10
  FRAMES_ARG=(--max-frames "$(( ${SECONDS_TO_RUN:-0} * RATE ))")  # 0: the whole route
fi
if [ "$KEEP_GOING" = 1 ] && [ "$SCENARIO" = head ]; then FRAMES_ARG=(--frames 100000000); fi

echo "== epmapd on 127.0.0.1:$PORT, DDS domain $DOMAIN, $URDF (log: $OUT/epmapd.log)"
$BIN/epmapd --listen "$SERVER" --domain "$DOMAIN" --urdf "$URDF" "${EPMAPD_ARGS[@]}" \
  > "$OUT/epmapd.log" 2>&1 &
PIDS+=("$!")
for _ in $(seq 1 100); do
  $BIN/epmapctl --server "$SERVER" --timeout 1 status > /dev/null 2>&1 && break
  sleep 0.2
done

echo "== epmap-sim publish --scenario $SCENARIO ${SIM_ARGS[*]} ${FRAMES_ARG[*]} at $RATE Hz (log: $OUT/sim.log)"
$BIN/epmap-sim publish --scenario "$SCENARIO" "${SIM_ARGS[@]}" --domain "$DOMAIN" --rate "$RATE" \
  "${FRAMES_ARG[@]}" > "$OUT/sim.log" 2>&1 &
SIM=$!
PIDS+=("$SIM")

# What moves on its own, as it happens: one JSON line per frame with unexpected regions.
$BIN/epmapctl --server "$SERVER" watch-unexpected --min-area 200 > "$OUT/unexpected_events.jsonl" \
  2> "$OUT/watch.log" &
PIDS+=("$!")

# The client: read the maps and write them out ("all": with the expectation images and the PFM).
status() {
  $BIN/epmapctl --server "$SERVER" status > "$OUT/status.txt" || true
}
snapshot() {
  $BIN/epmapctl --server "$SERVER" disparity --out "$OUT/disparity.png" --wait-ms 10000 \
    > /dev/null || return 0
  if [ "${1:-}" = all ]; then
    $BIN/epmapctl --server "$SERVER" disparity --out "$OUT/disparity.pfm" > /dev/null || true
    $BIN/epmapctl --server "$SERVER" expectation --out "$OUT/expectation" \
      > "$OUT/expectation.txt" 2>&1 || true
  fi
  $BIN/epmapctl --server "$SERVER" unexpected --out "$OUT/unexpected.png" > "$OUT/unexpected.txt" \
    2>&1 || true
  if [ "$SCENARIO" = building ]; then
    # The maps for planners (mobile-base mode); before the first key frame they are not there yet.
    for f in pmap.svg pmap.json; do
      $BIN/epmapctl --server "$SERVER" pmap --out "$OUT/$f" > /dev/null 2>&1 || true
    done
    for f in grid.png grid.pgm; do
      $BIN/epmapctl --server "$SERVER" grid --out "$OUT/$f" > /dev/null 2>&1 || true
    done
    # What a local planner polls: the 8 m square around the robot.
    $BIN/epmapctl --server "$SERVER" grid --around-robot 8 --out "$OUT/grid_around_robot.png" \
      > /dev/null 2>&1 || true
    $BIN/epmapctl --server "$SERVER" pmap --around-robot 8 --out "$OUT/pmap_around_robot.svg" \
      > /dev/null 2>&1 || true
    $BIN/epmapctl --server "$SERVER" pose --json > "$OUT/pose.json" 2> /dev/null || true
  fi
  status
  $BIN/epmapctl --server "$SERVER" status --json > "$OUT/status.json" || true
}
START=$(date +%s)
LAST_SNAPSHOT=$START
while kill -0 "$SIM" 2>/dev/null; do
  sleep 5
  if [ $(( $(date +%s) - LAST_SNAPSHOT )) -ge "$REFRESH" ]; then
    snapshot
    LAST_SNAPSHOT=$(date +%s)
  else
    status
  fi
  LINE="$(grep -m1 '^frames:' "$OUT/status.txt" 2>/dev/null || echo 'waiting for the first frame')"
  if [ "$SCENARIO" = building ]; then
    # The maps' progress: key frames taken so far (the pictures follow every --refresh s).
    KEY_FRAMES=$(awk '$1 == "maps_key_frames" {print $2}' "$OUT/status.txt" 2>/dev/null)
    LINE="$LINE; ${KEY_FRAMES:-0} key frames mapped"
  fi
  echo "   $(( $(date +%s) - START )) s: $LINE"
done
sleep 1
snapshot all

echo
echo "== summary (full status in $OUT/status.txt)"
sed -n '1,6p' "$OUT/status.txt"
grep -m1 '^memory:' "$OUT/status.txt" || true
echo
echo "expected perception (paper 000): $(sed 's/^wrote [^ ]* //' "$OUT/expectation.txt" 2>/dev/null)"
echo "unexpected now: $(sed -n 2p "$OUT/unexpected.txt" 2>/dev/null)"
echo "frames with something moving on its own: $(wc -l < "$OUT/unexpected_events.jsonl") (JSON lines in $OUT/unexpected_events.jsonl)"
if [ "$SCENARIO" = building ]; then
  echo
  echo "maps events: $(grep -E '^ +(maps_key_frames|maps_correlation_shifts|maps_heading_turns|maps_key_frame_motion_masked|ros_map_published|ros_perceptual_map_published|ros_tf_published) ' \
    "$OUT/status.txt" | awk '{printf "%s%s %s", sep, $1, $2; sep=", "}')"
  echo "pose (odometry, corrected, difference): $(tr -d '\n ' < "$OUT/pose.json" 2>/dev/null)"
  # The perceptual map as GetPerceptualMap served it, and what a planner client reads of the
  # grid (clients/python/epmap_planner.py, the remote-planner example).
  /usr/bin/python3 - "$OUT/pmap.json" <<'PY' || true
import json, math, sys
m = json.load(open(sys.argv[1]))
length = sum(math.hypot(s["x2"] - s["x1"], s["y2"] - s["y1"]) for s in m["segments"])
print("perceptual map: %d segments, %.0f m of them, %d views on a path of %d points" %
      (len(m["segments"]), length, len(m.get("views", [])), len(m.get("path", []))))
PY
  /usr/bin/python3 clients/python/epmap_planner.py --server "$SERVER" > "$OUT/planner.json" \
    2> "$OUT/planner.log" || true
  /usr/bin/python3 - "$OUT/planner.json" <<'PY' || true
import json, sys
g = json.load(open(sys.argv[1]))["map"]
print("planner client: grid %dx%d cells of %.2f m, %d known, %d occupied; free %.2f m straight "
      "ahead of the corrected pose (ends: %s)" % (g["width"], g["height"], g["resolution_m"],
      g["known_cells"], g["occupied_cells"], g["free_ahead_m"], g["free_ahead_ends"]))
PY
fi
echo
echo "maps written to $OUT/:"
for f in "$OUT"/*.{png,pfm,pgm,yaml,svg,json,jsonl} "$OUT"/expectation/*.png; do
  if [ -e "$f" ]; then echo "  ${f#"$OUT"/}"; fi
done
