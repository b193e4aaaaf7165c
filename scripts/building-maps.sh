#!/usr/bin/env bash
# Issue 6's figures on the four building runs that perception/mobile_mapping/README.md quotes
# (forward, reverse, seed 7, seed 11): records each dataset once (about 17 s each), runs
# `epmap-bench maps` on it, two at a time, and prints one line per run plus the mean. One run's
# map figures swing with a single correlation alias or view placement, so compare the means.
# Needs a build (scripts/build.sh). Extra arguments go to `epmap-bench maps`, e.g.
# --no-map-correlation or --reject-contested. --route rooms records the route that steps into
# seven of the eight rooms (epmap-sim --route) instead of the default corridors route.
# --odometry-scale-error E records odometry that under-counts the distance by E (epmap-sim's
# option of that name; the datasets and outputs get an -se<E> suffix). --true-depth records
# the true disparity of every frame and gives the maps their points' true depths (epmap-bench
# maps --true-depth: what the stereo's depth error costs; datasets and outputs get -td).
#
#   scripts/building-maps.sh [--work DIR] [--tag NAME] [--route corridors|rooms]
#                            [--odometry-scale-error E] [--true-depth] [-- BENCH ARGS...]
set -euo pipefail
cd "$(dirname "$0")/.."

WORK=building-maps
TAG=default
ROUTE=corridors
SCALE_ERROR=
TRUE_DEPTH=
while [ $# -gt 0 ]; do
  case "$1" in
    --work) WORK="$2"; shift 2 ;;
    --tag) TAG="$2"; shift 2 ;;
    --route) ROUTE="$2"; shift 2 ;;
    --odometry-scale-error) SCALE_ERROR="$2"; shift 2 ;;
    --true-depth) TRUE_DEPTH=1; shift ;;
    --) shift; break ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "building-maps.sh: unknown argument $1 (bench arguments go after --)" >&2; exit 2 ;;
  esac
done
BIN=build/bin
for tool in epmap-sim epmap-bench; do
  [ -x "$BIN/$tool" ] || { echo "building-maps.sh: $BIN/$tool missing: run scripts/build.sh" >&2; exit 1; }
done

declare -A RECORD_ARGS=([fwd]="" [rev]="--reverse" [s7]="--seed 7" [s11]="--seed 11")
RUNS=(fwd rev s7 s11)
# The corridors route's datasets keep their old names (data-fwd, ...).
DATA=data
[ "$ROUTE" = corridors ] || { DATA="data-$ROUTE"; TAG="$TAG-$ROUTE"; }
SIM_ARGS=()
if [ -n "$SCALE_ERROR" ]; then
  DATA="$DATA-se$SCALE_ERROR"; TAG="$TAG-se$SCALE_ERROR"
  SIM_ARGS=(--odometry-scale-error "$SCALE_ERROR")
fi
BENCH_ARGS=()
if [ -n "$TRUE_DEPTH" ]; then
  DATA="$DATA-td"; TAG="$TAG-td"
  SIM_ARGS+=(--disparity-every-frame)
  BENCH_ARGS=(--true-depth)
fi
mkdir -p "$WORK"
for run in "${RUNS[@]}"; do
  if [ ! -d "$WORK/$DATA-$run/mav0" ]; then
    echo "recording $run ($ROUTE route) ..."
    # shellcheck disable=SC2086  # the record arguments are words
    "$BIN/epmap-sim" record --scenario building --route "$ROUTE" ${RECORD_ARGS[$run]} \
      "${SIM_ARGS[@]}" --out "$WORK/$DATA-$run" > "$WORK/record-$DATA-$run.log" 2>&1
  fi
done

bench() {
  local run=$1; shift
  "$BIN/epmap-bench" maps --dataset "$WORK/$DATA-$run" --out "$WORK/$TAG-$run" --json \
    --no-variants "${BENCH_ARGS[@]}" "$@" > "$WORK/$TAG-$run.json" 2> "$WORK/$TAG-$run.log"
}
for pair in "fwd rev" "s7 s11"; do
  pids=()
  for run in $pair; do bench "$run" "$@" & pids+=($!); done
  for pid in "${pids[@]}"; do wait "$pid"; done
done

# The JSON is one line: pick a number by its key (the first occurrence, or the one after a
# given block key).
value() { grep -o "\"$2\":[-0-9.]*" "$1" | head -1 | cut -d: -f2; }
after() { sed "s/.*\"$2\"://" "$1" | grep -o "\"$3\":[-0-9.]*" | head -1 | cut -d: -f2; }

printf '%-5s %9s %9s %8s %8s %9s %10s %12s\n' run heading° coverage seen stray grid_iou iou_seen ms/keyframe
for run in "${RUNS[@]}"; do
  j="$WORK/$TAG-$run.json"
  printf '%-5s %9s %9s %8s %8s %9s %10s %12s\n' "$run" \
    "$(value "$j" corrected_final_error_deg)" "$(value "$j" wall_coverage_0p5m)" \
    "$(value "$j" seen_wall_coverage_0p5m)" "$(value "$j" stray_share_1m)" \
    "$(after "$j" corrected iou)" "$(after "$j" corrected iou_observed)" \
    "$(value "$j" per_key_frame_ms_median)"
done | tee "$WORK/$TAG-summary.txt"
awk '{c+=$3; s+=$5; g+=$6; i+=$7; n++} END {printf "mean  coverage %.4f  stray %.4f  grid IoU %.4f (over seen cells %.4f)\n", c/n, s/n, g/n, i/n}' \
  "$WORK/$TAG-summary.txt"
echo "outputs (pmap.svg, grid.png, figures.json, ...) in $WORK/$TAG-<run>/"
