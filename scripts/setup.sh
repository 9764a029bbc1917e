#!/usr/bin/env bash
# First command on a fresh Debian 12 machine: installs the Debian packages,
# builds agvcal, and runs the main job on a bundled sample recording.
#   scripts/setup.sh            (as root, or with sudo available)
#   scripts/setup.sh --no-sample   install and build only
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"

packages=(build-essential cmake pkg-config ccache git iproute2 util-linux procps python3
  liblcm-dev liblcm-bin libglib2.0-dev libeigen3-dev libceres-dev libyaml-cpp-dev
  nlohmann-json3-dev libssl-dev libcli11-dev libgtest-dev libncurses-dev zlib1g-dev libpcl-dev tmux supervisor
  clang libclang-rt-14-dev
  python3-distributed python3-scipy python3-yaml python3-psycopg2 postgresql chromium python3-matplotlib
  libsqlite3-dev libzstd-dev liblz4-dev libssl-dev liburdfdom-dev nodejs
  python3-rosbag python3-sensor-msgs python3-nav-msgs python3-geometry-msgs python3-tf2-msgs
  liblcm-java default-jdk-headless)
sudo=""
[ "$(id -u)" -eq 0 ] || sudo=sudo
missing=()
for p in "${packages[@]}"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
if [ ${#missing[@]} -gt 0 ]; then
  echo "== installing: ${missing[*]}"
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

echo "== building (build/)"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"

[ "${1:-}" = "--no-sample" ] && exit 0

echo "== the bundled sample: logs/forklift_demo.log"
build/agvcal info logs/forklift_demo.log
echo "== re-simulating it: the same config and seed give the same bytes"
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
build/agvcal simulate config/sims/forklift.yaml "$tmp/forklift_demo.log" --trajectory demo
if cmp -s "$tmp/forklift_demo.log" logs/forklift_demo.log; then
  echo "identical to logs/forklift_demo.log"
else
  echo "differs from logs/forklift_demo.log (simulator or configs changed since it was made:" \
       "scripts/make-samples.sh regenerates the samples)" >&2
  exit 1
fi
echo "== calibrating the forklift from it (simulator truth: drive_radius 0.1163, wheelbase 1.4335,"
echo "   steer_offset 0.0131, lidar2d x 1.6152 y 0.0123 yaw -0.0142)"
build/agvcal solve config/robots/forklift.yaml logs/forklift_demo.log --out "$tmp/result.json"
