#!/usr/bin/env bash
# The main job: installs the dependencies, builds, then runs epmapd on the built-in synthetic
# stereo head (epmap-sim publish --scenario head) and a client (epmapctl) that reads the maps
# the service builds and writes them to demo-out/ as files a person can open. Ends by itself
# after about 30 s; --keep-going runs until Ctrl-C.
#
#   scripts/demo.sh [--seconds N] [--keep-going] [--out DIR]
set -euo pipefail
cd "$(dirname "$0")/.."

SECONDS_TO_RUN=30
KEEP_GOING=0
OUT=demo-out
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) SECONDS_TO_RUN="$2"; shift 2 ;;
    --keep-going) KEEP_GOING=1; shift ;;
    --out) OUT="$2"; shift 2 ;;
    -h|--help) sed -n '2,8p' "$0"; exit 0 ;;
    *) echo "demo.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

./scripts/install-deps.sh
./scripts/build.sh

export SKIP_DEFAULT_XML_FILE=1
BIN=build/bin
DOMAIN=${EPMAP_DOMAIN:-42}
PORT=${EPMAP_PORT:-50051}
SERVER=127.0.0.1:$PORT
mkdir -p "$OUT"
rm -f "$OUT"/*.png "$OUT"/*.pfm "$OUT"/*.json "$OUT"/*.txt

PIDS=()
cleanup() {
  for pid in "${PIDS[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap cleanup EXIT INT TERM

echo "== epmapd on 127.0.0.1:$PORT, DDS domain $DOMAIN (log: $OUT/epmapd.log)"
$BIN/epmapd --listen "$SERVER" --domain "$DOMAIN" --urdf clients/sim/urdf/icub_head.urdf \
  > "$OUT/epmapd.log" 2>&1 &
PIDS+=($!)
for _ in $(seq 1 100); do
  $BIN/epmapctl --server "$SERVER" --timeout 1 status > /dev/null 2>&1 && break
  sleep 0.2
done

# The synthetic head publishes at 30 Hz over DDS, as a camera driver and encoders would.
FRAMES=$((SECONDS_TO_RUN * 30))
if [ "$KEEP_GOING" = 1 ]; then FRAMES=100000000; fi
echo "== epmap-sim publish --scenario head ($FRAMES frames at 30 Hz; log: $OUT/sim.log)"
$BIN/epmap-sim publish --scenario head --domain "$DOMAIN" --rate 30 --frames "$FRAMES" \
  > "$OUT/sim.log" 2>&1 &
SIM=$!
PIDS+=($SIM)

# The client: every few seconds, read the maps and write them out.
snapshot() {
  $BIN/epmapctl --server "$SERVER" disparity --out "$OUT/disparity.png" --wait-ms 10000 \
    > /dev/null || return 0
  $BIN/epmapctl --server "$SERVER" disparity --out "$OUT/disparity.pfm" > /dev/null || true
  $BIN/epmapctl --server "$SERVER" status > "$OUT/status.txt" || true
  $BIN/epmapctl --server "$SERVER" status --json > "$OUT/status.json" || true
}
START=$(date +%s)
while kill -0 "$SIM" 2>/dev/null; do
  sleep 5
  snapshot
  echo "   $(( $(date +%s) - START )) s: $(grep -m1 '^frames:' "$OUT/status.txt" 2>/dev/null || echo 'waiting for the first frame')"
done
sleep 1
snapshot

echo
echo "== summary (full status in $OUT/status.txt)"
sed -n '1,6p' "$OUT/status.txt"
echo
echo "maps written to $OUT/:"
ls -1 "$OUT" | grep -E '\.(png|pfm|json)$' | sed 's/^/  /'
