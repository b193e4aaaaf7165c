#!/usr/bin/env bash
# Installs the dependencies, builds, and runs the whole test suite (unit, integration, e2e).
# Extra arguments go to ctest, e.g. `scripts/test.sh -L unit` for the fast unit tests only.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
./scripts/build.sh
# Tests must not pick up a stray Fast DDS profile from the working directory.
export SKIP_DEFAULT_XML_FILE=1
ctest --test-dir build --output-on-failure -j2 "$@"
