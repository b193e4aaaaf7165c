#!/usr/bin/env bash
# Configures and builds epmap into build/ (binaries in build/bin). Parallel but small (-j2):
# the reference machine has 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build build -j"${EPMAP_JOBS:-2}"
