#!/usr/bin/env bash
# Installs everything epmap needs to build, run and test, from Debian 12 packages.
# Safe to run again: when every package is already there it does nothing.
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake pkg-config git ca-certificates python3
  # the planner-side Python example (clients/python)
  python3-grpcio python3-protobuf
  # middleware: Fast DDS (ROS 2 wire-compatible), gRPC + Protobuf
  libfastrtps-dev libfastcdr-dev fastddsgen fastdds-tools
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  # algorithms
  libopencv-dev libeigen3-dev libnlopt-dev libnlopt-cxx-dev
  liburdfdom-dev liburdfdom-headers-dev liborocos-kdl-dev libkdl-parser-dev
  # service plumbing
  libsqlite3-dev libspdlog-dev libcli11-dev libyaml-cpp-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends "${PACKAGES[@]}"
