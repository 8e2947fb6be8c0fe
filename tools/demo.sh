#!/usr/bin/env bash
# The main job: set up, build the host tools, and calibrate the bundled simulated recording
# (raw 16-bit counts, known truth) in float, as on the device, and in double as the reference.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup_debian.sh
cmake --preset host >/dev/null
cmake --build --preset host --target imucal_poses
build/host/tools/imucal_poses calibrate data/simulated_poses_raw_counts.csv
